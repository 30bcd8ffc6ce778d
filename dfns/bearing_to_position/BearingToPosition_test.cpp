// BearingToPosition: a target 1.5 km ahead seen along noisy bearings (0.2 mrad across the line of
// sight) with noisy radar ranges (1 m). The position must be range x direction, its covariance
// the first-order one (the range's variance along the line of sight, range^2 x the direction's
// across it) and honest over many draws (NEES within the 95 % chi-square bounds); a bearing
// without a range gives no position and a warning; bad bearings and parameters are errors.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "BearingToPosition.gen.hpp"
#include "cdff/types/statistics.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<BearingToPosition> make(const std::string& yaml = "{}") {
  return testing::makeDfn<BearingToPosition>("BearingToPosition", "RangeAndDirection", yaml);
}

const Eigen::Vector3d kTruth{1500.0, 40.0, -20.0};  // servicer frame, m
constexpr double kAngleSigma = 2e-4;                // rad, per axis across the line of sight
constexpr double kRangeSigma = 1.0;                 // m

Eigen::Matrix3d across(const Eigen::Vector3d& d) {
  return Eigen::Matrix3d::Identity() - d * d.transpose();
}

// The bearing a far-range tracker reports: direction and range with independent noise, the
// direction's covariance at the measured direction (the tracker knows no other).
Bearing bearingOf(const Eigen::Vector3d& p, std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d d0 = p.normalized();
  const Eigen::Vector3d e1 = d0.unitOrthogonal(), e2 = d0.cross(e1);
  Bearing b;
  b.stamp = 7'000'000;
  b.frame_id = "servicer";
  b.direction = d0;
  b.range = p.norm();
  if (rng) {
    b.direction = (d0 + kAngleSigma * (n(*rng) * e1 + n(*rng) * e2)).normalized();
    b.range += kRangeSigma * n(*rng);
  }
  b.covariance = kAngleSigma * kAngleSigma * across(b.direction);
  b.range_variance = kRangeSigma * kRangeSigma;
  return b;
}

TEST(BearingToPositionRangeAndDirection, ThePositionIsRangeTimesDirectionWithItsCovariance) {
  auto node = make("{target_frame: client}");
  const Bearing b = bearingOf(kTruth, nullptr);
  node->in.bearing.set(b);
  ASSERT_OK(node->process());
  const PoseWithCovariance& p = *node->out.position;
  EXPECT_EQ(p.pose.stamp, b.stamp);
  EXPECT_EQ(p.pose.parent_frame, "servicer");
  EXPECT_EQ(p.pose.child_frame, "client");
  // r d reproduces the point to the rounding of a 1.5 km vector (a few ulp).
  EXPECT_LT((p.pose.translation - kTruth).norm(), 8 * kTruth.norm() * 1e-16);
  EXPECT_EQ(p.pose.rotation.coeffs(), Eigen::Quaterniond::Identity().coeffs());
  const Eigen::Matrix3d c = p.covariance.topLeftCorner<3, 3>();
  const Eigen::Vector3d d = b.direction, e = d.unitOrthogonal();
  const double across_variance = std::pow(kTruth.norm() * kAngleSigma, 2);  // 0.09 m^2
  EXPECT_NEAR(d.dot(c * d), kRangeSigma * kRangeSigma, 1e-12);
  EXPECT_NEAR(e.dot(c * e), across_variance, 1e-12);
  EXPECT_NEAR(e.dot(c * d), 0.0, 1e-12);
  // The attitude: not observed, 180 deg per axis, uncorrelated with the position.
  EXPECT_EQ(Eigen::Matrix3d(p.covariance.bottomRightCorner<3, 3>()),
            Eigen::Matrix3d(Eigen::Matrix3d::Identity() * M_PI * M_PI));
  EXPECT_TRUE((p.covariance.topRightCorner<3, 3>().isZero(0.0)));
}

TEST(BearingToPositionRangeAndDirection, TheCovarianceIsHonestOverNoisyBearings) {
  constexpr int kDraws = 2000;
  auto node = make();
  std::mt19937 rng(42);
  double sum_nees = 0;
  for (int i = 0; i < kDraws; ++i) {
    node->in.bearing.set(bearingOf(kTruth, &rng));
    ASSERT_OK(node->process());
    const PoseWithCovariance& p = *node->out.position;
    const Eigen::Vector3d err = p.pose.translation - kTruth;
    sum_nees += err.dot(p.covariance.topLeftCorner<3, 3>().ldlt().solve(err));
  }
  // Independent draws: the sum is chi-square with 3 kDraws dof when the covariance is right
  // (the second-order term, r |delta|^2 / 2 = 3e-5 m, is far below the 0.3 m sigma).
  const double low = chiSquareQuantile(0.025, 3 * kDraws) / kDraws;
  const double high = chiSquareQuantile(0.975, 3 * kDraws) / kDraws;
  const double anees = sum_nees / kDraws;
  RecordProperty("anees_3dof", fmt::format("{:.3f} in [{:.3f}, {:.3f}]", anees, low, high));
  EXPECT_GT(anees, low) << "pessimistic";
  EXPECT_LT(anees, high) << "overconfident";
}

TEST(BearingToPositionRangeAndDirection, ABearingWithoutRangeGivesNoPositionAndAWarning) {
  auto node = make();
  node->in.bearing.set(bearingOf(kTruth, nullptr));
  ASSERT_OK(node->process());
  const void* before = node->out.position.anyValue().raw();
  Bearing b = bearingOf(kTruth, nullptr);
  b.range = b.range_variance = std::numeric_limits<double>::quiet_NaN();
  node->in.bearing.set(b);
  ASSERT_OK(node->process());
  EXPECT_EQ(node->out.position.anyValue().raw(), before) << "a position without a range";
  EXPECT_EQ(node->diagnostics().warning_count, 1u);
  ASSERT_FALSE(node->diagnostics().warnings.empty());
  EXPECT_NE(node->diagnostics().warnings.back().find("no range"), std::string::npos)
      << node->diagnostics().warnings.back();
}

TEST(BearingToPositionRangeAndDirection, BadBearingsAreErrors) {
  auto node = make();
  Bearing b = bearingOf(kTruth, nullptr);
  b.range = -3.0;
  node->in.bearing.set(b);
  testing::expectRejected(*node, "range is -3 m; expected NaN (unknown) or a positive value");

  b = bearingOf(kTruth, nullptr);
  b.direction *= 1.1;
  node->in.bearing.set(b);
  testing::expectRejected(*node, "expected a finite unit vector");

  b = bearingOf(kTruth, nullptr);
  b.direction.x() = std::nan("");
  node->in.bearing.set(b);
  testing::expectRejected(*node, "expected a finite unit vector");

  b = bearingOf(kTruth, nullptr);
  b.covariance(0, 0) = -1e-6;
  node->in.bearing.set(b);
  testing::expectRejected(*node, "positive semi-definite");

  b = bearingOf(kTruth, nullptr);
  b.range_variance = 0.0;  // nothing along the line of sight: singular
  node->in.bearing.set(b);
  testing::expectRejected(*node, "singular position covariance (range variance 0 m^2");

  b = bearingOf(kTruth, nullptr);
  b.frame_id.clear();
  node->in.bearing.set(b);
  testing::expectRejected(*node, "has no frame_id");
}

TEST(BearingToPositionRangeAndDirection, BadParametersAreRejected) {
  auto node = Registry::instance().create("BearingToPosition", "RangeAndDirection");
  ASSERT_TRUE(node.isOk());
  Status s = node.value()->configure(YAML::Load("{target_frame: ''}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("target_frame"), std::string::npos) << s.message();
  s = node.value()->configure(YAML::Load("{unknown_attitude_sigma: 0.5}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("unknown_attitude_sigma"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace cdff::dfn
