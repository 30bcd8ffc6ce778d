#pragma once
// A spinning multi-beam LIDAR's description, published beside its scans as a camera's
// calibration is beside its images: what a consumer needs to know of the sensor's geometry and
// noise without a constant that matches one model.

#include <string>
#include <vector>

#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

/// The description of a spinning LIDAR whose lasers sweep cones about the z axis of `frame_id`
/// (x forward, y left, z up; a VLP-16 in its own frame).
struct LidarInfo {
  Timestamp stamp = 0;
  std::string frame_id;  // the sensor's frame, that of its scans
  /// The lasers' elevations (rad, above the x-y plane), one per laser, in any order (the
  /// simulator lists them in firing order); lasers may share an elevation.
  std::vector<double> elevations;
  double rotation_rate = 10.0;                // Hz, revolutions per second
  double min_range = 0.0, max_range = 100.0;  // m, the returns the sensor reports
  double range_noise = 0.0;                   // m, 1 sigma along the ray

  /// At least one laser, every value finite, elevations within +-90 degrees, rotation_rate > 0,
  /// 0 <= min_range < max_range, range_noise >= 0.
  Status validate() const;
  /// The distinct elevations, lowest first (lasers within `tolerance` rad of each other are one).
  std::vector<double> sortedElevations(double tolerance = 0.0) const;
};

}  // namespace cdff
