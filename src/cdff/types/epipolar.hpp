#pragma once
// Two-view epipolar distances shared by the fundamental and essential matrix DFNs: the same
// formulas whether the 3x3 matrix is F (pixels) or E = [t]x R (normalised image coordinates).

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace cdff {

/// The larger of the distances of b to the epipolar line M a and of a to M^T b (in the units
/// of a and b): the error OpenCV's RANSAC for F and E thresholds.
inline double epipolarDistance(const cv::Matx33d& m, const cv::Point2d& a, const cv::Point2d& b) {
  const cv::Vec3d l2 = m * cv::Vec3d(a.x, a.y, 1), l1 = m.t() * cv::Vec3d(b.x, b.y, 1);
  const double r = b.x * l2[0] + b.y * l2[1] + l2[2];
  return std::max(std::abs(r) / std::hypot(l2[0], l2[1]), std::abs(r) / std::hypot(l1[0], l1[1]));
}

/// The signed Sampson distances of the homogeneous pairs (a_i, b_i) under M: the first-order
/// distance of a pair to the epipolar constraint b^T M a = 0.
inline Eigen::VectorXd sampsonDistances(const std::vector<Eigen::Vector3d>& a,
                                        const std::vector<Eigen::Vector3d>& b,
                                        const Eigen::Matrix3d& m) {
  Eigen::VectorXd out(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Eigen::Vector3d ma = m * a[i], mb = m.transpose() * b[i];
    out(i) = b[i].dot(ma) / std::sqrt(ma.head<2>().squaredNorm() + mb.head<2>().squaredNorm());
  }
  return out;
}

}  // namespace cdff
