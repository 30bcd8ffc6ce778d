#pragma once
// Shared by the NormalsEstimation DFIs: orienting a normal and publishing the points that got
// one.

#include <cmath>
#include <cstdint>
#include <vector>

#include "NormalsEstimation.gen.hpp"

namespace cdff::dfn::normals {

/// Unit `n` turned to face `viewpoint` from `p`; false when n is not a usable direction.
inline bool orient(Eigen::Vector3f& n, const Eigen::Vector3f& p, const Eigen::Vector3f& viewpoint) {
  const float norm = n.norm();
  if (!std::isfinite(norm) || norm < 1e-12f) return false;
  n /= norm;
  if (n.dot(viewpoint - p) < 0) n = -n;
  return true;
}

/// The points at `keep` with `normals` (one per kept point), every other field kept.
template <typename Warn>
void publish(NormalsEstimation::Outputs& out, const PointCloud& cloud,
             const std::vector<std::uint32_t>& keep, std::vector<Point4f>&& normals, Warn&& warn) {
  PointCloud result;
  if (keep.size() == cloud.size()) {
    result = cloud;  // shares the points and every other field
  } else {
    warn(
        fmt::format("{} of {} points have fewer than 3 neighbours and no normal; they are left out",
                    cloud.size() - keep.size(), cloud.size()));
    auto gather = [&](const auto& values) {
      using T = std::decay_t<decltype(values[0])>;
      if (values.empty()) return Buffer<T>{};
      std::vector<T> v;
      v.reserve(keep.size());
      for (std::uint32_t i : keep) v.push_back(values[i]);
      return Buffer<T>::fromVector(std::move(v));
    };
    result.stamp = cloud.stamp;
    result.frame_id = cloud.frame_id;
    result.points = gather(cloud.points);
    result.intensity = gather(cloud.intensity);
    result.ring = gather(cloud.ring);
    result.time_offset_us = gather(cloud.time_offset_us);
  }
  for (Point4f& n : normals) n.pad = 0.0f;
  result.normals = Buffer<Point4f>::fromVector(std::move(normals));
  out.with_normals.set(std::move(result));
}

}  // namespace cdff::dfn::normals
