#include "cdff/types/lidar_info.hpp"

#include <algorithm>
#include <cmath>

namespace cdff {

Status LidarInfo::validate() const {
  if (elevations.empty())
    return invalidInput("LIDAR info '{}' has no laser elevation; expected at least one laser",
                        frame_id);
  for (std::size_t i = 0; i < elevations.size(); ++i)
    if (!std::isfinite(elevations[i]) || std::abs(elevations[i]) > M_PI / 2)
      return invalidInput(
          "LIDAR info '{}' laser {} elevation is {} rad; expected a finite angle within +-pi/2 "
          "rad (+-90 degrees)",
          frame_id, i, elevations[i]);
  if (!std::isfinite(rotation_rate) || rotation_rate <= 0)
    return invalidInput("LIDAR info '{}' rotation_rate is {} Hz; expected a finite rate > 0",
                        frame_id, rotation_rate);
  if (!std::isfinite(min_range) || !std::isfinite(max_range) || min_range < 0 ||
      max_range <= min_range)
    return invalidInput(
        "LIDAR info '{}' range is [{}, {}] m; expected finite bounds with 0 <= min_range < "
        "max_range",
        frame_id, min_range, max_range);
  if (!std::isfinite(range_noise) || range_noise < 0)
    return invalidInput("LIDAR info '{}' range_noise is {} m; expected a finite sigma >= 0",
                        frame_id, range_noise);
  return Status::ok();
}

std::vector<double> LidarInfo::sortedElevations(double tolerance) const {
  std::vector<double> sorted = elevations;
  std::sort(sorted.begin(), sorted.end());
  std::vector<double> distinct;
  for (const double e : sorted)
    if (distinct.empty() || e - distinct.back() > tolerance) distinct.push_back(e);
  return distinct;
}

}  // namespace cdff
