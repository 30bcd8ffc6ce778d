#pragma once
// The checks of a scan's companions, shared by the DFNs that register against a model (their
// ports `source`, `model`, `sensor` and a source_T_model pose): the LIDAR description given
// beside the scan, valid and of the scan's frame; a pose between the scan's and the model's
// frames; and the description's distinct laser elevations, sorted once per description.

#include <span>
#include <string_view>
#include <vector>

#include "cdff/registration/ring_visibility.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/lidar_info.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff::registration {

/// OK without a description (`sensor` null); else its validate(), and its frame the scan's
/// (the input `scan_port`).
inline Status checkScanSensor(const PointCloud& source, const LidarInfo* sensor,
                              std::string_view scan_port = "source") {
  if (sensor == nullptr) return Status::ok();
  CDFF_RETURN_IF_ERROR(sensor->validate().withContext("input 'sensor'"));
  if (sensor->frame_id != source.frame_id)
    return invalidInput(
        "input 'sensor' describes the LIDAR of frame '{}' but input '{}' is in frame '{}'; "
        "expected the description of the sensor that took the scan (the same frame)",
        sensor->frame_id, scan_port, source.frame_id);
  return Status::ok();
}

/// The input `port` holds a valid source_T_model: its frames those of `source` and `model`
/// (an empty frame name matches any).
inline Status checkSourceTModel(const Transform& pose, const PointCloud& source,
                                const PointCloud& model, std::string_view port) {
  CDFF_RETURN_IF_ERROR(pose.validate().withContext(fmt::format("input '{}'", port)));
  const bool parent_ok =
      pose.parent_frame.empty() || source.frame_id.empty() || pose.parent_frame == source.frame_id;
  const bool child_ok =
      pose.child_frame.empty() || model.frame_id.empty() || pose.child_frame == model.frame_id;
  if (!parent_ok || !child_ok)
    return invalidInput(
        "input '{}' is {}_T_{}; expected source_T_model = {}_T_{} (the frames of 'source' and "
        "'model')",
        port, pose.parent_frame, pose.child_frame, source.frame_id, model.frame_id);
  return Status::ok();
}

/// A LIDAR's distinct laser elevations, lowest first (RingVisibility::setScan's `lasers`),
/// sorted again only when the description's elevations change (one comes with every scan).
class LaserElevations {
 public:
  /// None without a description.
  std::span<const double> of(const LidarInfo* sensor) {
    if (sensor == nullptr) return {};
    if (sensor->elevations != sorted_from_) {
      sorted_ = sensor->sortedElevations(RingVisibility::kSameRing);
      sorted_from_ = sensor->elevations;
    }
    return sorted_;
  }

 private:
  std::vector<double> sorted_from_;  // the elevations sorted_ was sorted from
  std::vector<double> sorted_;
};

}  // namespace cdff::registration
