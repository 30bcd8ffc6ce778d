#include "cdff/types/bearing.hpp"

#include <cmath>

#include <Eigen/Eigenvalues>

namespace cdff {

double Bearing::azimuth() const {
  return std::atan2(direction.y(), direction.x());
}

double Bearing::elevation() const {
  return std::atan2(direction.z(), std::hypot(direction.x(), direction.y()));
}

Status Bearing::validate() const {
  const std::string what = fmt::format("bearing in '{}'", frame_id);
  if (!direction.allFinite() || std::abs(direction.norm() - 1.0) > 1e-6)
    return invalidInput("{}: direction ({}, {}, {}) has norm {}; expected a finite unit vector",
                        what, direction.x(), direction.y(), direction.z(), direction.norm());
  if (!covariance.allFinite() || !covariance.isApprox(covariance.transpose(), 1e-9) ||
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance).eigenvalues().minCoeff() <
          -1e-12 * (1.0 + covariance.norm()))
    return invalidInput(
        "{}: direction covariance is not finite, symmetric and positive semi-definite", what);
  if (!std::isnan(range) && !(range > 0 && std::isfinite(range)))
    return invalidInput("{}: range is {} m; expected NaN (unknown) or a positive value", what,
                        range);
  if (!std::isnan(range) && !(range_variance >= 0))
    return invalidInput("{}: range variance is {} m^2; expected a non-negative value", what,
                        range_variance);
  if (!std::isnan(range_rate) && (!std::isfinite(range_rate) || !(range_rate_variance >= 0)))
    return invalidInput(
        "{}: range rate {} m/s with variance {}; expected a finite rate and a non-negative "
        "variance",
        what, range_rate, range_rate_variance);
  return Status::ok();
}

}  // namespace cdff
