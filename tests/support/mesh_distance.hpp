#pragma once
// The distance from a point to a triangle mesh, by brute force over its triangles (the tests'
// meshes have hundreds): the mesh goals' Hausdorff distances.

#include <algorithm>
#include <limits>

#include <Eigen/Core>

#include "cdff/types/mesh.hpp"
#include "cdff/types/triangle.hpp"

namespace cdff::testing {

/// The distance from p to the nearest triangle of `mesh` (infinity without triangles).
inline double distanceToMesh(const TriangleMesh& mesh, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d q = closestPointOnTriangle(p, mesh.vertices[t[0]].cast<double>(),
                                                     mesh.vertices[t[1]].cast<double>(),
                                                     mesh.vertices[t[2]].cast<double>());
    best = std::min(best, (q - p).norm());
  }
  return best;
}

}  // namespace cdff::testing
