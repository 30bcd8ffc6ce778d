#pragma once
// The simulator's two procedural targets as the 3D detection tests use them: each mesh with its
// model cloud sampled 2 cm apart (as ModelPointCloud samples a mesh), and a pose of the target
// at a range ahead of the sensor. Header-only: a test that includes it links cdff_egse.

#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "cdff/egse/procedural.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/point_cloud.hpp"
#include "support/lidar.hpp"

namespace cdff::testing {

struct ProceduralTarget {
  std::string name;
  TriangleMesh mesh;
  PointCloud model;
};

/// `mesh` sampled 2 cm apart (seed 5) with `normals`.
inline PointCloud modelOf(const TriangleMesh& mesh, SampleNormals normals = SampleNormals::kAuto) {
  const auto points = static_cast<std::size_t>(mesh.surfaceArea() / (0.02 * 0.02));
  Result<PointCloud> cloud = sampleSurface(mesh, points, 5, normals);
  EXPECT_TRUE(cloud.isOk()) << cloud.status().toString();
  return std::move(cloud).value();
}

/// The box satellite ("box") and the hexagonal one ("hexagonal"), in that order.
inline std::vector<ProceduralTarget> proceduralTargets(
    SampleNormals normals = SampleNormals::kAuto) {
  std::vector<ProceduralTarget> t;
  TriangleMesh box = egse::makeTargetSatellite().value().mesh;
  t.push_back({"box", box, modelOf(box, normals)});
  TriangleMesh hexagonal = egse::makeHexagonalSatellite().value().mesh;
  t.push_back({"hexagonal", hexagonal, modelOf(hexagonal, normals)});
  return t;
}

/// `cloud` with its points in millimetres (normals unchanged): the unit mistake the DFNs must
/// report.
inline PointCloud inMillimetres(const PointCloud& cloud) {
  std::vector<Point4f> points;
  for (const Point4f& p : cloud.points) points.emplace_back(1000 * p.x, 1000 * p.y, 1000 * p.z);
  PointCloud scaled = cloud;
  scaled.points = Buffer<Point4f>::fromVector(std::move(points));
  return scaled;
}

/// sensor_T_target `range` m ahead along x (slightly off the axis), attitude drawn from `seed`
/// uniformly.
inline Eigen::Isometry3d targetAhead(double range, std::uint32_t seed) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(range, 0.2, -0.3);
  return perturb(pose, 0.0, M_PI, seed);
}

}  // namespace cdff::testing
