#pragma once
// The direction to the target from the servicer, with its range where a sensor measures it: the
// product of far-range tracking (seed §4.1.1), where a camera sees a direction and a radar, if
// any, the range.

#include <limits>
#include <string>

#include <Eigen/Core>

#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

struct Bearing {
  Timestamp stamp = 0;
  std::string frame_id;                                  // the frame of `direction` (servicer)
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // unit norm, in frame_id
  /// Covariance of the direction (rad^2 across it: rank 2, zero along it).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  /// Range (m) and range rate (m/s, positive opening) with their variances; NaN when unknown.
  double range = std::numeric_limits<double>::quiet_NaN();
  double range_variance = std::numeric_limits<double>::quiet_NaN();
  double range_rate = std::numeric_limits<double>::quiet_NaN();
  double range_rate_variance = std::numeric_limits<double>::quiet_NaN();
  /// Which designation started the track ("user", "automatic"); empty when unknown.
  std::string designation;

  /// REP-103 angles of `direction` in frame_id (x forward, y left, z up): azimuth atan2(y, x),
  /// positive to the left; elevation atan2(z, hypot(x, y)), positive up. Radians.
  double azimuth() const;
  double elevation() const;

  /// Ok when the direction is finite with unit norm (1e-6), the covariance finite, symmetric and
  /// positive semi-definite, the range NaN or positive with a non-negative variance, the range
  /// rate NaN or finite with a non-negative variance; the error names the field and its value.
  Status validate() const;
};

}  // namespace cdff
