// End-to-end accuracy on real ground truth: ViSP's Castle-simu sequence (visp-images-data,
// installed by scripts/install-deps.sh), 40 frames at 640x480 with the CAD model and the true
// camera pose of every frame. As in ViSP's own regression test (testGenericTracker.cpp), the
// tracker starts from the true pose of frame 1 and then predicts each frame with its previous
// estimate; frame 1 itself is tracked too. The thresholds are the goals of the visual tracking
// issue: EdgeTracker max <= 3 mm and <= 1 deg from edges, <= 1 mm and <= 0.25 deg with depth.
// ViSP's own tracker is held to bounds just above what it achieves here (6.9 mm / 2.1 deg edges,
// 3.8 mm / 2.3 deg edges + KLT, 1 mm / 0.35 deg edges + depth, in ViSP's theta-u metric), to
// catch a broken DFI.
#include <gtest/gtest.h>

#include "ModelBasedTracking.gen.hpp"
#include "support/castle_simu.hpp"
#include "support/dfn_testing.hpp"

namespace cdff::dfn {
namespace {

namespace castle = testing::castle;

struct SequenceErrors {
  double max_translation = 0, max_angle = 0, max_theta_u = 0;
  int not_tracking = 0;
};

SequenceErrors run(const std::string& dfi, const std::string& yaml, bool depth) {
  SequenceErrors out;
  auto node = testing::makeDfn<ModelBasedTracking>("ModelBasedTracking", dfi, yaml);
  if (!node) return out;
  Result<PolygonModel> model = castle::model();
  EXPECT_TRUE(model.isOk()) << model.status().toString();
  if (!model) return out;
  node->in.model.set(std::move(model).value());
  PoseWithCovariance predicted;
  for (int k = 1; k <= castle::kFrames; ++k) {
    Result<castle::Frame> frame = castle::frame(k, depth);
    EXPECT_TRUE(frame.isOk()) << frame.status().toString();
    if (!frame) return out;
    if (k == 1) predicted.pose = Transform::fromIsometry(frame->camera_T_model, "camera", "castle");
    node->in.image.set(frame->image);
    if (depth) node->in.depth.set(frame->depth);
    node->in.predicted_pose.set(predicted);
    const Status s = node->process();
    EXPECT_TRUE(s.isOk()) << "frame " << k << ": " << s.toString();
    if (!s) return out;
    if (*node->out.status != static_cast<int>(TrackingStatus::kTracking)) ++out.not_tracking;
    predicted = *node->out.pose;
    const castle::PoseError e = castle::poseError(predicted.pose.isometry(), frame->camera_T_model);
    out.max_translation = std::max(out.max_translation, e.translation);
    out.max_angle = std::max(out.max_angle, e.angle);
    out.max_theta_u = std::max(out.max_theta_u, e.theta_u);
  }
  ::testing::Test::RecordProperty("max_translation_error_mm",
                                  std::to_string(out.max_translation * 1e3));
  ::testing::Test::RecordProperty("max_angle_error_deg",
                                  std::to_string(out.max_angle * 180 / M_PI));
  ::testing::Test::RecordProperty("max_theta_u_error_deg",
                                  std::to_string(out.max_theta_u * 180 / M_PI));
  return out;
}

class CastleSimu : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(castle::available())
        << castle::kDirectory << " is missing: install visp-images-data (scripts/install-deps.sh)";
  }
};

constexpr double kDeg = M_PI / 180;
// ViSP's settings for this sequence (Config/chateau.xml and chateau_depth.xml).
const char* kVispSettings =
    "{me_mask_size: 5, me_mask_number: 180, me_range: 8, me_threshold: 10000, me_mu1: 0.5, "
    "me_mu2: 0.5, me_sample_step: 5, angle_appear: 85, angle_disappear: 89, "
    "near_clipping: 0.01, far_clipping: 2, fov_clipping: true, depth_dense_step: 4, "
    "depth_extrinsics: [-0.05, 0, 0, 0, 0, 0]";

TEST_F(CastleSimu, EdgeTrackerFromEdgesIsWithin3mmAnd1Degree) {
  const SequenceErrors e = run("EdgeTracker", "{}", false);
  EXPECT_EQ(e.not_tracking, 0);
  EXPECT_LE(e.max_translation, 0.003);
  EXPECT_LE(e.max_angle, 1.0 * kDeg);
  EXPECT_LE(e.max_theta_u, 1.0 * kDeg);
}

TEST_F(CastleSimu, EdgeTrackerWithDepthIsWithin1mmAndAQuarterDegree) {
  const SequenceErrors e = run("EdgeTracker", "{depth_extrinsics: [-0.05, 0, 0, 0, 0, 0]}", true);
  EXPECT_EQ(e.not_tracking, 0);
  EXPECT_LE(e.max_translation, 0.001);
  EXPECT_LE(e.max_angle, 0.25 * kDeg);
  EXPECT_LE(e.max_theta_u, 0.25 * kDeg);
}

TEST_F(CastleSimu, VispMbtEdgesTracksTheWholeSequence) {
  const SequenceErrors e = run("VispMbt", std::string(kVispSettings) + ", mode: edges}", false);
  EXPECT_EQ(e.not_tracking, 0);
  EXPECT_LE(e.max_translation, 0.010);
  EXPECT_LE(e.max_theta_u, 3.0 * kDeg);
}

TEST_F(CastleSimu, VispMbtEdgesAndKltTracksTheWholeSequence) {
  const SequenceErrors e = run("VispMbt", std::string(kVispSettings) + ", mode: edges_klt}", false);
  EXPECT_EQ(e.not_tracking, 0);
  EXPECT_LE(e.max_translation, 0.006);
  EXPECT_LE(e.max_theta_u, 3.0 * kDeg);
}

TEST_F(CastleSimu, VispMbtEdgesAndDepthTracksTheWholeSequence) {
  const SequenceErrors e =
      run("VispMbt", std::string(kVispSettings) + ", mode: edges_depth}", true);
  EXPECT_EQ(e.not_tracking, 0);
  EXPECT_LE(e.max_translation, 0.002);
  EXPECT_LE(e.max_theta_u, 0.6 * kDeg);
}

}  // namespace
}  // namespace cdff::dfn
