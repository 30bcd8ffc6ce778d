// ScanPosition's inputs: each bad input is an error that says what, which value and what was
// expected, and leaves every output as it was; too few returns in the gate and non-finite
// returns are warnings; a call without a new cloud changes nothing; a new model is used.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "ScanPosition.gen.hpp"
#include "scan_position_testing.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

using namespace scan_position_testing;  // NOLINT: this folder's test scenes

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A node that has measured one scene at 30 m (so that a rejected call has outputs to keep).
struct Measured {
  std::unique_ptr<ScanPosition> node = make();
  Draw draw;

  Measured() {
    std::mt19937 rng(11);
    draw = drawScene(30.0, rng);
    setInputs(*node, draw);
    EXPECT_OK(node->process());
    EXPECT_TRUE(node->out.position.hasValue());
  }
  void reset() { setInputs(*node, draw); }
};

TEST(ScanPositionVisibleCentroid, BadCloudsAndFramesAreErrors) {
  Measured m;
  PointCloud empty = m.draw.scan;
  empty.points = {};
  empty.ring = {};
  m.node->in.cloud.set(empty);
  testing::expectRejected(*m.node, "input 'cloud' has no points");

  m.reset();
  PointCloud elsewhere = m.draw.scan;
  elsewhere.frame_id = "velodyne";
  m.node->in.cloud.set(elsewhere);
  testing::expectRejected(*m.node,
                          "input 'cloud' is in frame 'velodyne' but input 'sensor_pose' is "
                          "servicer_T_lidar");

  m.reset();
  RigidBodyState in_lidar = m.draw.prediction;
  in_lidar.pose.parent_frame = "lidar";
  m.node->in.prediction.set(in_lidar);
  testing::expectRejected(*m.node,
                          "input 'prediction' is lidar_T_target but input 'sensor_pose' is "
                          "servicer_T_lidar");

  m.reset();
  LidarInfo other = testing::lidarInfo(m.draw.options, "tof");
  m.node->in.sensor.set(other);
  testing::expectRejected(*m.node, "input 'sensor' describes the LIDAR of frame 'tof'");

  m.reset();  // a description of another LIDAR's lasers: none crosses the target seen
  LidarInfo upward = testing::lidarInfo(m.draw.options, "lidar");
  upward.elevations = {80 * kDeg};
  m.node->in.sensor.set(upward);
  testing::expectRejected(*m.node, "no laser at (80.000) deg crosses the model (radius 2.792 m)");

  m.reset();
  Transform bad_mount = servicerTLidar();
  bad_mount.rotation.coeffs() *= 2.0;
  m.node->in.sensor_pose.set(bad_mount);
  testing::expectRejected(*m.node, "input 'sensor_pose'");
}

// A prediction is read with a new cloud (a call without one only reads a new model).
TEST(ScanPositionVisibleCentroid, BadPredictionsAreErrors) {
  Measured m;
  const auto rejects = [&](const RigidBodyState& p, const std::string& fragment) {
    m.reset();
    m.node->in.prediction.set(p);
    testing::expectRejected(*m.node, fragment);
  };
  RigidBodyState p = m.draw.prediction;
  p.pose.translation.y() = kNaN;
  rejects(p,
          "input 'prediction': transform servicer_T_target translation has a non-finite entry "
          "(nan) at (1, 0)");

  p = m.draw.prediction;
  p.covariance(1, 1) = std::numeric_limits<double>::infinity();
  rejects(p, "state covariance has a non-finite entry (inf) at (1, 1)");

  p = m.draw.prediction;
  p.covariance(2, 2) = 0.0;  // singular: no gate along z
  rejects(p, "expected a positive definite 3x3 block");

  p = m.draw.prediction;  // a positive diagonal, a negative eigenvalue
  p.covariance(0, 1) = p.covariance(1, 0) = 2 * p.covariance(0, 0);
  rejects(p, "position covariance with eigenvalues (-0.09, 0.09, 0.27)");
}

TEST(ScanPositionVisibleCentroid, BadModelsAreErrors) {
  Measured m;
  PointCloud empty;
  empty.frame_id = "target";
  m.node->in.model.set(empty);
  testing::expectRejected(*m.node, "input 'model' has no points");

  m.node->in.model.set(PointCloud::fromXyz({{0.f, 0.f, 0.f}, {0.f, 0.f, 0.f}}, "target"));
  m.node->in.cloud.set(m.draw.scan);
  testing::expectRejected(*m.node, "input 'model' has all its 2 points at its origin");

  m.node->in.model.set(PointCloud::fromXyz({{1.f, std::nanf(""), 0.f}}, "target"));
  m.node->in.cloud.set(m.draw.scan);
  testing::expectRejected(*m.node, "input 'model' point 0 is (1, nan, 0)");

  m.reset();
  PointCloud wrong_frame = satelliteModel();
  wrong_frame.frame_id = "client";
  m.node->in.model.set(wrong_frame);
  testing::expectRejected(*m.node,
                          "input 'model' is in frame 'client' but input 'prediction' is "
                          "servicer_T_target");
}

TEST(ScanPositionVisibleCentroid, TooFewReturnsInTheGateGiveAWarningAndNoPosition) {
  Measured m;
  const void* before = m.node->out.position.anyValue().raw();
  RigidBodyState p = m.draw.prediction;
  p.pose.translation += Eigen::Vector3d(0, 20, 0);  // 20 m to the side: nothing in the gate
  m.reset();
  m.node->in.prediction.set(p);
  m.node->resetDiagnostics();
  ASSERT_OK(m.node->process());
  EXPECT_EQ(m.node->out.position.anyValue().raw(), before) << "a position without returns";
  ASSERT_EQ(m.node->diagnostics().warning_count, 1u);
  const std::string& w = m.node->diagnostics().warnings.back();
  for (const char* fragment :
       {"0 returns of the cloud at t = 5000000 us in the gate", "centre (", "frame 'lidar'",
        "radius 3.692 m = R 2.792 m + 3 x sigma_max "
        "0.300 m",
        "expected at least min_points = 5"})
    EXPECT_NE(w.find(fragment), std::string::npos) << "'" << fragment << "' not in: " << w;
}

TEST(ScanPositionVisibleCentroid, NonFiniteReturnsAreSkippedWithAWarning) {
  Measured m;
  const Eigen::Vector3d clean = m.node->out.position->pose.translation;
  std::vector<Point4f> points(m.draw.scan.points.begin(), m.draw.scan.points.end());
  std::vector<std::uint16_t> rings(m.draw.scan.ring.begin(), m.draw.scan.ring.end());
  for (int i = 0; i < 3; ++i) {
    points.emplace_back(std::nanf(""), 0.f, 0.f);
    rings.push_back(0);
  }
  PointCloud with_nan = m.draw.scan;
  with_nan.points = Buffer<Point4f>::fromVector(std::move(points));
  with_nan.ring = Buffer<std::uint16_t>::fromVector(std::move(rings));
  m.node->in.cloud.set(with_nan);
  m.node->resetDiagnostics();
  ASSERT_OK(m.node->process());
  EXPECT_EQ(m.node->out.position->pose.translation, clean);
  ASSERT_EQ(m.node->diagnostics().warning_count, 1u);
  EXPECT_NE(m.node->diagnostics().warnings.back().find("3 of its"), std::string::npos)
      << m.node->diagnostics().warnings.back();
}

TEST(ScanPositionVisibleCentroid, ACallWithoutANewCloudChangesNoOutput) {
  Measured m;
  const void* before = m.node->out.position.anyValue().raw();
  m.node->in.prediction.set(m.draw.prediction);  // a new prediction, the same (consumed) cloud
  ASSERT_OK(m.node->process());
  EXPECT_EQ(m.node->out.position.anyValue().raw(), before);
}

// The same model moved 1 m along its x axis: the origin measured moves by -1 m along the
// target's x axis (the surface seen is 1 m further along x from the new origin).
TEST(ScanPositionVisibleCentroid, ANewModelBufferIsUsed) {
  Measured m;
  const Eigen::Vector3d before = m.node->out.position->pose.translation;
  std::vector<Point4f> shifted(satelliteModel().points.begin(), satelliteModel().points.end());
  for (Point4f& p : shifted) p.x += 1.0f;
  PointCloud moved = satelliteModel();
  moved.points = Buffer<Point4f>::fromVector(std::move(shifted));
  m.reset();
  m.node->in.model.set(moved);
  ASSERT_OK(m.node->process());
  const Eigen::Vector3d change = m.node->out.position->pose.translation - before;
  const Eigen::Vector3d expected = m.draw.truth.linear() * Eigen::Vector3d(-1, 0, 0);
  // The offsets of a larger, shifted model are a new estimate: within its own sigma.
  const double sigma = std::sqrt(m.node->out.position->covariance.topLeftCorner<3, 3>().trace());
  EXPECT_LT((change - expected).norm(), sigma) << change.transpose();
}

TEST(ScanPositionVisibleCentroid, BadParametersAreRejected) {
  for (const char* bad : {"{gate_sigmas: -1}", "{min_points: 0}", "{attitude_samples: 2}",
                          "{unknown_attitude_sigma: 0.5}", "{gate_sigma: 3}"}) {
    auto node = Registry::instance().createAs<ScanPosition>("ScanPosition", "VisibleCentroid");
    ASSERT_OK(node.status());
    const Status s = node.value()->configure(YAML::Load(bad));
    EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << bad << ": " << s.toString();
  }
}

}  // namespace
}  // namespace cdff::dfn
