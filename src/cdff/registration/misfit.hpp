#pragma once
// How badly a pose explains a scan, in squared noise units (noise sigma = inlier_distance / 3):
// the inliers' point-to-plane residuals, every unmatched return as one at the inlier distance,
// and the fraction of the visible model surface without a return (1 - visibility) as that
// fraction of the returns unmatched. Additive over scans: a negative log-likelihood up to a
// constant, the score that the hypothesis confirmation sums.

#include <span>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/registration/model_index.hpp"
#include "cdff/registration/quality.hpp"

namespace cdff::registration {

/// The cost of an unmatched return: (inlier_distance / sigma)^2 with sigma a third of it.
inline constexpr double kUnmatchedCost = 9.0;

/// The misfit of source_T_model `pose` on the scan `points`; `visibility` (RingVisibility) is
/// left out when it is NaN.
double misfit(std::span<const Eigen::Vector3f> points, const ModelIndex& model,
              const Eigen::Isometry3d& pose, double inlier_distance, double visibility);

/// The same misfit from the pose's Quality on `returns` points at `inlier_distance` (evaluate()
/// with that distance), for a caller that has it already.
double misfit(const Quality& quality, std::size_t returns, double inlier_distance,
              double visibility);

}  // namespace cdff::registration
