#pragma once
// Shared by the KeypointExtraction3D DFIs: the cloud's extent and point spacing (from which the
// default radii follow), the check of an explicit radius, and the output built from the indices
// of the chosen points. No PCL here: this header is cheap to include.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "KeypointExtraction3D.gen.hpp"
#include "cdff/types/kd_tree.hpp"
#include "cdff/types/point_spacing.hpp"

namespace cdff::dfn::keypoints {

/// The axis-aligned bounding box of the cloud's points.
struct Extent {
  Eigen::Vector3f min = Eigen::Vector3f::Zero();
  Eigen::Vector3f max = Eigen::Vector3f::Zero();
  double diagonal() const { return (max - min).cast<double>().norm(); }
};

/// The bounding box of a non-empty cloud with finite points (checked by validate() first).
inline Extent extentOf(const PointCloud& cloud) {
  Extent extent;
  extent.min = extent.max = cloud.points[0].vec();
  for (const Point4f& p : cloud.points) {
    extent.min = extent.min.cwiseMin(p.vec());
    extent.max = extent.max.cwiseMax(p.vec());
  }
  return extent;
}

/// An explicit radius must not exceed the cloud's extent: a larger one holds the whole cloud in
/// one neighbourhood (one voxel, one scatter matrix), which is a unit or configuration mistake.
inline Status checkRadiusAgainstExtent(const char* parameter, double radius, const Extent& extent) {
  if (radius <= extent.diagonal()) return Status::ok();
  return invalidParameter(
      "parameter '{}' = {} m is larger than the extent of input 'cloud' (bounding-box diagonal "
      "{:.4g} m); expected a radius at most that, or 0 to derive it from the point spacing",
      parameter, radius, extent.diagonal());
}

/// The keypoints at `indices` (points of `cloud`, in increasing order): positions, and normals
/// when the cloud has them (a non-finite or zero normal is given as the zero vector, "unknown").
inline Features3D keypointsAt(const PointCloud& cloud, std::vector<std::uint32_t> indices) {
  std::sort(indices.begin(), indices.end());
  Features3D features;
  features.stamp = cloud.stamp;
  features.frame_id = cloud.frame_id;
  features.keypoints.reserve(indices.size());
  for (std::uint32_t i : indices) {
    Keypoint3D keypoint;
    keypoint.position = cloud.points[i].vec();
    if (cloud.hasNormals()) {
      const Eigen::Vector3f n = cloud.normals[i].vec();
      const float norm = n.norm();
      if (std::isfinite(norm) && norm > 1e-12f) keypoint.normal = n / norm;
    }
    features.keypoints.push_back(keypoint);
  }
  return features;
}

/// No keypoint, the cloud's frame and stamp: the output of a cloud too small to give any.
inline Features3D noKeypoints(const PointCloud& cloud) {
  return keypointsAt(cloud, {});
}

}  // namespace cdff::dfn::keypoints
