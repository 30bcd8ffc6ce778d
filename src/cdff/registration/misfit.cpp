#include "cdff/registration/misfit.hpp"

#include <cmath>

#include "cdff/registration/quality.hpp"

namespace cdff::registration {

double misfit(std::span<const Eigen::Vector3f> points, const ModelIndex& model,
              const Eigen::Isometry3d& pose, double inlier_distance, double visibility) {
  return misfit(evaluate(points, model, pose, inlier_distance, 1.0), points.size(), inlier_distance,
                visibility);
}

double misfit(const Quality& q, std::size_t returns, double inlier_distance, double visibility) {
  const double sigma = inlier_distance / 3.0;
  const double n = static_cast<double>(returns);
  double cost = (n - static_cast<double>(q.inliers)) * kUnmatchedCost;
  if (q.inliers > 0)
    cost += static_cast<double>(q.inliers) * q.inlier_rms * q.inlier_rms / (sigma * sigma);
  if (std::isfinite(visibility)) cost += (1.0 - visibility) * n * kUnmatchedCost;
  return cost;
}

}  // namespace cdff::registration
