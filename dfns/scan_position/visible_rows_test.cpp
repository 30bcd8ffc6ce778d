// The visible-surface model of ScanPosition: its attitudes spread over SO(3), and its offsets
// against ray-cast scans of the same target at the same attitudes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "scan_position_testing.hpp"
#include "visible_rows.hpp"

namespace cdff::dfn::scan_position {
namespace {

using scan_position_testing::kDeg;
using scan_position_testing::satelliteModel;

// Evenly spread rotations average to zero: the mean rotation matrix of a uniform set is 0, and
// every quaternion has unit norm.
TEST(VisibleRows, TheAttitudesAreSpreadOverSO3) {
  const std::vector<Eigen::Vector4d> q = VisibleRows::spreadAttitudes(200);
  ASSERT_EQ(q.size(), 200u);
  Eigen::Matrix3d mean = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector4d& v : q) {
    EXPECT_NEAR(v.norm(), 1.0, 1e-12);
    mean += Eigen::Quaterniond(v.w(), v.x(), v.y(), v.z()).toRotationMatrix() / 200.0;
  }
  // A random set of 200 would give entries of about 1/sqrt(3 x 200) = 0.04.
  EXPECT_LT(mean.cwiseAbs().maxCoeff(), 0.02);
}

// The scans of the model's own attitudes, each at 8 random ring phases, from the target straight
// ahead: the ray-cast offsets (origin - centroid of the returns, line-of-sight frame) have the
// mean and spread that the rows give for the same lasers.
TEST(VisibleRows, TheOffsetsAreThoseOfRayCastScans) {
  const ViewableModel model = ViewableModel::of(satelliteModel()).value();
  const std::vector<Eigen::Vector4d> attitudes = VisibleRows::spreadAttitudes(200);
  for (const double range : {15.0, 50.0}) {
    SCOPED_TRACE(::testing::Message() << "range " << range << " m");
    const VisibleRows rows = VisibleRows::build(model, 200, range);
    testing::ScanOptions o;  // lasers every 2 deg at odd degrees
    o.min_azimuth = -std::asin(model.radius / range) - kDeg;
    o.max_azimuth = -o.min_azimuth;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> phase(-1.0, 1.0);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d sum_sq = Eigen::Matrix3d::Zero();
    int n = 0;
    for (int a = 0; a < 200; ++a)
      for (int k = 0; k < 8; ++k) {
        const double el = phase(rng) * kDeg;  // one gap between the lasers at -1 and 1 deg
        const Eigen::Vector3d u(std::cos(el), 0, std::sin(el));
        const Eigen::Vector3d z = (Eigen::Vector3d::UnitZ() - u.z() * u).normalized();
        Eigen::Matrix3d los;
        los << u, z.cross(u), z;
        const Eigen::Quaterniond q(attitudes[a].w(), attitudes[a].x(), attitudes[a].y(),
                                   attitudes[a].z());
        const Eigen::Isometry3d lidar_T_target =
            Eigen::Translation3d(range * u) * Eigen::Isometry3d(los * q.toRotationMatrix());
        const PointCloud scan =
            testing::simulateScan(testing::satelliteMesh(), lidar_T_target, o, 100 * a + k);
        if (scan.empty()) continue;
        const Eigen::Vector3d c = scan.xyzMatrix().cast<double>().rowwise().mean();
        const Eigen::Vector3d offset = los.transpose() * (range * u - c);
        sum += offset;
        sum_sq += offset * offset.transpose();
        ++n;
      }
    const Eigen::Vector3d mean = sum / n;
    const Eigen::Matrix3d cov = sum_sq / n - mean * mean.transpose();
    std::vector<double> heights;
    for (int k = 0; k < 16; ++k) heights.push_back(range * std::tan((-15.0 + 2 * k) * kDeg));
    const OffsetStatistics model_offsets = rows.offsets(heights, range * 2 * kDeg);
    std::printf(
        "range %.0f m: ray-cast offset mean (%.3f, %.3f, %.3f) m, variances (%.4f, %.4f, %.4f) "
        "m^2; rows: (%.3f, %.3f, %.3f) m, (%.4f, %.4f, %.4f) m^2\n",
        range, mean.x(), mean.y(), mean.z(), cov(0, 0), cov(1, 1), cov(2, 2),
        model_offsets.mean.x(), model_offsets.mean.y(), model_offsets.mean.z(),
        model_offsets.covariance(0, 0), model_offsets.covariance(1, 1),
        model_offsets.covariance(2, 2));
    // The depth offset to 3 cm (its standard error over 1600 scans is 0.5 cm at 15 m); the
    // lateral means are 0 by symmetry; the variances within 25 % (the standard error of a
    // variance over 1600 draws of a skewed distribution is about 5 %; the rows are a model).
    EXPECT_NEAR(model_offsets.mean.x(), mean.x(), 0.03);
    EXPECT_NEAR(model_offsets.mean.y(), 0.0, 0.03);
    EXPECT_NEAR(model_offsets.mean.z(), 0.0, 0.03);
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(model_offsets.covariance(i, i), cov(i, i), 0.25 * cov(i, i)) << "axis " << i;
  }
}

}  // namespace
}  // namespace cdff::dfn::scan_position
