#pragma once
// The nearest point of a triangle: the simulator's contact query (RayCaster::closestPoint) and the
// tests' mesh distances.

#include <Eigen/Core>

namespace cdff {

/// The point of triangle abc nearest to p: p projected onto the triangle's plane when that falls
/// inside, else the nearest point of the nearest edge or vertex, told apart by the barycentric
/// regions of the triangle (the Voronoi regions of its vertices and edges); a degenerate
/// triangle gives its first vertex.
Eigen::Vector3d closestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace cdff
