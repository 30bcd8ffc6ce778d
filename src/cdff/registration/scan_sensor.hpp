#pragma once
// The check of a LIDAR description given beside a scan, shared by the DFNs that take both (their
// ports `sensor` and `source`): valid, and of the scan's frame.

#include "cdff/types/lidar_info.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff::registration {

/// OK without a description (`sensor` null); else its validate(), and its frame the scan's.
inline Status checkScanSensor(const PointCloud& source, const LidarInfo* sensor) {
  if (sensor == nullptr) return Status::ok();
  CDFF_RETURN_IF_ERROR(sensor->validate().withContext("input 'sensor'"));
  if (sensor->frame_id != source.frame_id)
    return invalidInput(
        "input 'sensor' describes the LIDAR of frame '{}' but input 'source' is in frame '{}'; "
        "expected the description of the sensor that took the scan (the same frame)",
        sensor->frame_id, source.frame_id);
  return Status::ok();
}

}  // namespace cdff::registration
