// EdgePoseEstimation/RobustGaussNewton, fed by the real chain of DFNs (VisibilityDetermination,
// ContourSampling, EdgeMatching) on rendered images with known poses: the pose is recovered from a
// perturbed prediction in one camera, in two cameras, with one camera dark (from the other alone)
// and with a depth map; divergence and too few matches are lost tracks, malformed inputs errors.
#include <gtest/gtest.h>

#include "ContourSampling.gen.hpp"
#include "EdgeMatching.gen.hpp"
#include "EdgePoseEstimation.gen.hpp"
#include "VisibilityDetermination.gen.hpp"
#include "cdff/tracking/edge_tracker.hpp"
#include "support/dfn_testing.hpp"
#include "support/model_rendering.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

struct Rig {
  CameraModel camera = testing::pinholeCamera(640, 480, 600);
  PolygonModel model = testing::lShapeModel(0.08);
  // The model 0.5 m in front of the left camera; the right camera 12 cm to its right.
  Eigen::Isometry3d left_T_model = testing::lookAt({0.3, -0.35, 0.22}, Eigen::Vector3d::Zero());
  Eigen::Isometry3d right_T_left = [] {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.translation() << -0.12, 0, 0;
    return t;
  }();
};

Image render(const Rig& rig, const Eigen::Isometry3d& camera_T_model, double gain = 1.0,
             std::uint32_t seed = 1) {
  testing::RenderOptions options;
  options.noise_sigma = 2.0;
  options.gain = gain;
  options.seed = seed;
  Image image =
      testing::toImage(testing::renderModel(rig.model, rig.camera, camera_T_model, options));
  image.camera = rig.camera;
  return image;
}

Eigen::Isometry3d perturb(const Eigen::Isometry3d& pose, double metres, double radians) {
  Eigen::Isometry3d p = pose;
  p.translation() += Eigen::Vector3d(0.6, -0.5, 0.62).normalized() * metres;
  p.linear() = expSO3(Eigen::Vector3d(-0.3, 0.8, 0.5).normalized() * radians).toRotationMatrix() *
               p.linear();
  return p;
}

// One camera's chain up to its matched samples.
struct Chain {
  std::unique_ptr<VisibilityDetermination> visibility =
      testing::makeDfn<VisibilityDetermination>("VisibilityDetermination", "HiddenLineRemoval");
  std::unique_ptr<ContourSampling> sampling =
      testing::makeDfn<ContourSampling>("ContourSampling", "Uniform");
  std::unique_ptr<EdgeMatching> matching =
      testing::makeDfn<EdgeMatching>("EdgeMatching", "NormalSearch", "{search_distance: 12}");

  std::shared_ptr<const ContourSamples> run(const PolygonModel& model, const Image& image,
                                            const Transform& predicted,
                                            const Transform* extrinsics = nullptr) {
    visibility->in.model.set(model);
    visibility->in.image.set(image);
    visibility->in.pose.set(predicted);
    if (extrinsics) visibility->in.camera_extrinsics.set(*extrinsics);
    EXPECT_OK(visibility->process());
    sampling->in.contours.set(visibility->out.contours.shared());
    EXPECT_OK(sampling->process());
    matching->in.image.set(image);
    matching->in.samples.set(sampling->out.samples.shared());
    EXPECT_OK(matching->process());
    return matching->out.matches.shared();
  }
};

std::unique_ptr<EdgePoseEstimation> makeEstimator(const std::string& yaml = "{}") {
  return testing::makeDfn<EdgePoseEstimation>("EdgePoseEstimation", "RobustGaussNewton", yaml);
}

double translationError(const Transform& estimate, const Eigen::Isometry3d& truth) {
  return (estimate.translation - truth.translation()).norm();
}
double angleError(const Transform& estimate, const Eigen::Isometry3d& truth) {
  return angularDistance(estimate.rotation, Eigen::Quaterniond(truth.linear()));
}

TEST(EdgePoseEstimation, OneCameraRecoversThePoseFromAPerturbedPrediction) {
  const Rig rig;
  const Transform predicted =
      Transform::fromIsometry(perturb(rig.left_T_model, 0.004, 0.01), "left", "model");
  Chain chain;
  auto estimator = makeEstimator();
  // Two rounds, as the EdgeTracker's refinement pass does: the second starts where the first ended.
  Transform pose = predicted;
  for (int round = 0; round < 2; ++round) {
    estimator->in.matches.set(chain.run(rig.model, render(rig, rig.left_T_model), pose));
    ASSERT_OK(estimator->process());
    pose = estimator->out.pose->pose;
  }
  const double dt = translationError(pose, rig.left_T_model);
  const double da = angleError(pose, rig.left_T_model);
  ::testing::Test::RecordProperty("translation_error_mm", std::to_string(dt * 1e3));
  ::testing::Test::RecordProperty("angle_error_deg", std::to_string(da * 180 / M_PI));
  // 0.5 m away at 600 px focal length, 1 px is 0.8 mm: the estimate must be sub-pixel.
  EXPECT_LT(dt, 0.0005);
  EXPECT_LT(da, 0.1 * M_PI / 180);
  EXPECT_EQ(*estimator->out.status, static_cast<int>(TrackingStatus::kTracking));
  EXPECT_GT(*estimator->out.inlier_ratio, 0.8);
  EXPECT_LT(*estimator->out.residual_rms, 0.5);
  const Matrix6d& cov = estimator->out.pose->covariance;
  EXPECT_GT(cov.diagonal().minCoeff(), 0);
  EXPECT_LT(std::sqrt(cov(2, 2)), 0.002) << "the depth is known to a few millimetres at most";
  EXPECT_EQ(pose.parent_frame, "left");
  EXPECT_EQ(pose.child_frame, "model");
}

TEST(EdgePoseEstimation, TwoCamerasFuseAndADarkOneIsLeftOut) {
  const Rig rig;
  const Transform predicted =
      Transform::fromIsometry(perturb(rig.left_T_model, 0.003, 0.008), "left", "model");
  const Transform extrinsics = Transform::fromIsometry(rig.right_T_left, "right", "left");
  const Image left = render(rig, rig.left_T_model);
  const Image right = render(rig, rig.right_T_left * rig.left_T_model, 1.0, 2);
  const Image right_dark = render(rig, rig.right_T_left * rig.left_T_model, 0.02, 3);
  Chain left_chain, right_chain;
  for (bool dark : {false, true}) {
    SCOPED_TRACE(dark ? "right camera dark" : "both cameras");
    auto estimator = makeEstimator();
    Transform pose = predicted;
    for (int round = 0; round < 2; ++round) {
      estimator->in.matches.set(left_chain.run(rig.model, left, pose));
      estimator->in.matches_secondary.set(
          right_chain.run(rig.model, dark ? right_dark : right, pose, &extrinsics));
      ASSERT_OK(estimator->process());
      pose = estimator->out.pose->pose;
    }
    EXPECT_LT(translationError(pose, rig.left_T_model), 0.0005);
    EXPECT_LT(angleError(pose, rig.left_T_model), 0.1 * M_PI / 180);
    EXPECT_EQ(*estimator->out.status,
              static_cast<int>(dark ? TrackingStatus::kDegraded : TrackingStatus::kTracking));
  }
}

TEST(EdgePoseEstimation, ADepthMapJoinsTheEstimate) {
  const Rig rig;
  const Transform predicted =
      Transform::fromIsometry(perturb(rig.left_T_model, 0.004, 0.01), "left", "model");
  DepthMap depth;
  depth.image = testing::toImage(testing::renderDepth(rig.model, rig.camera, rig.left_T_model));
  depth.image.camera = rig.camera;
  Chain chain;
  auto estimator = makeEstimator();
  Transform pose = predicted;
  for (int round = 0; round < 2; ++round) {
    estimator->in.matches.set(chain.run(rig.model, render(rig, rig.left_T_model), pose));
    estimator->in.depth.set(depth);
    ASSERT_OK(estimator->process());
    pose = estimator->out.pose->pose;
  }
  EXPECT_LT(translationError(pose, rig.left_T_model), 0.0003);
  EXPECT_LT(angleError(pose, rig.left_T_model), 0.05 * M_PI / 180);
  EXPECT_EQ(*estimator->out.status, static_cast<int>(TrackingStatus::kTracking));
}

TEST(EdgePoseEstimation, DivergenceAndTooFewMatchesAreLostTracks) {
  const Rig rig;
  // The image shows the model 3 cm away from the prediction; a wide search finds it, and the
  // estimate moves farther than the divergence threshold allows.
  const Transform predicted = Transform::fromIsometry(rig.left_T_model, "left", "model");
  Eigen::Isometry3d moved = rig.left_T_model;
  moved.translation() += Eigen::Vector3d(0.03, 0, 0);
  Chain chain;
  chain.matching =
      testing::makeDfn<EdgeMatching>("EdgeMatching", "NormalSearch", "{search_distance: 60}");
  auto estimator = makeEstimator("{divergence_translation: 0.01}");
  estimator->in.matches.set(chain.run(rig.model, render(rig, moved), predicted));
  ASSERT_OK(estimator->process());
  EXPECT_EQ(*estimator->out.status, static_cast<int>(TrackingStatus::kLost));
  EXPECT_LT(translationError(estimator->out.pose->pose, rig.left_T_model), 1e-12)
      << "a lost track reports the prediction";
  EXPECT_EQ(estimator->out.pose->covariance.diagonal(),
            tracking::noInformationCovariance().diagonal());

  Image black = render(rig, rig.left_T_model, 0.0);
  estimator = makeEstimator();
  estimator->in.matches.set(chain.run(rig.model, black, predicted));
  ASSERT_OK(estimator->process());
  EXPECT_EQ(*estimator->out.status, static_cast<int>(TrackingStatus::kLost));
  EXPECT_GE(estimator->diagnostics().warning_count, 1u);
}

TEST(EdgePoseEstimation, MalformedInputsAreRejected) {
  const Rig rig;
  const Transform predicted = Transform::fromIsometry(rig.left_T_model, "left", "model");
  Chain chain;
  auto matched = chain.run(rig.model, render(rig, rig.left_T_model), predicted);
  auto estimator = makeEstimator();
  ContourSamples unmatched = *chain.sampling->out.samples;
  estimator->in.matches.set(unmatched);
  testing::expectRejected(*estimator, "never matched; expected the output of EdgeMatching");

  // The second camera's contours come from another prediction.
  Chain other;
  const Transform elsewhere =
      Transform::fromIsometry(perturb(rig.left_T_model, 0.01, 0), "left", "model");
  estimator->in.matches.set(matched);
  estimator->in.matches_secondary.set(
      other.run(rig.model, render(rig, rig.left_T_model), elsewhere));
  testing::expectRejected(*estimator, "computed for different poses");

  auto bad =
      Registry::instance().createAs<EdgePoseEstimation>("EdgePoseEstimation", "RobustGaussNewton");
  ASSERT_TRUE(bad.isOk());
  const Status s = bad.value()->configure(YAML::Load("{depth_extrinsics: [0, 0, 0]}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
}

}  // namespace
}  // namespace cdff::dfn
