#include "open3d_global_registration.hpp"

#include <ctime>
#include <memory>

#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/CorrespondenceChecker.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/utility/Random.h>

namespace cdff::bench {
namespace {

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

std::shared_ptr<open3d::geometry::PointCloud> toOpen3d(const PointCloud& cloud) {
  auto o = std::make_shared<open3d::geometry::PointCloud>();
  o->points_.reserve(cloud.size());
  for (const Point4f& p : cloud.points) o->points_.push_back(p.vec().cast<double>());
  return o;
}

}  // namespace

Open3dResult open3dGlobalRegistration(const PointCloud& scene, const PointCloud& model,
                                      const Open3dSettings& settings, unsigned seed) {
  namespace reg = open3d::pipelines::registration;
  using open3d::geometry::KDTreeSearchParamHybrid;
  open3d::utility::random::Seed(static_cast<int>(seed));
  Open3dResult result;
  const double voxel = settings.voxel;
  double t0 = cpuSeconds();
  // The tutorial's preprocessing: voxel downsampling, normals within 2 voxels (30 neighbours at
  // most), FPFH within 5 voxels (100 neighbours at most).
  auto prepare = [&](const PointCloud& cloud) {
    auto down = toOpen3d(cloud)->VoxelDownSample(voxel);
    down->EstimateNormals(KDTreeSearchParamHybrid(2 * voxel, 30));
    // Normals towards the sensor (at the scene's origin; the model's own are outward, and the
    // tutorial orients neither: FPFH uses them only up to sign through the Darboux frame).
    down->OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
    auto fpfh = reg::ComputeFPFHFeature(*down, KDTreeSearchParamHybrid(5 * voxel, 100));
    return std::make_pair(down, fpfh);
  };
  auto [scene_down, scene_fpfh] = prepare(scene);
  auto [model_down, model_fpfh] = prepare(model);
  double t1 = cpuSeconds();
  result.cpu_features_s = t1 - t0;
  // The tutorial's RANSAC: matches of mutual nearest features, 3 per hypothesis, pruned by edge
  // lengths (0.9) and distance (1.5 voxels), point-to-point estimation.
  const double distance = 1.5 * voxel;
  reg::CorrespondenceCheckerBasedOnEdgeLength edges(0.9);
  reg::CorrespondenceCheckerBasedOnDistance close(distance);
  const reg::RegistrationResult r = reg::RegistrationRANSACBasedOnFeatureMatching(
      *model_down, *scene_down, *model_fpfh, *scene_fpfh, /*mutual_filter=*/true, distance,
      reg::TransformationEstimationPointToPoint(false), 3, {edges, close},
      reg::RANSACConvergenceCriteria(settings.max_iterations, settings.confidence));
  result.cpu_ransac_s = cpuSeconds() - t1;
  result.scene_T_model.matrix() = r.transformation_;
  result.fitness = r.fitness_;
  return result;
}

}  // namespace cdff::bench
