#pragma once
// Shared by the PointCloudFiltering DFIs: parameter and input checks, the crop box's transform,
// and copying the kept points with all their fields.

#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "PointCloudFiltering.gen.hpp"

namespace cdff::dfn::filtering {

template <typename Parameters>
Status checkParameters(const Parameters& p) {
  for (int i = 0; i < 3; ++i)
    if (!(p.crop_min[i] < p.crop_max[i]))
      return invalidParameter(
          "parameter 'crop_min'[{}] = {} is not below 'crop_max'[{}] = {}; expected a box "
          "with min < max on every axis",
          i, p.crop_min[i], i, p.crop_max[i]);
  return Status::ok();
}

/// Checks the cloud (finite coordinates not required) and returns box_T_cloud, the transform
/// that brings the cloud's points into the crop box's frame.
inline Result<Eigen::Isometry3f> checkInputs(const PointCloud& cloud, const Transform* box_pose) {
  CDFF_RETURN_IF_ERROR(cloud.validate("input 'cloud'", /*require_finite=*/false));
  if (box_pose == nullptr) return Eigen::Isometry3f::Identity();
  CDFF_RETURN_IF_ERROR(box_pose->validate().withContext("input 'box_pose'"));
  if (!box_pose->parent_frame.empty() && !cloud.frame_id.empty() &&
      box_pose->parent_frame != cloud.frame_id)
    return invalidInput(
        "input 'box_pose' is {}_T_{}; expected its parent frame to be the cloud's frame '{}'",
        box_pose->parent_frame, box_pose->child_frame, cloud.frame_id);
  return Eigen::Isometry3f(box_pose->isometry().inverse().cast<float>());
}

inline bool isFinite(const Point4f& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

template <typename T>
Buffer<T> gather(const Buffer<T>& values, const std::vector<std::uint32_t>& keep) {
  if (values.empty()) return {};
  std::vector<T> out;
  out.reserve(keep.size());
  for (std::uint32_t i : keep) out.push_back(values[i]);
  return Buffer<T>::fromVector(std::move(out));
}

/// The points of `cloud` at `keep` (in that order), with every optional field.
inline PointCloud subset(const PointCloud& cloud, const std::vector<std::uint32_t>& keep) {
  PointCloud out;
  out.stamp = cloud.stamp;
  out.frame_id = cloud.frame_id;
  if (keep.size() == cloud.size()) {
    out = cloud;  // nothing removed: share every buffer
    return out;
  }
  out.points = gather(cloud.points, keep);
  out.normals = gather(cloud.normals, keep);
  out.intensity = gather(cloud.intensity, keep);
  out.ring = gather(cloud.ring, keep);
  out.time_offset_us = gather(cloud.time_offset_us, keep);
  return out;
}

/// Sets both outputs, with a warning (through `warn`) when nothing is left.
template <typename Warn>
void publish(PointCloudFiltering::Outputs& out, const PointCloud& input, PointCloud filtered,
             Warn&& warn) {
  const double fraction =
      input.empty() ? 0.0
                    : static_cast<double>(filtered.size()) / static_cast<double>(input.size());
  if (filtered.empty())
    warn(fmt::format("no point of the {} in input 'cloud' (frame '{}') passed the filters",
                     input.size(), input.frame_id));
  out.filtered.set(std::move(filtered));
  out.kept_fraction.set(fraction);
}

}  // namespace cdff::dfn::filtering
