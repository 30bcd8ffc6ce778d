#pragma once
// Shared by the GlobalRegistration3D DFIs (registration_common.cpp, compiled once, no OpenCV
// contrib here): the input and parameter checks, the sizes derived from the model's diameter and
// the publishing of the pose clusters as Detections.

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "GlobalRegistration3D.gen.hpp"

namespace cdff::dfn::global_registration {

/// The model's extent: its points' axis-aligned bounding box.
struct ModelExtent {
  Eigen::Vector3f min = Eigen::Vector3f::Zero();
  Eigen::Vector3f max = Eigen::Vector3f::Zero();
  /// D, the bounding box's diagonal (m).
  double diameter() const { return (max - min).cast<double>().norm(); }
  Eigen::Vector3f centre() const { return 0.5f * (min + max); }
};

/// The sizes of one model and configuration (m).
struct Sizes {
  double diameter = 0;          // D
  double step = 0;              // d = sampling x D
  double cluster_distance = 0;  // the parameter, or 0.1 D
  double normal_radius = 0;     // the parameter, or 2 d
};

/// The model: finite points, not all at one place, with finite unit normals.
Status checkModel(const PointCloud& model);
/// The scene: finite points; normals, when present, finite and non-zero.
Status checkScene(const PointCloud& scene);
/// A downsampled model of `count` points has at least `fewest` (the error says how to get more).
Status checkDownsampledModel(std::size_t count, std::size_t fewest, const Sizes& sizes,
                             double sampling);
/// sampling strictly between 0 and 1 (the description's range admits both ends).
Status checkSampling(double sampling);

ModelExtent extentOf(const PointCloud& cloud);
/// The sizes from the shared parameters (a size given as 0 is derived, see the description).
Sizes sizesOf(double sampling, double cluster_distance, double normal_radius,
              const ModelExtent& extent);

/// A point with its unit normal.
struct Oriented {
  Eigen::Vector3f p;
  Eigen::Vector3f n;
};

/// The point indices of a cloud sorted by voxel (cubes of `step` m), and where each voxel's run
/// starts.
struct VoxelRuns {
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed;  // (voxel, point index), sorted
  std::vector<std::uint32_t> starts;                           // run starts, then keyed.size()

  void build(const PointCloud& cloud, float step);
};

/// One point per voxel of `step` and normal direction (the cloud has normals): the points of a
/// voxel whose normals are within 30 degrees of a group's mean direction are averaged into it
/// (positions and normals), the others start new groups: the two sides of a 3 cm solar panel
/// and the two faces at an edge are different surfaces that one averaged normal would
/// misdescribe. `runs` is working memory.
void downsampleWithNormals(const PointCloud& cloud, float step, VoxelRuns& runs,
                           std::vector<Oriented>& out);

/// A pose cluster: scene_T_model and its votes.
struct Cluster {
  Eigen::Isometry3d scene_T_model = Eigen::Isometry3d::Identity();
  double votes = 0;
};

/// Sets `hypotheses` from the clusters (sorted here, most votes first, at most max_hypotheses)
/// and `scene_points`.
void publish(std::vector<Cluster> clusters, int max_hypotheses, std::size_t scene_points,
             const PointCloud& scene, const PointCloud& model, GlobalRegistration3D::Outputs& out);

}  // namespace cdff::dfn::global_registration
