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

/// The cloud's point spacing s: the pitch of its sampling, sqrt(surface area per point),
/// estimated from the distance r8 to the 8th nearest other point as s = r8 sqrt(pi / 8) (on a
/// surface of density 1/s^2, a disc of radius r8 holds 8 points). The 8th neighbour rather than
/// the nearest because it gives the same s, within 10 %, for a regular grid (the nearest is then
/// s) and for random samples (the nearest is then about s/2): a radius that follows s holds
/// about the same number of points whatever the sampling. The median over the points, so that
/// outliers and a scan's sparse rim do not move it; at most `max_samples` points, evenly spread
/// over the cloud's order, are queried (the median of 4096 is within a few percent of the full
/// one, at a fixed cost of about 1 ms). 0 when no point has 8 distinct others (a tiny cloud, or
/// all points coincide).
inline double pointSpacing(const PointCloud& cloud, std::size_t max_samples = 4096) {
  constexpr int kNeighbours = 8;
  const KdTree3f tree(cloud.points.span());
  const std::size_t step = std::max<std::size_t>(1, cloud.size() / max_samples);
  std::vector<KdTree3f::Neighbour> found;
  std::vector<float> distances;
  distances.reserve(cloud.size() / step + 1);
  for (std::size_t i = 0; i < cloud.size(); i += step) {
    tree.kNearest(cloud.points[i].vec(), kNeighbours + 1, found);  // the point itself first
    if (found.size() == kNeighbours + 1 && found.back().squared_distance > 0)
      distances.push_back(std::sqrt(found.back().squared_distance));
  }
  if (distances.empty()) return 0;
  auto middle = distances.begin() + static_cast<std::ptrdiff_t>(distances.size() / 2);
  std::nth_element(distances.begin(), middle, distances.end());
  return *middle * std::sqrt(M_PI / kNeighbours);
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
