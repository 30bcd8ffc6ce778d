// ModelBasedTracking on rendered sequences with known poses: both DFIs follow a moving target
// (mono), EdgeTracker fuses a stereo pair and carries on without a jump when one camera goes dark
// or misses frames; faults are errors with a clear message and lost tracks a status, never a
// crash.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "EstimationFilter.gen.hpp"
#include "ModelBasedTracking.gen.hpp"
#include "support/dfn_testing.hpp"
#include "support/model_rendering.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr int kTracking = static_cast<int>(TrackingStatus::kTracking);
constexpr int kDegraded = static_cast<int>(TrackingStatus::kDegraded);
constexpr int kLost = static_cast<int>(TrackingStatus::kLost);

std::unique_ptr<ModelBasedTracking> make(const std::string& dfi, const std::string& yaml = "{}") {
  return testing::makeDfn<ModelBasedTracking>("ModelBasedTracking", dfi, yaml);
}

// A target 0.5 m in front of the left camera drifting and turning a little each frame; the right
// camera 12 cm to the right.
struct Sequence {
  CameraModel camera = testing::pinholeCamera(640, 480, 600);
  PolygonModel model = testing::lShapeModel(0.08);
  Eigen::Isometry3d right_T_left = [] {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.translation() << -0.12, 0, 0;
    return t;
  }();

  Eigen::Isometry3d truth(int k) const {
    Eigen::Isometry3d start = testing::lookAt({0.3, -0.35, 0.22}, Eigen::Vector3d::Zero());
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    step.translation() << 0.0015 * k, -0.001 * k, -0.002 * k;
    step.linear() =
        expSO3(Eigen::Vector3d(0.2, 1.0, 0.4).normalized() * (0.006 * k)).toRotationMatrix();
    return step * start;  // left_T_model
  }

  Image image(const Eigen::Isometry3d& camera_T_model, int k, double gain = 1.0) const {
    testing::RenderOptions o;
    o.noise_sigma = 2.0;
    o.seed = static_cast<std::uint32_t>(k + 1);
    o.gain = gain;
    Image image = testing::toImage(testing::renderModel(model, camera, camera_T_model, o));
    image.camera = camera;
    image.stamp = static_cast<Timestamp>(k) * 100000;
    return image;
  }
};

PoseWithCovariance prediction(const Eigen::Isometry3d& pose) {
  PoseWithCovariance p;
  p.pose = Transform::fromIsometry(pose, "left", "model");
  return p;
}

double translationError(const PoseWithCovariance& p, const Eigen::Isometry3d& truth) {
  return (p.pose.translation - truth.translation()).norm();
}
double angleError(const PoseWithCovariance& p, const Eigen::Isometry3d& truth) {
  return angularDistance(p.pose.rotation, Eigen::Quaterniond(truth.linear()));
}

void trackMono(const std::string& dfi, const std::string& yaml, double max_translation,
               double max_angle) {
  const Sequence seq;
  auto node = make(dfi, yaml);
  node->in.model.set(seq.model);
  Eigen::Isometry3d pose = seq.truth(0);
  double worst_t = 0, worst_a = 0;
  for (int k = 0; k < 15; ++k) {
    node->in.image.set(seq.image(seq.truth(k), k));
    node->in.predicted_pose.set(prediction(pose));
    ASSERT_OK(node->process());
    ASSERT_EQ(*node->out.status, kTracking) << "frame " << k;
    pose = node->out.pose->pose.isometry();
    worst_t = std::max(worst_t, translationError(*node->out.pose, seq.truth(k)));
    worst_a = std::max(worst_a, angleError(*node->out.pose, seq.truth(k)));
  }
  ::testing::Test::RecordProperty("max_translation_error_mm", std::to_string(worst_t * 1e3));
  ::testing::Test::RecordProperty("max_angle_error_deg", std::to_string(worst_a * 180 / M_PI));
  EXPECT_LT(worst_t, max_translation);
  EXPECT_LT(worst_a, max_angle);
}

// 0.5 m away at 600 px focal length a pixel spans 0.8 mm: sub-pixel edges give sub-millimetre
// poses.
TEST(ModelBasedTracking, EdgeTrackerFollowsAMonoSequence) {
  trackMono("EdgeTracker", "{}", 0.0005, 0.05 * M_PI / 180);
}

TEST(ModelBasedTracking, VispMbtFollowsTheSameSequence) {
  trackMono("VispMbt", "{me_range: 12}", 0.003, 0.5 * M_PI / 180);
}

TEST(ModelBasedTracking, VispMbtScalesItsMovingEdgeSettingsToTheImageWidth) {
  // The settings declared for images half as wide: ViSP gets them doubled (10 px sample step,
  // +-24 px search, 11 px masks) and still follows the sequence (0.64 deg at worst, coarser than
  // with its 640 px settings), from about half as many moving edges. Declared for the images'
  // own width, or 0, they are used as given.
  trackMono("VispMbt", "{me_range: 12, pixel_settings_width: 320}", 0.003, 1.0 * M_PI / 180);
  const Sequence seq;
  const auto features = [&](const std::string& yaml) {
    auto node = make("VispMbt", yaml);
    node->in.model.set(seq.model);
    node->in.image.set(seq.image(seq.truth(0), 0));
    node->in.predicted_pose.set(prediction(seq.truth(0)));
    EXPECT_OK(node->process());
    return *node->out.feature_count;
  };
  const int given = features("{pixel_settings_width: 0}");
  EXPECT_EQ(features("{pixel_settings_width: 640}"), given);
  const int scaled = features("{pixel_settings_width: 320}");
  EXPECT_GT(given, 40);
  EXPECT_NEAR(static_cast<double>(scaled) / given, 0.5, 0.15) << scaled << " of " << given;
}

TEST(ModelBasedTracking, EdgeTrackerStereoCarriesOnWhenACameraFails) {
  const Sequence seq;
  auto node = make("EdgeTracker");
  node->in.model.set(seq.model);
  Eigen::Isometry3d pose = seq.truth(0);
  double previous_error = -1;
  for (int k = 0; k < 18; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    const bool dark = k >= 5 && k < 10;      // right camera under-exposed
    const bool missing = k >= 12 && k < 15;  // right camera drops frames
    StereoImagePair pair;
    pair.left = seq.image(seq.truth(k), k);
    pair.right =
        missing ? Image{} : seq.image(seq.right_T_left * seq.truth(k), 100 + k, dark ? 0.03 : 1.0);
    pair.right.frame_id = "right";
    pair.right_T_left = Transform::fromIsometry(seq.right_T_left, "right", "left");
    node->in.stereo_images.set(pair);
    node->in.predicted_pose.set(prediction(pose));
    ASSERT_OK(node->process());
    EXPECT_EQ(*node->out.status, dark || missing ? kDegraded : kTracking);
    pose = node->out.pose->pose.isometry();
    const double error = translationError(*node->out.pose, seq.truth(k));
    EXPECT_LT(error, 0.0005);
    EXPECT_LT(angleError(*node->out.pose, seq.truth(k)), 0.05 * M_PI / 180);
    // No jump: consecutive errors differ by much less than a pixel's worth (0.8 mm).
    if (previous_error >= 0) {
      EXPECT_LT(std::abs(error - previous_error), 0.0003);
    }
    previous_error = error;
  }
}

TEST(ModelBasedTracking, VispMbtTracksAStereoPair) {
  const Sequence seq;
  auto node = make("VispMbt", "{me_range: 12}");
  node->in.model.set(seq.model);
  Eigen::Isometry3d pose = seq.truth(0);
  for (int k = 0; k < 10; ++k) {
    StereoImagePair pair;
    pair.left = seq.image(seq.truth(k), k);
    pair.right = seq.image(seq.right_T_left * seq.truth(k), 100 + k);
    pair.right.frame_id = "right";
    pair.right_T_left = Transform::fromIsometry(seq.right_T_left, "right", "left");
    node->in.stereo_images.set(pair);
    node->in.predicted_pose.set(prediction(pose));
    ASSERT_OK(node->process());
    ASSERT_EQ(*node->out.status, kTracking) << "frame " << k;
    pose = node->out.pose->pose.isometry();
    EXPECT_LT(translationError(*node->out.pose, seq.truth(k)), 0.003) << "frame " << k;
    EXPECT_LT(angleError(*node->out.pose, seq.truth(k)), 0.5 * M_PI / 180) << "frame " << k;
  }
}

TEST(ModelBasedTracking, ADepthMapJoinsTheEdgeTrackerEstimate) {
  const Sequence seq;
  auto node = make("EdgeTracker");
  node->in.model.set(seq.model);
  const Eigen::Isometry3d truth = seq.truth(3);
  Eigen::Isometry3d predicted = truth;
  predicted.translation() += Eigen::Vector3d(0.002, -0.001, 0.003);
  DepthMap depth;
  depth.image = testing::toImage(testing::renderDepth(seq.model, seq.camera, truth));
  depth.image.camera = seq.camera;
  node->in.image.set(seq.image(truth, 3));
  node->in.depth.set(depth);
  node->in.predicted_pose.set(prediction(predicted));
  ASSERT_OK(node->process());
  EXPECT_EQ(*node->out.status, kTracking);
  EXPECT_LT(translationError(*node->out.pose, truth), 0.0003);
  EXPECT_LT(angleError(*node->out.pose, truth), 0.05 * M_PI / 180);
  EXPECT_GT(*node->out.feature_count, 1000) << "depth points count as features";
}

class BadInput : public ::testing::TestWithParam<const char*> {};

TEST_P(BadInput, ABlackImageIsALostTrackNotACrash) {
  const Sequence seq;
  auto node = make(GetParam());
  node->in.model.set(seq.model);
  node->in.image.set(seq.image(seq.truth(0), 0, 0.0));
  node->in.predicted_pose.set(prediction(seq.truth(0)));
  ASSERT_OK(node->process());
  EXPECT_EQ(*node->out.status, kLost);
  EXPECT_LT(translationError(*node->out.pose, seq.truth(0)), 1e-12) << "lost: the prediction";
  EXPECT_GE(node->diagnostics().warning_count, 1u);
}

TEST_P(BadInput, APoseBehindTheCameraIsALostTrack) {
  const Sequence seq;
  auto node = make(GetParam());
  node->in.model.set(seq.model);
  node->in.image.set(seq.image(seq.truth(0), 0));
  Eigen::Isometry3d behind = seq.truth(0);
  behind.translation().z() = -0.5;
  node->in.predicted_pose.set(prediction(behind));
  ASSERT_OK(node->process());
  EXPECT_EQ(*node->out.status, kLost);
  ASSERT_FALSE(node->diagnostics().warnings.empty());
}

TEST_P(BadInput, AnImageOfTheWrongSizeIsRejected) {
  const Sequence seq;
  auto node = make(GetParam());
  node->in.model.set(seq.model);
  Image image = testing::toImage(cv::Mat(240, 320, CV_8UC1, cv::Scalar(0)));
  image.camera = seq.camera;  // 640x480 calibration on a 320x240 image
  node->in.image.set(image);
  node->in.predicted_pose.set(prediction(seq.truth(0)));
  testing::expectRejected(*node, "input 'image'");
  const Status s = node->diagnostics().last_status;
  EXPECT_NE(s.message().find("640x480"), std::string::npos) << s.toString();
}

TEST_P(BadInput, MissingOrConflictingInputsAreRejected) {
  const Sequence seq;
  auto node = make(GetParam());
  node->in.image.set(seq.image(seq.truth(0), 0));
  node->in.predicted_pose.set(prediction(seq.truth(0)));
  testing::expectRejected(*node, "no model");
  node->in.model.set(seq.model);
  Image uncalibrated = seq.image(seq.truth(0), 0);
  uncalibrated.camera.reset();
  node->in.image.set(uncalibrated);
  testing::expectRejected(*node, "has no camera model");
  StereoImagePair pair;
  pair.left = pair.right = seq.image(seq.truth(0), 0);
  node->in.image.set(seq.image(seq.truth(0), 0));
  node->in.stereo_images.set(pair);
  testing::expectRejected(*node, "both 'image' and 'stereo_images' are set");
}

TEST_P(BadInput, AModelFileWithErrorsNamesTheLine) {
  const auto path = std::filesystem::temp_directory_path() /
                    (std::string("cdff_broken_model_") + GetParam() + ".cao");
  std::ofstream(path) << "V1\n# points\n3\n0 0 0\n1 0 0\n0 one 0\n0\n0\n1\n3 0 1 2\n";
  auto node = Registry::instance().createAs<ModelBasedTracking>("ModelBasedTracking", GetParam());
  ASSERT_TRUE(node.isOk());
  const Status s = node.value()->configure(YAML::Load("{model_file: " + path.string() + "}"));
  std::filesystem::remove(path);
  EXPECT_EQ(s.code(), StatusCode::kCorruptData) << s.toString();
  EXPECT_NE(s.message().find(path.string() + ":6:"), std::string::npos) << s.toString();
  EXPECT_NE(s.message().find("'one' is not a number"), std::string::npos) << s.toString();
}

INSTANTIATE_TEST_SUITE_P(BothImplementations, BadInput,
                         ::testing::Values("EdgeTracker", "VispMbt"));

TEST(ModelBasedTracking, TheModelCanComeFromItsFile) {
  const Sequence seq;
  const auto path = std::filesystem::temp_directory_path() / "cdff_l_shape.cao";
  ASSERT_OK(writeCao(seq.model, path.string()));
  auto node = make("EdgeTracker", "{model_file: " + path.string() + "}");
  std::filesystem::remove(path);
  node->in.image.set(seq.image(seq.truth(0), 0));
  Eigen::Isometry3d predicted = seq.truth(0);
  predicted.translation().x() += 0.002;
  node->in.predicted_pose.set(prediction(predicted));
  ASSERT_OK(node->process());
  EXPECT_EQ(*node->out.status, kTracking);
  EXPECT_LT(translationError(*node->out.pose, seq.truth(0)), 0.0005);
}

// The chain of the visual tracking DFPC: EstimationFilter predicts to the image time, the tracker
// measures from that prediction, the filter corrects with the measurement. The ports connect
// as they are (type-erased, as the DFPC layer connects them), and the filtered state follows the
// target, with its velocity, while the tracker reports lost frames that the filter then skips.
TEST(ModelBasedTracking, ChainsWithTheEstimationFilter) {
  const Sequence seq;
  auto tracker = make("EdgeTracker");
  auto filter = testing::makeDfn<EstimationFilter>(
      "EstimationFilter", "ExtendedKalman",
      "{linear_acceleration_psd: 1.0e-6, angular_acceleration_psd: 1.0e-6}");
  tracker->in.model.set(seq.model);
  PoseWithCovariance first;
  first.pose = Transform::fromIsometry(seq.truth(0), "left", "model");
  first.covariance = Matrix6d::Identity() * 1e-6;
  filter->in.pose_measurement.set(first);
  ASSERT_OK(filter->process());
  const auto connect = [](dfn::OutputPortBase* from, dfn::InputPortBase* to) {
    ASSERT_NE(from, nullptr);
    ASSERT_NE(to, nullptr);
    ASSERT_OK(to->setAny(from->anyValue()));
  };
  int fused = 0;
  for (int k = 1; k < 12; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    const bool dark = k == 6;
    Image image = seq.image(seq.truth(k), k, dark ? 0.0 : 1.0);
    filter->in.time.set(image.stamp);
    ASSERT_OK(filter->process());
    connect(filter->findOutput("state"), tracker->findInput("predicted_state"));
    tracker->in.image.set(image);
    ASSERT_OK(tracker->process());
    // The filter's first prediction carries an unknown velocity: its spread in the image exceeds
    // the search, so frame 1 is an acquisition, DEGRADED (ACQUIRING) until frame 2 confirms it.
    EXPECT_EQ(*tracker->out.status, dark ? kLost : k == 1 ? kDegraded : kTracking);
    if (k == 1) {
      EXPECT_EQ(*tracker->out.track_state, TrackState::kAcquiring);
    }
    if (*tracker->out.status == kLost) continue;  // the DFPC's gate
    connect(tracker->findOutput("pose"), filter->findInput("pose_measurement"));
    ASSERT_OK(filter->process());
    ++fused;
    const RigidBodyState& state = *filter->out.state;
    EXPECT_LT((state.pose.translation - seq.truth(k).translation()).norm(), 0.001);
  }
  EXPECT_EQ(fused, 10);
  // The sequence moves 1.5, -1, -2 mm per frame (plus the rotation's effect on the origin) at
  // 10 frames/s: the filter has picked up a velocity of the right size.
  const double speed = filter->out.state->twist.linear.norm();
  const double true_speed = (seq.truth(11).translation() - seq.truth(10).translation()).norm() * 10;
  EXPECT_NEAR(speed, true_speed, 0.3 * true_speed);
}

// A state older than the image is predicted to the image's time with its twist (the filter's
// constant-velocity mean), so that a DFPC can feed back the previous frame's corrected state.
TEST(ModelBasedTracking, APredictedStateIsMovedToTheImageTimeWithItsTwist) {
  const Sequence seq;
  auto node = make("EdgeTracker");
  node->in.model.set(seq.model);
  // The state 0.1 s before frame 3, moving so that it reaches frame 3's pose at the image time.
  const Eigen::Isometry3d truth = seq.truth(3);
  RigidBodyState state;
  state.pose = Transform::fromIsometry(truth, "left", "model", 200000);
  state.twist.linear = Eigen::Vector3d(0.08, -0.05, 0.03);  // m/s
  state.twist.angular = Eigen::Vector3d(0.2, 0.1, -0.3);    // rad/s
  state.pose.translation -= state.twist.linear * 0.1;
  state.pose.rotation = expSO3(-state.twist.angular * 0.1) * state.pose.rotation;
  node->in.predicted_state.set(state);
  node->in.image.set(seq.image(truth, 3));  // stamp 0.3 s
  ASSERT_OK(node->process());
  ASSERT_EQ(*node->out.status, kTracking);
  EXPECT_EQ(*node->out.track_state, TrackState::kTracking);
  EXPECT_EQ(node->out.pose->pose.stamp, 300000);
  EXPECT_LT(translationError(*node->out.pose, truth), 0.0005);
  // Without the twist the same state is 8 mm and 2 deg off: beyond a direct search
  // (search_distance 8 px), so the tracker would not have found the edges.
  EXPECT_GT((state.pose.translation - truth.translation()).norm(), 0.009);
}

// Acquisition: from the true pose perturbed by 5 % of the range and 5 degrees, with a covariance
// that says so, coarse-to-fine passes bring the first frame to the accuracy of tracking.
TEST(ModelBasedTracking, EdgeTrackerAcquiresFromAnUncertainInitialPose) {
  const Sequence seq;
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  int acquired = 0;
  for (int trial = 0; trial < 5; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    auto node = make("EdgeTracker");
    node->in.model.set(seq.model);
    const Eigen::Isometry3d truth = seq.truth(0);
    const double offset = 0.05 * truth.translation().norm();
    const Eigen::Vector3d dt = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized() * offset;
    const Eigen::Vector3d dr =
        Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized() * (5.0 * M_PI / 180);
    Eigen::Isometry3d start = truth;
    start.translation() += dt;
    start.linear() = expSO3(dr).toRotationMatrix() * truth.linear();
    PoseWithCovariance p = prediction(start);
    p.covariance.diagonal() << Eigen::Vector3d::Constant(offset * offset),
        Eigen::Vector3d::Constant(std::pow(5.0 * M_PI / 180, 2));
    node->in.predicted_pose.set(p);
    node->in.image.set(seq.image(truth, 0));
    ASSERT_OK(node->process());
    if (*node->out.status == kLost) continue;
    ++acquired;
    EXPECT_LT(translationError(*node->out.pose, truth), 0.0005);
    EXPECT_LT(angleError(*node->out.pose, truth), 0.1 * M_PI / 180);
  }
  EXPECT_EQ(acquired, 5);
  // Without the covariance the same tracker searches only search_distance and does not recover.
  auto node = make("EdgeTracker", "{acquisition_sigmas: 0}");
  node->in.model.set(seq.model);
  Eigen::Isometry3d start = seq.truth(0);
  start.translation() += Eigen::Vector3d(0.02, -0.015, 0.01);
  node->in.predicted_pose.set(prediction(start));
  node->in.image.set(seq.image(seq.truth(0), 0));
  ASSERT_OK(node->process());
  EXPECT_TRUE(*node->out.status == kLost ||
              translationError(*node->out.pose, seq.truth(0)) > 0.002);
}

// The coarse alignment needs edges to align with: in a black image (a back-lit target against
// black space) it is skipped, which the LOST reason says, while in the lit image of the same
// uncertain start it runs and the acquisition succeeds.
TEST(ModelBasedTracking, EdgeTrackerSkipsTheCoarseSearchWithoutEdgesToSupportIt) {
  const Sequence seq;
  const Eigen::Isometry3d truth = seq.truth(0);
  const double offset = 0.05 * truth.translation().norm();
  Eigen::Isometry3d start = truth;
  start.translation() += Eigen::Vector3d(0.6, -0.8, 0).normalized() * offset;
  start.linear() =
      expSO3(Eigen::Vector3d(0, 0, 3.0 * M_PI / 180)).toRotationMatrix() * truth.linear();
  PoseWithCovariance p = prediction(start);
  p.covariance.diagonal() << Eigen::Vector3d::Constant(offset * offset),
      Eigen::Vector3d::Constant(std::pow(5.0 * M_PI / 180, 2));
  for (const double brightness : {0.0, 1.0}) {
    SCOPED_TRACE("brightness " + std::to_string(brightness));
    auto node = make("EdgeTracker", "{acquisition_coarse_search: true}");
    node->in.model.set(seq.model);
    node->in.predicted_pose.set(p);
    node->in.image.set(seq.image(truth, 0, brightness));
    ASSERT_OK(node->process());
    const std::deque<std::string>& warnings = node->diagnostics().warnings;
    const bool skipped =
        !warnings.empty() && warnings.back().find("coarse alignment skipped") != std::string::npos;
    if (brightness == 0) {
      EXPECT_EQ(*node->out.status, kLost);
      EXPECT_TRUE(skipped) << (warnings.empty() ? "no warning" : warnings.back());
    } else {
      EXPECT_NE(*node->out.status, kLost);
      EXPECT_FALSE(skipped);
      EXPECT_LT(translationError(*node->out.pose, truth), 0.0005);
    }
  }
}

// An acquired pose is not yet a track: DEGRADED (ACQUIRING) until the next frame confirms it. A
// next frame whose estimate its prediction does not admit (here a prediction 3 mm off with a
// covariance of 0.1 mm, where the tracked pose returns to the truth) is LOST, and the frame after
// it acquires again from the acquisition's wide covariance even though its own prediction is
// narrow; a prediction that admits the estimate confirms it.
TEST(ModelBasedTracking, EdgeTrackerConfirmsAnAcquisitionWithTheNextFrame) {
  const Sequence seq;
  const auto narrow = [](const Eigen::Isometry3d& pose) {
    PoseWithCovariance p = prediction(pose);
    p.covariance = Matrix6d::Identity() * 1e-8;
    return p;
  };
  const auto acquireFirstFrame = [&](dfn::ModelBasedTracking& node) {
    const Eigen::Isometry3d truth = seq.truth(0);
    const double offset = 0.05 * truth.translation().norm();
    Eigen::Isometry3d start = truth;
    start.translation() += Eigen::Vector3d(0.6, -0.8, 0.0) * offset;
    start.linear() =
        expSO3(Eigen::Vector3d(0, 0, 5.0 * M_PI / 180)).toRotationMatrix() * truth.linear();
    PoseWithCovariance p = prediction(start);
    p.covariance.diagonal() << Eigen::Vector3d::Constant(offset * offset),
        Eigen::Vector3d::Constant(std::pow(5.0 * M_PI / 180, 2));
    node.in.predicted_pose.set(p);
    node.in.image.set(seq.image(truth, 0));
    ASSERT_OK(node.process());
    EXPECT_EQ(*node.out.status, kDegraded);
    EXPECT_EQ(*node.out.track_state, TrackState::kAcquiring);
    EXPECT_LT(translationError(*node.out.pose, truth), 0.0005);
  };
  {
    auto node = make("EdgeTracker");
    node->in.model.set(seq.model);
    acquireFirstFrame(*node);
    node->in.predicted_pose.set(narrow(seq.truth(1)));
    node->in.image.set(seq.image(seq.truth(1), 1));
    ASSERT_OK(node->process());
    EXPECT_EQ(*node->out.status, kTracking);
    EXPECT_EQ(*node->out.track_state, TrackState::kTracking);
  }
  auto node = make("EdgeTracker");
  node->in.model.set(seq.model);
  acquireFirstFrame(*node);
  Eigen::Isometry3d off = seq.truth(1);
  off.translation().x() += 0.003;
  node->in.predicted_pose.set(narrow(off));
  node->in.image.set(seq.image(seq.truth(1), 1));
  ASSERT_OK(node->process());
  EXPECT_EQ(*node->out.status, kLost);
  EXPECT_EQ(*node->out.track_state, TrackState::kLost);
  node->in.predicted_pose.set(narrow(seq.truth(2)));
  node->in.image.set(seq.image(seq.truth(2), 2));
  ASSERT_OK(node->process());
  EXPECT_EQ(*node->out.track_state, TrackState::kAcquiring);
  EXPECT_LT(translationError(*node->out.pose, seq.truth(2)), 0.0005);
}

TEST(ModelBasedTracking, ExactlyOnePredictionIsExpected) {
  const Sequence seq;
  auto node = make("EdgeTracker");
  node->in.model.set(seq.model);
  node->in.image.set(seq.image(seq.truth(0), 0));
  testing::expectRejected(*node, "no prediction");
  node->in.predicted_pose.set(prediction(seq.truth(0)));
  RigidBodyState state;
  state.pose = prediction(seq.truth(0)).pose;
  node->in.predicted_state.set(state);
  testing::expectRejected(*node, "both 'predicted_pose' and 'predicted_state' are set");
}

// The coarse alignment's Canny threshold: a threshold of 0 would make every pixel with any
// gradient an edge, one above 680 (the high threshold above the largest 3x3 Sobel L1 norm of an
// 8-bit image) no pixel; both are refused at configure time with the value and the bounds.
TEST(ModelBasedTracking, ACoarseSearchCannyThresholdOutOfRangeIsRejected) {
  auto node =
      dfn::Registry::instance().createAs<ModelBasedTracking>("ModelBasedTracking", "EdgeTracker");
  ASSERT_TRUE(node.isOk()) << node.status().toString();
  for (const std::string value : {"0", "681", "-5"}) {
    const Status s = node.value()->configure(
        YAML::Load("{acquisition_coarse_search: true, acquisition_canny_low: " + value + "}"));
    EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << s.toString();
    EXPECT_NE(s.message().find("acquisition_canny_low = " + value +
                               ": out of range; expected a number in [1, 680] grey levels/px"),
              std::string::npos)
        << s.message();
  }
  EXPECT_TRUE(node.value()
                  ->configure(YAML::Load("{acquisition_coarse_search: true, "
                                         "acquisition_canny_low: 35}"))
                  .isOk());
  // The threshold is the search's: at the largest one the lit image of an uncertain start has no
  // edges left to align with, and the search is skipped (see the test below at the default, 20).
  const Sequence seq;
  const Eigen::Isometry3d truth = seq.truth(0);
  const double offset = 0.05 * truth.translation().norm();
  Eigen::Isometry3d start = truth;
  start.translation() += Eigen::Vector3d(0.6, -0.8, 0).normalized() * offset;
  PoseWithCovariance p = prediction(start);
  p.covariance.diagonal() << Eigen::Vector3d::Constant(offset * offset),
      Eigen::Vector3d::Constant(std::pow(5.0 * M_PI / 180, 2));
  auto strict =
      make("EdgeTracker", "{acquisition_coarse_search: true, acquisition_canny_low: 680}");
  strict->in.model.set(seq.model);
  strict->in.predicted_pose.set(p);
  strict->in.image.set(seq.image(truth, 0));
  ASSERT_OK(strict->process());
  bool skipped = false;
  for (const std::string& w : strict->diagnostics().warnings)
    skipped = skipped || w.find("coarse alignment skipped: 0 edge pixels") != std::string::npos;
  EXPECT_TRUE(skipped) << "the acquisition frame's reason does not name the skipped search";
}

TEST(ModelBasedTracking, VispMbtNeedsTheDepthItsModeUses) {
  const Sequence seq;
  auto node = make("VispMbt", "{mode: edges_depth}");
  node->in.model.set(seq.model);
  node->in.image.set(seq.image(seq.truth(0), 0));
  node->in.predicted_pose.set(prediction(seq.truth(0)));
  testing::expectRejected(*node, "mode 'edges_depth' needs the 'depth' input");
}

}  // namespace
}  // namespace cdff::dfn
