// The external API (seed §7.3): state machine, queries in named frames, asynchronous
// subscriptions at the requested rate (on a simulated clock), errors returned, never thrown.
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>

#include "cdff/dfpc/api.hpp"
#include "cdff/dfpc/designation.hpp"
#include "test_helpers.hpp"

namespace cdff::api {
namespace {

const std::string kGraph = std::string(CDFF_SOURCE_DIR) + "/dfpcs/pose_filtering.yaml";
constexpr const char* kPoseChannel = "/chaser/target_pose_measurement";

// The target moves at constant twist; measurements are exact, so the filter converges on it.
PoseWithCovariance measurement(double t) {
  PoseWithCovariance z;
  z.pose = Transform::identity("servicer", "target", fromSeconds(t));
  z.pose.translation = Eigen::Vector3d(1.0 + 0.1 * t, 0.0, 10.0);
  z.pose.rotation = expSO3(Eigen::Vector3d(0, 0, 0.05 * t));
  z.covariance.diagonal() << Eigen::Vector3d::Constant(1e-4), Eigen::Vector3d::Constant(1e-6);
  return z;
}

std::unique_ptr<Cdff> makeCdff(std::shared_ptr<dfpc::Clock> clock = nullptr,
                               std::vector<Transform> transforms = {}) {
  Config config;
  config.graph_files = {kGraph};
  config.clock = std::move(clock);
  config.static_transforms = std::move(transforms);
  Result<std::unique_ptr<Cdff>> cdff = Cdff::create(std::move(config));
  EXPECT_TRUE(cdff.isOk()) << cdff.status().toString();
  return cdff ? std::move(cdff).value() : nullptr;
}

void feed(Cdff& cdff, double from, double to) {
  for (double t = from; t <= to + 1e-9; t += 0.1)
    ASSERT_OK(cdff.push(dfpc::Message::of(kPoseChannel, fromSeconds(t), measurement(t))));
  ASSERT_OK(cdff.flush(30.0));
}

#define EXPECT_CONTAINS(text, fragment) \
  EXPECT_NE(std::string(text).find(fragment), std::string::npos) << (text)

TEST(ExternalApi, StateMachineAcceptsTheSeedTransitionsAndNamesTheRefusedOnes) {
  auto cdff = makeCdff();
  ASSERT_TRUE(cdff);
  EXPECT_EQ(cdff->getCDFFState(), CdffState::kUninitialised);
  EXPECT_CONTAINS(cdff->setCDFFState(StateRequest::kIdle).message(),
                  "setCDFFState(idle) in state uninitialised; accepted here: initialize");
  EXPECT_FALSE(cdff->setCDFFState(StateRequest::kReset).isOk());
  EXPECT_FALSE(cdff->setCDFFState(StateRequest::kStop).isOk());
  ASSERT_OK(cdff->setCDFFState(StateRequest::kInitialize));
  EXPECT_EQ(cdff->getCDFFState(), CdffState::kRunning);
  EXPECT_CONTAINS(cdff->setCDFFState(StateRequest::kInitialize).message(), "running already");
  ASSERT_OK(cdff->setCDFFState(StateRequest::kIdle));
  EXPECT_EQ(cdff->getCDFFState(), CdffState::kIdle);
  ASSERT_OK(cdff->setCDFFState(StateRequest::kInitialize));  // resumes
  ASSERT_OK(cdff->setCDFFState(StateRequest::kStop));
  EXPECT_EQ(cdff->getCDFFState(), CdffState::kStopped);
  EXPECT_EQ(cdff->getDFPCStatus("pose_filtering")->state, dfpc::DfpcState::kStopped);
  ASSERT_OK(cdff->setCDFFState(StateRequest::kReset));
  EXPECT_EQ(cdff->getCDFFState(), CdffState::kStopped);
  ASSERT_OK(cdff->setCDFFState(StateRequest::kInitialize));
  EXPECT_EQ(cdff->getDFPCStatus("pose_filtering")->state, dfpc::DfpcState::kRunning);
}

TEST(ExternalApi, TargetPoseAndVelocityInTheProductFrameAndInAMountedFrame) {
  // camera_T_servicer: a camera 1 m forward, rotated 90 deg about z.
  Transform camera_T_servicer = Transform::identity("camera", "servicer");
  camera_T_servicer.rotation = expSO3(Eigen::Vector3d(0, 0, M_PI / 2));
  camera_T_servicer.translation = Eigen::Vector3d(0, -1, 0);
  auto cdff = makeCdff(nullptr, {camera_T_servicer});
  ASSERT_TRUE(cdff);
  EXPECT_CONTAINS(cdff->getTargetRelativePose("servicer").status().message(),
                  "no target_state or target_pose product yet (from {pose_filtering/state})");
  ASSERT_OK(cdff->setCDFFState(StateRequest::kInitialize));
  feed(*cdff, 0.0, 10.0);

  Result<PoseWithCovariance> pose = cdff->getTargetRelativePose("servicer");
  ASSERT_OK(pose.status());
  const PoseWithCovariance truth = measurement(10.0);
  EXPECT_EQ(pose->pose.stamp, fromSeconds(10.0));
  EXPECT_LT((pose->pose.translation - truth.pose.translation).norm(), 1e-3);
  EXPECT_LT(angularDistance(pose->pose.rotation, truth.pose.rotation), 1e-3);

  Result<PoseWithCovariance> in_camera = cdff->getTargetRelativePose("camera");
  ASSERT_OK(in_camera.status());
  EXPECT_EQ(in_camera->pose.parent_frame, "camera");
  EXPECT_EQ(in_camera->pose.child_frame, "target");
  EXPECT_TRUE(
      in_camera->pose.translation.isApprox(camera_T_servicer * pose->pose.translation, 1e-12));
  // The covariance rotates with the frame: x and y swap their variances.
  EXPECT_NEAR(in_camera->covariance(0, 0), pose->covariance(1, 1), 1e-15);
  EXPECT_NEAR(in_camera->covariance(1, 1), pose->covariance(0, 0), 1e-15);
  EXPECT_NEAR(in_camera->covariance.trace(), pose->covariance.trace(), 1e-15);
  EXPECT_CONTAINS(cdff->getTargetRelativePose("lidar").status().message(),
                  "no transform from 'servicer' to 'lidar'; the pose can be given in {servicer, "
                  "camera}");

  Result<VelocityWithCovariance> v = cdff->getTargetRelativeVelocity("servicer");
  ASSERT_OK(v.status());
  EXPECT_LT((v->twist.linear - Eigen::Vector3d(0.1, 0, 0)).norm(), 0.01);
  EXPECT_LT((v->twist.angular - Eigen::Vector3d(0, 0, 0.05)).norm(), 0.005);
  Result<VelocityWithCovariance> v_camera = cdff->getTargetRelativeVelocity("camera");
  ASSERT_OK(v_camera.status());
  EXPECT_TRUE(v_camera->twist.linear.isApprox(camera_T_servicer.rotation * v->twist.linear));
  EXPECT_EQ(v_camera->target_frame, "target");
  EXPECT_CONTAINS(cdff->getModelOfTarget().status().message(),
                  "no DFPC output has role target_model");
}

TEST(ExternalApi, SubscriptionsArriveAtTheRequestedRateOfTheClock) {
  auto clock = std::make_shared<dfpc::SimulatedClock>(0);
  auto cdff = makeCdff(clock);
  ASSERT_TRUE(cdff);
  ASSERT_OK(cdff->setCDFFState(StateRequest::kInitialize));
  feed(*cdff, 0.0, 2.0);

  std::mutex mutex;
  std::vector<Timestamp> pose_calls, status_calls;
  std::size_t poses_ok = 0;
  Result<SubscriptionId> pose_sub =
      cdff->getDFPCPose("pose_filtering", 10.0, [&](Timestamp now, const auto& pose) {
        std::lock_guard lock(mutex);
        pose_calls.push_back(now);
        poses_ok += pose.isOk();
      });
  ASSERT_OK(pose_sub.status());
  Result<SubscriptionId> status_sub =
      cdff->getDFPCStatus("pose_filtering", 33.0, [&](Timestamp now, const auto& status) {
        std::lock_guard lock(mutex);
        status_calls.push_back(now);
        EXPECT_TRUE(status.isOk());
      });
  ASSERT_OK(status_sub.status());

  // 10 s of clock time in 1 ms steps; each step returns once the callbacks due are done.
  for (int ms = 1; ms <= 10000; ++ms) clock->advanceTo(ms * 1000);
  {
    std::lock_guard lock(mutex);
    EXPECT_NEAR(static_cast<double>(pose_calls.size()), 100.0, 10.0);
    EXPECT_NEAR(static_cast<double>(status_calls.size()), 330.0, 33.0);
    EXPECT_EQ(poses_ok, pose_calls.size());
    for (std::size_t i = 1; i < pose_calls.size(); ++i)
      EXPECT_NEAR(static_cast<double>(pose_calls[i] - pose_calls[i - 1]), 100000.0, 10000.0);
    for (std::size_t i = 1; i < status_calls.size(); ++i)
      EXPECT_NEAR(static_cast<double>(status_calls[i] - status_calls[i - 1]), 30303.0, 3030.0);
  }
  ASSERT_OK(cdff->cancelSubscription(pose_sub.value()));
  const std::size_t before = pose_calls.size();
  for (int ms = 10001; ms <= 11000; ++ms) clock->advanceTo(ms * 1000);
  std::lock_guard lock(mutex);
  EXPECT_EQ(pose_calls.size(), before);
  EXPECT_NEAR(static_cast<double>(status_calls.size()), 363.0, 36.0);
}

TEST(ExternalApi, ErrorsAreReturnedNeverThrown) {
  auto clock = std::make_shared<dfpc::SimulatedClock>(0);
  auto cdff = makeCdff(clock);
  ASSERT_TRUE(cdff);
  auto ignore = [](Timestamp, const auto&) {};
  EXPECT_EQ(cdff->getDFPCStatus("nope").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(cdff->getDFPCPose("nope", 10, ignore).status().code(), StatusCode::kNotFound);
  EXPECT_CONTAINS(cdff->getDFPCStatus("pose_filtering", 0.0, ignore).status().message(),
                  "subscription frequency 0 Hz; expected (0, 1e6] Hz");
  EXPECT_FALSE(cdff->getDFPCStatus("pose_filtering", std::nan(""), ignore).isOk());
  EXPECT_FALSE(cdff->getDFPCPose("pose_filtering", 10, nullptr).isOk());
  EXPECT_EQ(cdff->cancelSubscription(12345).code(), StatusCode::kNotFound);
  EXPECT_CONTAINS(cdff->initDFPC("pose_filtering").message(),
                  "initDFPC(pose_filtering) while the CDFF is uninitialised");
  // A callback that throws stays contained; the others still run.
  std::atomic<int> good{0};
  ASSERT_OK(
      cdff->getDFPCStatus("pose_filtering", 10.0,
                          [](Timestamp, const auto&) { throw std::runtime_error("bad callback"); })
          .status());
  ASSERT_OK(cdff->getDFPCStatus("pose_filtering", 10.0, [&](Timestamp, const auto&) { ++good; })
                .status());
  for (int ms = 1; ms <= 1000; ++ms) clock->advanceTo(ms * 1000);
  EXPECT_EQ(good.load(), 10);
  // A cancelled subscription may cancel itself from its own callback.
  std::atomic<int> once{0};
  auto* api = cdff.get();
  std::atomic<SubscriptionId> self{0};
  Result<SubscriptionId> id =
      cdff->getDFPCStatus("pose_filtering", 100.0, [&](Timestamp, const auto&) {
        ++once;
        EXPECT_OK(api->cancelSubscription(self.load()));
      });
  ASSERT_OK(id.status());
  self = id.value();
  for (int ms = 1001; ms <= 1100; ++ms) clock->advanceTo(ms * 1000);
  EXPECT_EQ(once.load(), 1);

  Config given;
  given.graph_files = {kGraph};
  given.input = std::make_shared<dfpc::MemoryStream>(
      std::vector<dfpc::Message>{dfpc::Message::of(kPoseChannel, 0, measurement(0))});
  auto replay = Cdff::create(std::move(given));
  ASSERT_OK(replay.status());
  EXPECT_CONTAINS(
      replay.value()->push(dfpc::Message::of(kPoseChannel, 0, measurement(0))).message(),
      "consumes a given input stream");
  Config bad;
  bad.graph_files = {"/nonexistent/graph.yaml"};
  EXPECT_EQ(Cdff::create(std::move(bad)).status().code(), StatusCode::kNotFound);
  Config empty;
  EXPECT_CONTAINS(Cdff::create(std::move(empty)).status().message(), "no DFPC to run");
}

TEST(ExternalApi, AGivenRecordingIsConsumedOnceRunningAndIdlePausesLiveInput) {
  auto input = std::make_shared<dfpc::MemoryStream>();
  for (int k = 0; k <= 20; ++k)
    input->add(dfpc::Message::of(kPoseChannel, fromSeconds(0.1 * k), measurement(0.1 * k)));
  Config config;
  config.graph_files = {kGraph};
  config.input = input;
  auto replay = Cdff::create(std::move(config));
  ASSERT_OK(replay.status());
  EXPECT_EQ(replay.value()->flush(0.05).code(), StatusCode::kTimeout);  // not initialised yet
  ASSERT_OK(replay.value()->setCDFFState(StateRequest::kInitialize));
  ASSERT_OK(replay.value()->flush(30.0));
  EXPECT_EQ(replay.value()->getDFPCStatus("pose_filtering")->messages, 21u);
  EXPECT_TRUE(replay.value()->products()->contains("pose_filtering/state"));

  auto live = makeCdff();
  ASSERT_TRUE(live);
  ASSERT_OK(live->setCDFFState(StateRequest::kInitialize));
  ASSERT_OK(live->setCDFFState(StateRequest::kIdle));
  for (int k = 0; k < 5; ++k)
    ASSERT_OK(
        live->push(dfpc::Message::of(kPoseChannel, fromSeconds(0.1 * k), measurement(0.1 * k))));
  EXPECT_EQ(live->flush(0.05).code(), StatusCode::kTimeout);
  EXPECT_EQ(live->getDFPCStatus("pose_filtering")->messages, 0u);
  ASSERT_OK(live->setCDFFState(StateRequest::kInitialize));
  ASSERT_OK(live->flush(30.0));
  EXPECT_EQ(live->getDFPCStatus("pose_filtering")->messages, 5u);

  // stopDFPC / initDFPC: a stopped DFPC ignores its input; initDFPC restarts it afresh.
  ASSERT_OK(live->stopDFPC("pose_filtering"));
  feed(*live, 0.5, 0.9);
  EXPECT_EQ(live->getDFPCStatus("pose_filtering")->ignored_messages, 5u);
  ASSERT_OK(live->initDFPC("pose_filtering"));
  feed(*live, 1.0, 1.5);
  const dfpc::DfpcStatus status = live->getDFPCStatus("pose_filtering").value();
  EXPECT_EQ(status.state, dfpc::DfpcState::kRunning);
  EXPECT_EQ(status.messages, 6u);
  EXPECT_EQ(status.instances[0].calls, 6u + 10u);  // 6 measurements, 10 predictions between
}

// tests/dfpc/designation_probe.yaml: a DFPC that reads designations as far-range tracking does.
const std::string kDesignationGraph = CDFF_SOURCE_DIR "/tests/dfpc/designation_probe.yaml";

dfpc::Message cameraImage(double t, int width = 64, int height = 48) {
  Result<Image> image = Image::fromBytes(std::vector<std::uint8_t>(width * height, 20), width,
                                         height, PixelFormat::kGray8);
  EXPECT_TRUE(image.isOk());
  image->stamp = fromSeconds(t);
  image->frame_id = "camera_optical";
  return dfpc::Message::of("/camera/image", fromSeconds(t), *image);
}

TEST(ExternalApi, DesignateTargetDeliversTheUsersBoxAtTheStreamTime) {
  Result<dfpc::GraphSpec> spec = dfpc::loadGraphFile(kDesignationGraph);
  ASSERT_OK(spec.status());
  Config config;
  config.graphs = {*spec};
  Result<std::unique_ptr<Cdff>> created = Cdff::create(std::move(config));
  ASSERT_OK(created.status());
  Cdff& cdff = **created;

  // Not running yet; then running without an image.
  EXPECT_CONTAINS(cdff.designateTarget(10, 10, 8, 8).status().message(),
                  "no running DFPC reads designations (designation_probe is initialised)");
  ASSERT_OK(cdff.setCDFFState(StateRequest::kInitialize));
  Result<Designated> none = cdff.designateTarget(10, 10, 8, 8);
  EXPECT_EQ(none.status().code(), StatusCode::kNotFound);
  EXPECT_CONTAINS(none.status().message(), "no image on /camera/image yet");

  ASSERT_OK(cdff.push(cameraImage(1.0)));
  ASSERT_OK(cdff.flush(30.0));
  // Bad boxes: not finite, empty, leaving the 64x48 image (the message names the bounds).
  EXPECT_CONTAINS(cdff.designateTarget(std::nan(""), 10, 8, 8).status().message(),
                  "the box's corner (nan, 10) is not finite");
  EXPECT_CONTAINS(cdff.designateTarget(10, 10, 0, 8).status().message(),
                  "the box's size 0x8 px; expected at least 1x1 px");
  Result<Designated> outside = cdff.designateTarget(60, 10, 8, 8);
  EXPECT_EQ(outside.status().code(), StatusCode::kInvalidInput);
  EXPECT_CONTAINS(outside.status().message(),
                  "the box [60, 68) x [10, 18) leaves the 64x48 image of /camera/image");
  EXPECT_FALSE(cdff.designateTarget(-0.5, 10, 8, 8).isOk());
  EXPECT_FALSE(cdff.designateTarget(10, 41, 8, 8).isOk());
  EXPECT_FALSE(cdff.products()->contains("designation_probe/designated"));

  // A box that fits: delivered at the stream time (the latest message, 1 s), taken up by the
  // designation node with the next image (1.5 s), the box unchanged.
  ASSERT_OK(cdff.push(dfpc::testing::number("/unrelated", 1.2, 0)));
  ASSERT_OK(cdff.flush(30.0));
  Result<Designated> d = cdff.designateTarget(20.5, 10, 8, 6);
  ASSERT_OK(d.status());
  EXPECT_EQ(d->region.stamp, fromSeconds(1.2));
  EXPECT_EQ(d->region.source, "user");
  EXPECT_EQ(d->region.frame_id, "camera_optical");
  EXPECT_EQ(d->dfpcs, std::vector<std::string>{"designation_probe"});
  EXPECT_EQ(d->image_channel, "/camera/image");
  EXPECT_EQ(d->image_width, 64);
  EXPECT_EQ(d->image_height, 48);
  EXPECT_EQ(d->image_stamp, fromSeconds(1.0));
  ASSERT_OK(cdff.push(cameraImage(1.5)));
  ASSERT_OK(cdff.flush(30.0));
  Result<dfpc::Product> product = cdff.products()->latest("designation_probe/designated");
  ASSERT_OK(product.status());
  std::shared_ptr<const ImageRegion> region = product->as<ImageRegion>();
  ASSERT_TRUE(region);
  EXPECT_EQ(product->stamp, fromSeconds(1.5));
  EXPECT_EQ(region->source, "user");
  EXPECT_EQ(region->width, 8);
  EXPECT_EQ(region->height, 6);
  EXPECT_LT((region->centre() - Eigen::Vector2d(20.5 + 3.5, 10 + 2.5)).norm(), 1e-12);

  // A stopped reader: refused, naming its state.
  ASSERT_OK(cdff.stopDFPC("designation_probe"));
  EXPECT_CONTAINS(cdff.designateTarget(10, 10, 8, 8).status().message(),
                  "designation_probe is stopped");

  // A graph without a designation input.
  auto filtering = makeCdff();
  ASSERT_TRUE(filtering);
  ASSERT_OK(filtering->setCDFFState(StateRequest::kInitialize));
  Result<Designated> unread = filtering->designateTarget(10, 10, 8, 8);
  EXPECT_EQ(unread.status().code(), StatusCode::kNotFound);
  EXPECT_CONTAINS(unread.status().message(),
                  "no DFPC reads designations (an ImageRegion input on /cdff/designation); the "
                  "DFPCs are {pose_filtering}");
}

}  // namespace
}  // namespace cdff::api
