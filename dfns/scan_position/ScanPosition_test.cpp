// ScanPosition: a VLP-16-like scan (16 rings over +-15 deg, 0.2 deg azimuth step, 3 cm range
// noise, ray-cast so only the faces towards the sensor are seen) of the satellite-like target
// (R = 2.8 m) at 15, 30 and 50 m, at random attitudes and directions; the model is a point cloud
// sampled from the same mesh. The measured origin must be within a fraction of the target's
// size, its covariance must describe the errors (NEES), and the visible-surface offset must
// remove the naive centroid's depth bias. A mounted LIDAR moves the result by its mounting.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>

#include <Eigen/Eigenvalues>

#include "ScanPosition.gen.hpp"
#include "scan_position_testing.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

using namespace scan_position_testing;  // NOLINT: this folder's test scenes

struct RangeStatistics {
  int measured = 0, skipped = 0;  // draws with a position; without (too few returns in the gate)
  double mean_nees = 0, nees_standard_error = 0;
  double error_p50 = 0, error_p95 = 0;          // m, |estimate - truth|
  double depth_mean = 0, naive_depth_mean = 0;  // m, along the line of sight
  double depth_rms = 0, naive_depth_rms = 0;    // m
};

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

double mean(const std::vector<double>& v) {
  double s = 0;
  for (const double x : v) s += x;
  return s / static_cast<double>(v.size());
}

double rms(const std::vector<double>& v) {
  double s = 0;
  for (const double x : v) s += x * x;
  return std::sqrt(s / static_cast<double>(v.size()));
}

// The covariance and the bias covariance of a measurement: symmetric, the bias within the total.
void expectCovariancesWellFormed(const ScanPosition& node) {
  const Eigen::Matrix3d c = node.out.position->covariance.topLeftCorner<3, 3>();
  const Eigen::Matrix3d b = node.out.position_bias->covariance.topLeftCorner<3, 3>();
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c).eigenvalues().minCoeff(), 0);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c - b).eigenvalues().minCoeff(), -1e-12);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(b).eigenvalues().minCoeff(), -1e-12);
}

// `draws` random scenes at `range`, each measured once by one node (its rows built once).
RangeStatistics measureAt(double range, int draws, bool with_sensor,
                          const std::optional<Eigen::Quaterniond>& los_T_target = std::nullopt) {
  auto node = make();
  std::mt19937 rng(static_cast<std::uint32_t>(1000 * range) + (with_sensor ? 1 : 2) +
                   (los_T_target ? 7 : 0));
  std::vector<double> errors, nees, depth, naive_depth;
  RangeStatistics out;
  for (int i = 0; i < draws; ++i) {
    const Draw d = drawScene(range, rng, los_T_target);
    setInputs(*node, d, with_sensor);
    node->out.position.clear();
    EXPECT_OK(node->process());
    if (!node->out.position.hasValue()) {  // the prediction was so far off the gate missed
      ++out.skipped;
      continue;
    }
    expectCovariancesWellFormed(*node);
    const Eigen::Matrix3d c = node->out.position->covariance.topLeftCorner<3, 3>();
    const Eigen::Vector3d e = node->out.position->pose.translation - d.truth.translation();
    const Eigen::Vector3d u = d.truth.translation().normalized();
    errors.push_back(e.norm());
    nees.push_back(e.dot(c.ldlt().solve(e)));
    depth.push_back(e.dot(u));
    naive_depth.push_back((d.centroid - d.truth.translation()).dot(u));
    EXPECT_LE(*node->out.points_used, static_cast<int>(d.scan.size()));
  }
  out.measured = static_cast<int>(errors.size());
  if (out.measured < 2) return out;
  out.mean_nees = mean(nees);
  std::vector<double> centred;
  for (const double x : nees) centred.push_back(x - out.mean_nees);
  out.nees_standard_error = rms(centred) / std::sqrt(static_cast<double>(out.measured));
  out.error_p50 = percentile(errors, 0.5);
  out.error_p95 = percentile(errors, 0.95);
  out.depth_mean = mean(depth);
  out.naive_depth_mean = mean(naive_depth);
  out.depth_rms = rms(depth);
  out.naive_depth_rms = rms(naive_depth);
  std::printf(
      "range %.0f m, %s sensor, %d draws (%d without a position): mean NEES %.2f +- %.2f, "
      "|error| p50 %.3f m p95 %.3f m, depth error mean %.3f m RMS %.3f m (naive centroid: "
      "mean %.3f m RMS %.3f m)\n",
      range, with_sensor ? "with" : "without", draws, out.skipped, out.mean_nees,
      out.nees_standard_error, out.error_p50, out.error_p95, out.depth_mean, out.depth_rms,
      out.naive_depth_mean, out.naive_depth_rms);
  return out;
}

// What the test measured on 2026-12-07 (300 draws per range, with the sensor's description):
// the 95th percentile of the position error. Mean NEES 3.08 +- 0.14, 3.28 +- 0.21 and
// 2.74 +- 0.21; median errors 0.19, 0.22 and 0.37 m; depth errors: mean 0.03, 0.02, 0.05 m,
// RMS 0.15, 0.21, 0.31 m, against the naive centroid's -0.36, -0.33, -0.26 m and 0.40, 0.40,
// 0.41 m.
struct Measured {
  double range, p95;  // m
};
constexpr Measured kMeasured[] = {{15.0, 0.361}, {30.0, 0.684}, {50.0, 1.041}};

TEST(ScanPositionVisibleCentroid, MeasuresTheOriginWithAnHonestCovarianceAt15To50m) {
  constexpr int kDraws = 300;
  const double R = modelRadius();
  for (const Measured& m : kMeasured) {
    SCOPED_TRACE(::testing::Message() << "range " << m.range << " m");
    const RangeStatistics s = measureAt(m.range, kDraws, true);
    // A draw without a position is a prediction more than 3 sigma off (0.3 m per axis).
    EXPECT_LE(s.skipped, kDraws / 50);
    // NEES: a covariance equal to the errors' second moment gives a mean of 3 (3 dof), whatever
    // their distribution (E[e^T C^-1 e] = tr(C^-1 E[e e^T])). The band [1.5, 6] accepts a
    // covariance within a factor 2 of it (1.4 in standard deviation): the offsets are a model
    // (200 attitudes, a grid, rings as rows), and the mean of 300 skewed, heavy-tailed NEES
    // values has a standard error of about 0.3 (printed).
    EXPECT_GT(s.mean_nees, 1.5) << "pessimistic";
    EXPECT_LT(s.mean_nees, 6.0) << "overconfident";
    // The target's origin within half its radius in 95 % of the draws.
    EXPECT_LT(s.error_p95, 0.5 * R);
    // Regression: within 25 % of what was measured.
    EXPECT_LT(s.error_p95, 1.25 * m.p95);
    // The naive centroid lies in front of the origin (its mean depth error -0.26 to -0.36 m); the
    // offset removes that bias, and with it most of the depth error at 15 and 30 m (at 50 m
    // one or two rings cross the target and their depth on it dominates).
    EXPECT_LT(s.naive_depth_mean, -0.2);
    EXPECT_LT(std::abs(s.depth_mean), 0.05);
    EXPECT_LT(s.depth_rms, (m.range < 40 ? 0.6 : 0.85) * s.naive_depth_rms);
  }
}

// Measured on 2026-12-07: mean NEES 3.28, 2.78 and 2.17 (at 50 m one ring is often seen and
// is then taken to cross anywhere on the target), 95th percentile errors 0.36, 0.65, 1.12 m.
TEST(ScanPositionVisibleCentroid, WithoutTheSensorsDescriptionTheRingsSeenAreUsed) {
  constexpr int kDraws = 300;
  for (const double range : {15.0, 30.0, 50.0}) {
    SCOPED_TRACE(::testing::Message() << "range " << range << " m");
    const RangeStatistics s = measureAt(range, kDraws, false);
    EXPECT_GT(s.mean_nees, 1.5) << "pessimistic";
    EXPECT_LT(s.mean_nees, 6.0) << "overconfident";
    EXPECT_LT(s.error_p95, 0.5 * modelRadius());
  }
}

// The covariances above hold over every attitude alike; a target keeps one attitude for a whole
// approach. At each of four fixed attitudes, over directions and ring phases, the errors must
// stay within their covariance's scale: the scan's spread along the rings tells a satellite
// whose wings face the sensor (returns spread over metres, a centroid far from the origin)
// from one seen edge-on.
TEST(ScanPositionVisibleCentroid, AtAFixedAttitudeTheCovarianceStillHolds) {
  constexpr int kDraws = 150;
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY();
  struct View {
    const char* name;
    Eigen::Quaterniond los_T_target;
  };
  const View views[] = {
      {"adapter towards the sensor, wings edge-on", Eigen::Quaterniond::Identity()},
      {"adapter towards the sensor, pitched 20 deg",
       Eigen::Quaterniond(Eigen::AngleAxisd(20 * kDeg, y))},
      {"wings face-on along the rings", Eigen::Quaterniond(Eigen::AngleAxisd(-90 * kDeg, y))},
      {"wings face-on across the rings",
       Eigen::Quaterniond(Eigen::AngleAxisd(-90 * kDeg, y) * Eigen::AngleAxisd(90 * kDeg, x))},
  };
  for (const View& v : views)
    for (const double range : {30.0, 50.0}) {
      SCOPED_TRACE(::testing::Message() << v.name << ", range " << range << " m");
      std::printf("%s: ", v.name);
      const RangeStatistics s = measureAt(range, kDraws, true, v.los_T_target);
      // Within a factor 2 of the errors' scale (the band of the test above), and a regression
      // bound: at most 3.23 measured (+- 0.25); weighing every draw alike gave 4.36 edge-on at
      // 30 m.
      EXPECT_LT(s.mean_nees, 4.0) << "overconfident";
      EXPECT_GT(s.mean_nees, 1.0) << "pessimistic";
    }
}

// The same scan measured with the LIDAR as frame a and with the LIDAR mounted on the servicer:
// the second result is the first moved by the mounting, its covariances turned by it.
TEST(ScanPositionVisibleCentroid, AMountedSensorMovesTheResultByItsMounting) {
  std::mt19937 rng(5);
  const Draw d = drawScene(30.0, rng);
  auto in_lidar = make();
  setInputs(*in_lidar, d);
  in_lidar->in.sensor_pose.set(Transform::identity("lidar", "lidar"));
  RigidBodyState prediction_in_lidar = d.prediction;
  prediction_in_lidar.pose.parent_frame = "lidar";
  in_lidar->in.prediction.set(prediction_in_lidar);
  ASSERT_OK(in_lidar->process());

  const Transform mount = mountedServicerTLidar();
  const Eigen::Matrix3d rotation = mount.rotation.toRotationMatrix();
  RigidBodyState prediction = d.prediction;
  prediction.pose.translation = mount * d.prediction.pose.translation;
  prediction.covariance.topLeftCorner<3, 3>() =
      rotation * d.prediction.covariance.topLeftCorner<3, 3>() * rotation.transpose();
  auto mounted = make();
  setInputs(*mounted, d);
  mounted->in.sensor_pose.set(mount);
  mounted->in.prediction.set(prediction);
  ASSERT_OK(mounted->process());

  const PoseWithCovariance& a = *mounted->out.position;
  const PoseWithCovariance& l = *in_lidar->out.position;
  EXPECT_EQ(a.pose.parent_frame, "servicer");
  EXPECT_EQ(a.pose.child_frame, "target");
  EXPECT_EQ(a.pose.stamp, kStamp);
  EXPECT_EQ(l.pose.parent_frame, "lidar");
  EXPECT_LT((a.pose.translation - mount * l.pose.translation).norm(), 1e-9);
  const auto turned = [&](const Eigen::Matrix3d& m) {
    return Eigen::Matrix3d(rotation * m * rotation.transpose());
  };
  EXPECT_LT(
      (a.covariance.topLeftCorner<3, 3>() - turned(l.covariance.topLeftCorner<3, 3>())).norm(),
      1e-12);
  EXPECT_LT((mounted->out.position_bias->covariance.topLeftCorner<3, 3>() -
             turned(in_lidar->out.position_bias->covariance.topLeftCorner<3, 3>()))
                .norm(),
            1e-12);
  EXPECT_EQ(*mounted->out.points_used, *in_lidar->out.points_used);
  // The attitude is not observed: identity rotation, 180 deg per axis, no correlation.
  EXPECT_EQ(a.pose.rotation.coeffs(), Eigen::Quaterniond::Identity().coeffs());
  EXPECT_EQ(Eigen::Matrix3d(a.covariance.bottomRightCorner<3, 3>()),
            Eigen::Matrix3d(Eigen::Matrix3d::Identity() * M_PI * M_PI));
  EXPECT_TRUE((a.covariance.topRightCorner<3, 3>().isZero(0.0)));
  EXPECT_EQ(mounted->out.position_bias->pose.translation, a.pose.translation);
  EXPECT_TRUE((mounted->out.position_bias->covariance.bottomRightCorner<3, 3>().isZero(0.0)));
}

// The cost of a call once the model's rows are built (printed, not asserted: the machine may be
// loaded): a 16-ring scan cropped to the target, at 15 and 50 m.
TEST(ScanPositionVisibleCentroid, TimePerScan) {
  for (const double range : {15.0, 50.0}) {
    std::mt19937 rng(9);
    const Draw d = drawScene(range, rng);
    auto node = make();
    setInputs(*node, d);
    ASSERT_OK(node->process());
    const double first = node->diagnostics().last_wall_s;
    node->resetDiagnostics();
    constexpr int kCalls = 300;
    for (int i = 0; i < kCalls; ++i) {
      node->in.cloud.set(d.scan);
      ASSERT_OK(node->process());
    }
    std::printf(
        "range %.0f m, %zu returns: first call (model rows built) %.1f ms, then %.3f ms per "
        "scan (mean of %d)\n",
        range, d.scan.size(), 1e3 * first, 1e3 * node->diagnostics().meanWallSeconds(), kCalls);
  }
}

}  // namespace
}  // namespace cdff::dfn
