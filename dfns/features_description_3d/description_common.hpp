#pragma once
// Shared by the FeaturesDescription3D DFIs, without PCL: the input checks, the support radius
// (given, or derived from the surface's point spacing), each keypoint's normal, and the output
// (the keypoints whose descriptor is finite).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "FeaturesDescription3D.gen.hpp"
#include "cdff/types/kd_tree.hpp"
#include "cdff/types/point_spacing.hpp"

namespace cdff::dfn::description {

/// A normal is accepted as unit when its norm is within this of 1: float normals from any
/// estimator are unit to ~1e-6, while a normal that was never normalised is off by far more.
inline constexpr float kUnitNormTolerance = 1e-3f;
/// Checks the keypoints: finite positions, and normals that are unit or zero (unknown).
inline Status checkKeypoints(const Features3D& keypoints) {
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const Eigen::Vector3f& p = keypoints.keypoints[i].position;
    if (!p.allFinite())
      return invalidInput(
          "input 'keypoints' keypoint {} has the position ({}, {}, {}); expected finite "
          "coordinates",
          i, p.x(), p.y(), p.z());
    const Eigen::Vector3f& n = keypoints.keypoints[i].normal;
    if (!n.allFinite())
      return invalidInput(
          "input 'keypoints' keypoint {} has the normal ({}, {}, {}); expected a finite unit "
          "vector, or zero when unknown",
          i, n.x(), n.y(), n.z());
    const float norm = n.norm();
    if (norm != 0.0f && std::abs(norm - 1.0f) > kUnitNormTolerance)
      return invalidInput(
          "input 'keypoints' keypoint {} has a normal of norm {}; expected a unit vector, or "
          "zero when unknown",
          i, norm);
  }
  return keypoints.validate("input 'keypoints'");  // the descriptors' shape, if any
}

/// Checks the surface: finite points, unit normals, the keypoints' frame.
inline Status checkSurface(const PointCloud& surface, const Features3D& keypoints) {
  CDFF_RETURN_IF_ERROR(surface.validate("input 'surface'"));
  if (!surface.hasNormals())
    return invalidInput(
        "input 'surface' ({} points) has no normals; expected a cloud with normals (run "
        "NormalsEstimation on it first)",
        surface.size());
  for (std::size_t i = 0; i < surface.size(); ++i) {
    const Eigen::Vector3f n = surface.normals[i].vec();
    const float norm = n.norm();
    if (!std::isfinite(norm) || std::abs(norm - 1.0f) > kUnitNormTolerance)
      return invalidInput(
          "input 'surface' normal {} is ({}, {}, {}) (norm {}); expected a finite unit vector", i,
          n.x(), n.y(), n.z(), norm);
  }
  if (!surface.frame_id.empty() && !keypoints.frame_id.empty() &&
      surface.frame_id != keypoints.frame_id)
    return invalidInput(
        "input 'surface' is in frame '{}' but input 'keypoints' in frame '{}'; expected both in "
        "one frame",
        surface.frame_id, keypoints.frame_id);
  return Status::ok();
}

/// The diagonal of the surface's bounding box, m.
inline double extent(const PointCloud& surface) {
  const auto xyz = surface.xyzMatrix();
  return static_cast<double>((xyz.rowwise().maxCoeff() - xyz.rowwise().minCoeff()).norm());
}

/// What both DFIs work from once the inputs are checked.
struct Support {
  double radius = 0;                              // m, of the descriptor's support
  double spacing = 0;                             // m, of the surface (0 when not needed)
  double extent = 0;                              // m, the surface's bounding-box diagonal
  std::vector<Eigen::Vector3f> keypoint_normals;  // one unit normal per keypoint
};

/// Checks a radius parameter given as a positive value against the surface's extent.
inline Status checkRadius(const char* parameter, double value, double extent) {
  if (value > extent)
    return invalidParameter(
        "parameter '{}' = {} m is larger than the extent of input 'surface' (its bounding box's "
        "diagonal, {} m); expected at most {} m, or 0 to derive it from the surface's point "
        "spacing",
        parameter, value, extent, extent);
  return Status::ok();
}

/// Checks both inputs and works out the support radius: `radius` when positive, else
/// `multiple` times the surface's point spacing. Call only with at least one keypoint.
inline Result<Support> prepare(const Features3D& keypoints, const PointCloud& surface,
                               double radius, double multiple) {
  CDFF_RETURN_IF_ERROR(checkSurface(surface, keypoints));
  Support support;
  support.extent = extent(surface);
  const KdTree3f tree(surface.points.span(), 12, surface.normals.span());
  if (radius > 0) {
    CDFF_RETURN_IF_ERROR(checkRadius("radius", radius, support.extent));
    support.radius = radius;
  } else {
    support.spacing = pointSpacing(surface);
    if (support.spacing <= 0)
      return invalidInput(
          "input 'surface' has no point with 8 distinct neighbours ({} points); expected a "
          "sampled surface, to derive parameter 'radius' = 0 from its point spacing (or set a "
          "positive radius)",
          surface.size());
    support.radius = multiple * support.spacing;
  }
  // A keypoint without a normal takes its nearest surface point's: the surface it describes.
  support.keypoint_normals.reserve(keypoints.size());
  for (const Keypoint3D& k : keypoints.keypoints) {
    if (k.normal.squaredNorm() > 0) {
      support.keypoint_normals.push_back(k.normal);
      continue;
    }
    KdTree3f::Neighbour nearest;
    tree.nearest(k.position, std::numeric_limits<float>::infinity(), nearest);
    support.keypoint_normals.push_back(surface.normals[nearest.index].vec());
  }
  return support;
}

/// The output for no keypoint: none, with descriptors of the DFI's kind and length.
inline Features3D emptyFeatures(const Features3D& keypoints, int descriptor_length) {
  Features3D features;
  features.stamp = keypoints.stamp;
  features.frame_id = keypoints.frame_id;
  features.descriptors.element = DescriptorMatrix::Element::kFloat32;
  features.descriptors.distance = DescriptorMatrix::Distance::kL2;
  features.descriptors.cols = descriptor_length;
  return features;
}

/// The keypoints whose descriptor (row i of `descriptors`, `descriptor_length` floats) is
/// finite, with their normals and descriptors; warns with the count of the others.
template <typename Warn>
Features3D keepFinite(const Features3D& keypoints, const Support& support,
                      const std::vector<float>& descriptors, int descriptor_length,
                      const char* descriptor_name, Warn&& warn) {
  Features3D features = emptyFeatures(keypoints, descriptor_length);
  const auto length = static_cast<std::size_t>(descriptor_length);
  std::vector<std::uint8_t> bytes;
  bytes.reserve(descriptors.size() * sizeof(float));
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const float* row = descriptors.data() + i * length;
    if (!std::all_of(row, row + length, [](float v) { return std::isfinite(v); })) continue;
    features.keypoints.push_back({keypoints.keypoints[i].position, support.keypoint_normals[i]});
    const std::size_t at = bytes.size();
    bytes.resize(at + length * sizeof(float));
    std::memcpy(bytes.data() + at, row, length * sizeof(float));
  }
  const std::size_t dropped = keypoints.size() - features.size();
  if (dropped > 0)
    warn(fmt::format(
        "{} of {} keypoints have no finite {} descriptor (too few surface points within the "
        "support radius {} m); they are left out",
        dropped, keypoints.size(), descriptor_name, support.radius));
  features.descriptors.rows = static_cast<int>(features.size());
  features.descriptors.data = Buffer<std::uint8_t>::fromVector(std::move(bytes));
  return features;
}

}  // namespace cdff::dfn::description
