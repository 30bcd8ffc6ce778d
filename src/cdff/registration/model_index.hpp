#pragma once
// The model a scan is registered against: its points, their unit normals and the KD-tree over
// them, rebuilt only when a cloud with another point buffer arrives.

#include <cstdint>

#include <Eigen/Core>

#include "cdff/types/kd_tree.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff::registration {

/// A model cloud and the KD-tree over it. The index keeps its buffers alive, so a cloud whose
/// buffers share its memory (Buffer::sharesMemoryWith) always holds the same points.
struct ModelIndex {
  Buffer<Point4f> points;
  Buffer<Point4f> normals;
  KdTree3f tree;
  std::uint64_t builds = 0;  // a number unique to each build in the process (0: none)

  /// Whether the index is over `model`'s buffers.
  bool holds(const PointCloud& model) const;

  /// Checks `model` (finite points, one unit normal per point) and (re)builds the index when it
  /// is a new cloud.
  Status update(const PointCloud& model);
};

/// The model's point spacing: the median distance from a sample of 201 of its points to their
/// nearest neighbour (0.01 when none has one).
double modelSpacing(const ModelIndex& index);

/// The mean of the model's points.
Eigen::Vector3d modelCentroid(const ModelIndex& index);

/// The axis-aligned box of the model's points (low > high when it has none).
struct ModelBounds {
  Eigen::Vector3d low, high;
  Eigen::Vector3d centre() const { return (low + high) / 2; }
  double radius() const { return (high - low).norm() / 2; }  // of the box's sphere
};
ModelBounds modelBounds(const ModelIndex& index);

}  // namespace cdff::registration
