// End to end: dfpcs/visual_tracking.yaml through the Orchestrator on ViSP's Castle-simu sequence
// (real rendered images with ground truth), started from the true pose perturbed by 5 % of the
// range and 5 degrees (the initial pose the visual tracking issue prescribes until the detection
// DFPC provides one); a stretch of black frames is a LOST status, never a silent divergence. The
// camera is given a mounting on a servicer, so that the servicer-frame pose product is checked
// against the camera-frame state moved by it.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/graph.hpp"
#include "cdff/dfpc/orchestrator.hpp"

#include "support/castle_simu.hpp"
#include "test_helpers.hpp"
#include "visual_tracking_support.hpp"

namespace cdff::dfpc {
namespace {

namespace castle = cdff::testing::castle;

const std::string kGraph = std::string(CDFF_SOURCE_DIR) + "/dfpcs/visual_tracking.yaml";
constexpr const char* kPose = "/cdff/visual_tracking/pose";
constexpr const char* kCameraPose = "/cdff/visual_tracking/camera_pose";
constexpr const char* kStatus = "/cdff/visual_tracking/status";

Transform servicerTCamera() {
  return Transform::fromIsometry(
      Eigen::Translation3d(0.4, -0.1, 1.2) *
          Eigen::AngleAxisd(1.9, Eigen::Vector3d(1, -2, 0.5).normalized()),
      "servicer", "camera_left_optical");
}

struct CastleRun {
  eval::PoseEvaluation pose;  // the filtered camera-frame state against the truth, every frame
  std::vector<int> status;    // per frame
  MemorySink sink;
};

// Frames 1..40 at 30 Hz; frames in [black_from, black_to] are replaced by all-black images.
void runCastle(CastleRun& run, std::uint32_t seed, int black_from = 0, int black_to = -1) {
  MemoryStream input;
  Result<PolygonModel> model = castle::model();
  ASSERT_OK(model.status());
  std::vector<Transform> truth;
  std::vector<castle::Frame> frames;
  for (int k = 1; k <= castle::kFrames; ++k) {
    Result<castle::Frame> f = castle::frame(k, false);
    ASSERT_OK(f.status());
    truth.push_back(Transform::fromIsometry(f->camera_T_model, "camera_left_optical", "castle",
                                            f->image.stamp));
    frames.push_back(std::move(f).value());
  }
  const Timestamp t0 = frames[0].image.stamp;
  input.add(Message::of("/chaser/tf/camera_left_optical", 0, servicerTCamera()));
  input.add(Message::of("/cdff/visual_tracking/model", t0, *model));
  std::mt19937 rng(seed);
  input.add(
      Message::of("/cdff/visual_tracking/initial_pose", t0,
                  visual::perturbedInitialState(frames[0].camera_T_model, "camera_left_optical",
                                                "castle", t0, 0.05, 5.0 * M_PI / 180, rng)));
  for (int k = 1; k <= castle::kFrames; ++k) {
    Image image = frames[k - 1].image;
    if (k >= black_from && k <= black_to) {
      std::vector<std::uint8_t> zeros(640 * 480, 0);
      Image black = Image::fromBytes(std::move(zeros), 640, 480, PixelFormat::kGray8).value();
      black.camera = image.camera;
      black.frame_id = image.frame_id;
      black.stamp = image.stamp;
      image = std::move(black);
    }
    input.add(Message::of("/chaser/camera/left/image", image.stamp, std::move(image)));
  }

  OrchestratorOptions options;
  options.sink = &run.sink;
  Orchestrator o(options);
  Result<GraphSpec> spec = loadGraphFile(kGraph);
  ASSERT_OK(spec.status());
  for (InstanceSpec& instance : spec->instances)
    if (instance.name == "tracker") instance.parameters["model_file"] = "";  // the model input
  Result<std::unique_ptr<Dfpc>> dfpc = Dfpc::create(std::move(spec).value());
  ASSERT_OK(dfpc.status());
  ASSERT_OK(o.add(std::move(dfpc).value()));
  ASSERT_OK(o.startAll());
  ASSERT_OK(o.run(input).status());

  for (const Message& m : run.sink.messages(kStatus)) run.status.push_back(*m.as<int>());
  // The first pose is the initial state itself, published when the filter takes it.
  const std::vector<Message> camera_poses = run.sink.messages(kCameraPose);
  ASSERT_EQ(camera_poses.size(), castle::kFrames + 1u);
  Result<eval::PoseEvaluation> e = eval::evaluatePoses(visual::estimates(camera_poses, 1), truth);
  ASSERT_OK(e.status());
  run.pose = std::move(e).value();
  // The product: the same state in the servicer frame, twist and covariance turned with it.
  const std::vector<Message> poses = run.sink.messages(kPose);
  ASSERT_EQ(poses.size(), camera_poses.size());
  const Transform mounting = servicerTCamera();
  const Eigen::Matrix3d r = mounting.rotation.toRotationMatrix();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const RigidBodyState& c = *camera_poses[i].as<RigidBodyState>();
    const RigidBodyState& s = *poses[i].as<RigidBodyState>();
    ASSERT_EQ(s.pose.parent_frame, "servicer");
    ASSERT_EQ(s.pose.child_frame, "castle");
    ASSERT_EQ(s.pose.stamp, c.pose.stamp);
    EXPECT_LT(
        (s.pose.isometry().matrix() - (mounting.isometry() * c.pose.isometry()).matrix()).norm(),
        1e-9);
    EXPECT_LT((s.twist.linear - r * c.twist.linear).norm(), 1e-12);
    EXPECT_LT((s.twist.angular - r * c.twist.angular).norm(), 1e-12);
    EXPECT_NEAR(s.covariance.trace(), c.covariance.trace(), 1e-9 * c.covariance.trace());
  }
}

TEST(VisualTrackingDfpc, TracksCastleSimuFromAPerturbedInitialPose) {
  if (!castle::available()) GTEST_SKIP() << "visp-images-data is not installed";
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    CastleRun run;
    runCastle(run, seed);
    ASSERT_EQ(run.status.size(), 40u);
    // Acquisition may need the second image (it retries from the filter's prediction, which
    // keeps the initial uncertainty while the first frame is LOST); every later frame tracks.
    for (std::size_t k = 1; k < run.status.size(); ++k)
      EXPECT_NE(run.status[k], 2) << "frame " << k + 1;
    ASSERT_EQ(run.pose.errors.size(), 40u);
    const std::size_t first = run.status[0] == 2 ? 1 : 0;
    double max_t = 0, max_a = 0;
    for (std::size_t k = first; k < run.pose.errors.size(); ++k) {
      max_t = std::max(max_t, run.pose.errors[k].position_error_m);
      max_a = std::max(max_a, run.pose.errors[k].angle_error_deg);
    }
    const std::string tag = "_seed" + std::to_string(seed);
    RecordProperty("first_frame_lost" + tag, std::to_string(first));
    RecordProperty("max_translation_mm" + tag, std::to_string(max_t * 1e3));
    RecordProperty("max_angle_deg" + tag, std::to_string(max_a));
    // The edge tracker's goal on this sequence (max 3 mm, 1 degree) from the first tracked
    // frame on: acquisition removes the 5 % / 5 degree initial error.
    EXPECT_LT(max_t, 0.003);
    EXPECT_LT(max_a, 1.0);
    EXPECT_EQ(run.sink.events(EventType::kDfnError).size(), 0u);
  }
}

TEST(VisualTrackingDfpc, BlackFramesAreALostStatusAndTheTrackResumes) {
  if (!castle::available()) GTEST_SKIP() << "visp-images-data is not installed";
  CastleRun run;
  runCastle(run, 4, 15, 17);
  ASSERT_EQ(run.status.size(), 40u);
  for (int k = 1; k <= 40; ++k) {
    if (k >= 15 && k <= 17)
      EXPECT_EQ(run.status[k - 1], 2) << "frame " << k;
    else
      EXPECT_NE(run.status[k - 1], 2) << "frame " << k;
  }
  // While lost the filter coasts on its constant-velocity prediction; tracking resumes from it.
  ASSERT_EQ(run.pose.errors.size(), 40u);
  for (int k = 1; k <= 40; ++k) {
    if (k >= 15 && k <= 19) continue;
    EXPECT_LT(run.pose.errors[k - 1].position_error_m, 0.003) << "frame " << k;
    EXPECT_LT(run.pose.errors[k - 1].angle_error_deg, 1.0) << "frame " << k;
  }
  std::size_t to_lost = 0;
  for (const Event& e : run.sink.events(EventType::kTrackStateChanged))
    if (e.message.find("LOST") != std::string::npos) ++to_lost;
  EXPECT_GE(to_lost, 1u);
}

}  // namespace
}  // namespace cdff::dfpc
