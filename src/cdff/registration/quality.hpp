#pragma once
// How well a pose registers a scan, measured the same way for every registration method at its
// final pose: the fitness, the inlier RMS and the Gauss-Newton covariance of the point-to-plane
// problem over the inliers.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/registration/model_index.hpp"
#include "cdff/types/geometry.hpp"

namespace cdff::registration {

/// What counts as an inlier, and the covariance's inflation.
struct QualityOptions {
  double inlier_distance = 0.1;  // m
  /// Factor on the Gauss-Newton covariance for what it ignores (correlated residuals, model
  /// discretisation).
  double covariance_inflation = 1.5;
};

struct Quality {
  double fitness = 0;  // fraction of the scan's points with a model point within inlier_distance
  double inlier_rms = std::numeric_limits<double>::quiet_NaN();  // point-to-plane, m
  std::size_t inliers = 0;
  Matrix6d covariance = Matrix6d::Zero();  // [dt, dtheta] in the source frame
  bool degenerate = false;                 // some direction is barely constrained
};

/// The quality of source_T_model `pose` for the scan `source` (source frame).
///
/// Residual of a source point p (source frame) paired with the model point q and normal n (model
/// frame), with n' = R n and q' = R q + t in the source frame: r = n' . (p - q'). Perturbing the
/// pose as the conventions do (t + dt, exp(dtheta) R) gives the Jacobian
/// dr/d[dt, dtheta] = [-n', n' x (p - t)]. The covariance is sigma^2 (J^T J)^-1, sigma^2 the
/// inliers' residual variance, times `covariance_inflation` (for what it ignores: correlated
/// residuals, model discretisation).
///
/// `hints` (one model index per source point, or ~0u) are earlier matches that bound each
/// search: the result is the same, found faster.
Quality evaluate(std::span<const Eigen::Vector3f> source, const ModelIndex& model,
                 const Eigen::Isometry3d& pose, double inlier_distance, double covariance_inflation,
                 const std::vector<std::uint32_t>* hints = nullptr);

}  // namespace cdff::registration
