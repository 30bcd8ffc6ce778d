#pragma once
// Shared by the PointCloudAssembly DFIs: the input checks (cloud, pose, frames, stamps), the
// voxel index of a point and the statistics output.

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "PointCloudAssembly.gen.hpp"

namespace cdff::dfn::assembly {

/// 21 bits per axis: voxel indices within +-(2^20 - 1) pack into one 64-bit key, with room for
/// the neighbours' indices (one more on either side) in the same bits.
constexpr std::int64_t kHalfRange = std::int64_t{1} << 20;

inline bool isFinite(const Point4f& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

/// The voxel index of `p` (model frame, m) packed into 63 bits, or nothing when an index is
/// beyond +-(2^20 - 1).
inline std::optional<std::uint64_t> voxelKey(const Eigen::Vector3d& p, double inverse_size) {
  const Eigen::Vector3d f = (p * inverse_size).array().floor();
  if (!(f.cwiseAbs().maxCoeff() < static_cast<double>(kHalfRange - 1))) return std::nullopt;
  const auto axis = [](double v) {
    return static_cast<std::uint64_t>(std::int64_t(v) + kHalfRange);
  };
  return (axis(f.x()) << 42) | (axis(f.y()) << 21) | axis(f.z());
}

/// The key of the voxel `(dx, dy, dz)` away from `key` (each in -1..1; voxelKey leaves room for
/// them).
inline std::uint64_t neighbourKey(std::uint64_t key, int dx, int dy, int dz) {
  return key + static_cast<std::uint64_t>((static_cast<std::int64_t>(dx) << 42) +
                                          (static_cast<std::int64_t>(dy) << 21) +
                                          static_cast<std::int64_t>(dz));
}

/// Checks one call's inputs against each other and against the map's frame (empty before the
/// first fused cloud).
inline Status checkInputs(const PointCloud& cloud, const PoseWithCovariance& pose,
                          const std::string& map_frame, double max_pose_offset) {
  CDFF_RETURN_IF_ERROR(cloud.validate("input 'cloud'", /*require_finite=*/false));
  CDFF_RETURN_IF_ERROR(pose.validate().withContext("input 'pose'"));
  if (pose.pose.child_frame != cloud.frame_id)
    return invalidInput(
        "input 'pose' is {}_T_{} but input 'cloud' is in frame '{}'; expected the pose of the "
        "cloud's frame (model_T_{})",
        pose.pose.parent_frame, pose.pose.child_frame, cloud.frame_id, cloud.frame_id);
  if (!map_frame.empty() && pose.pose.parent_frame != map_frame)
    return invalidInput(
        "input 'pose' is {}_T_{} but the map is in frame '{}' (the first fused pose's parent); "
        "expected every pose in the model frame '{}' (or a reset)",
        pose.pose.parent_frame, pose.pose.child_frame, map_frame, map_frame);
  const double offset = std::abs(toSeconds(cloud.stamp - pose.pose.stamp));
  if (offset > max_pose_offset + 1e-9)
    return invalidInput(
        "input 'pose' is stamped {} us, {:.6f} s from the cloud at {} us; expected within "
        "max_pose_offset = {} s (the pose of the cloud's own instant)",
        pose.pose.stamp, offset, cloud.stamp, max_pose_offset);
  return Status::ok();
}

/// The counters of the statistics output.
struct Statistics {
  std::uint64_t frames = 0, points = 0, skipped_points = 0, voxels = 0, supported_voxels = 0,
                outliers_removed = 0, output_points = 0;

  nlohmann::json toJson() const {
    return {{"frames", frames},
            {"points", points},
            {"skipped_points", skipped_points},
            {"voxels", voxels},
            {"supported_voxels", supported_voxels},
            {"outliers_removed", outliers_removed},
            {"output_points", output_points}};
  }
};

/// The warnings of a call: skipped non-finite points, a cloud that fused nothing.
template <typename Warn>
void warnSkipped(const PointCloud& cloud, std::size_t skipped, Warn&& warn) {
  if (skipped == 0) return;
  if (skipped == cloud.size())
    warn(fmt::format(
        "input 'cloud' at {} us (frame '{}') has no finite point ({} points): nothing fused, "
        "the frame is not counted",
        cloud.stamp, cloud.frame_id, cloud.size()));
  else
    warn(
        fmt::format("input 'cloud' at {} us (frame '{}'): {} of {} points are not finite and "
                    "were skipped",
                    cloud.stamp, cloud.frame_id, skipped, cloud.size()));
}

}  // namespace cdff::dfn::assembly
