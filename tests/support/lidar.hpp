#pragma once
// Synthetic LIDAR data with known ground truth: simple target meshes and a ray-cast scan of a
// VLP-16-like sensor (16 rings over +-15 deg, 0.2 deg azimuth steps, Gaussian range noise), with
// occlusion, so that only the faces turned towards the sensor are seen.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "cdff/types/types.hpp"

namespace cdff::testing {

/// An axis-aligned box centred at `centre`, 12 outward-facing triangles, frame `frame_id`.
TriangleMesh boxMesh(const Eigen::Vector3d& half_extents,
                     const Eigen::Vector3d& centre = Eigen::Vector3d::Zero(),
                     const std::string& frame_id = "target");

/// A satellite-like target in frame `target` (x forward, z up): a 1.2 x 1.0 x 1.0 m bus, two
/// solar wings along +-y (2.0 x 0.8 x 0.03 m each, on short yokes), an antenna box on +z and an
/// adapter block on -x. No symmetry leaves its pose ambiguous from any side. About 4.5 m across.
TriangleMesh satelliteMesh();

/// Merges meshes (same frame) into one.
TriangleMesh mergeMeshes(const std::vector<TriangleMesh>& meshes);

struct ScanOptions {
  int rings = 16;
  double min_elevation = -15.0 * M_PI / 180.0;  // rad
  double max_elevation = 15.0 * M_PI / 180.0;   // rad
  /// The lasers' elevations (rad), any order; when set, instead of `rings` evenly spaced from
  /// min_elevation to max_elevation. Rings are numbered in this order.
  std::vector<double> elevations;
  double azimuth_step = 0.2 * M_PI / 180.0;        // rad (VLP-16 at 10 Hz)
  double min_azimuth = -M_PI, max_azimuth = M_PI;  // rad, about the sensor's z axis
  double range_noise = 0.03;                       // m, 1 sigma (VLP-16: +-3 cm)
  double min_range = 0.3, max_range = 100.0;       // m
  /// > 0: the sensor is inside a closed room (a box of this half size, centred on the sensor),
  /// so that rays that miss the target return from its walls, as in a ground test bench.
  double room_half_size = 0;
};

/// Ray-casts `mesh` (in its own frame) seen from a sensor at `sensor_T_mesh`; the cloud is in
/// the sensor frame `frame_id`, with ring indices, reproducible from `seed`.
PointCloud simulateScan(const TriangleMesh& mesh, const Eigen::Isometry3d& sensor_T_mesh,
                        const ScanOptions& options, std::uint32_t seed,
                        const std::string& frame_id = "lidar");

/// The lasers' elevations (rad) of a scan with `options`, ring by ring.
std::vector<double> laserElevations(const ScanOptions& options);

/// The description of the sensor that simulateScan(..., options, ..., frame_id) models: its
/// lasers, one revolution per 0.1 s, its range limits and noise.
LidarInfo lidarInfo(const ScanOptions& options, const std::string& frame_id = "lidar");

/// Rotation error (rad) and translation error (m) of `estimate` against `truth`.
struct PoseError {
  double translation = 0;
  double rotation = 0;
};
PoseError poseError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth);

/// `pose` moved by a translation of `translation` m and a rotation of `angle` rad about random
/// axes (the rotation about the pose's origin), reproducible from `seed`.
Eigen::Isometry3d perturb(const Eigen::Isometry3d& pose, double translation, double angle,
                          std::uint32_t seed);

}  // namespace cdff::testing
