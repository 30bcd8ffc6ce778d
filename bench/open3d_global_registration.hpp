#pragma once
// The peer of the 3D model detection benchmark: Open3D's global registration (FPFH features and
// RANSAC over their matches), configured as Open3D's global registration tutorial does for the
// job, with every distance a multiple of one voxel size. Kept in its own translation unit: only
// this file includes Open3D.

#include <Eigen/Geometry>

#include "cdff/types/point_cloud.hpp"

namespace cdff::bench {

struct Open3dSettings {
  double voxel = 0.05;          // m, the downsampling voxel; the rest follow from it
  int max_iterations = 100000;  // RANSACConvergenceCriteria
  double confidence = 0.999;
};

struct Open3dResult {
  Eigen::Isometry3d scene_T_model = Eigen::Isometry3d::Identity();
  double fitness = 0;                           // Open3D's: inlier correspondences / model points
  double cpu_features_s = 0, cpu_ransac_s = 0;  // the features of both clouds; the RANSAC
};

/// Global registration of `model` (with normals) onto `scene` (normals estimated as the
/// tutorial does). One thread: call with OMP_NUM_THREADS=1 for one-core figures.
Open3dResult open3dGlobalRegistration(const PointCloud& scene, const PointCloud& model,
                                      const Open3dSettings& settings, unsigned seed);

}  // namespace cdff::bench
