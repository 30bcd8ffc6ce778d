#pragma once
// Shared by the MeshReconstruction DFIs (no PCL here: mesh_common.cpp compiles fast): the input's
// checks, point spacing and normals; the mesh's trimming, orientation, compaction and vertex
// normals; the fit diagnostic and the outputs.

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "MeshReconstruction.gen.hpp"
#include "cdff/types/kd_tree.hpp"
#include "cdff/types/mesh.hpp"

namespace cdff::dfn::meshing {

/// The parameters both DFIs share.
struct Settings {
  double point_spacing = 0;  // m; 0: estimated from the cloud
  int normal_neighbours = 12;
  bool outward = true;  // estimated normals away from the centroid, else towards viewpoint
  Eigen::Vector3f viewpoint = Eigen::Vector3f::Zero();
  double fit_tolerance = 0;  // m; 0: the point spacing
};

template <typename Parameters>
Settings settingsOf(const Parameters& p) {
  Settings s;
  s.point_spacing = p.point_spacing;
  s.normal_neighbours = p.normal_neighbours;
  s.outward = p.normal_orientation == "outward";
  s.viewpoint =
      Eigen::Vector3f(static_cast<float>(p.viewpoint[0]), static_cast<float>(p.viewpoint[1]),
                      static_cast<float>(p.viewpoint[2]));
  s.fit_tolerance = p.fit_tolerance;
  return s;
}

using Warn = std::function<void(std::string)>;
using Triangle = std::array<std::uint32_t, 3>;

/// The input made ready to mesh: its finite points with unit normals (the cloud's, or
/// estimated), a KD-tree over them, their spacing and bounding box.
struct Prepared {
  PointCloud cloud;  // finite points, unit normals; the input's frame and stamp
  KdTree3f tree;     // over cloud.points
  double spacing = 0;
  std::size_t dropped = 0;  // input points with a non-finite coordinate or normal
  Eigen::Vector3f min = Eigen::Vector3f::Zero(), max = Eigen::Vector3f::Zero();
};

/// Checks `input` and prepares it; drops (and reports through `warn`) non-finite points.
Result<Prepared> prepare(const PointCloud& input, const Settings& settings, const Warn& warn);

/// Removes the vertices farther than `max_distance` from every point of `data`, with their
/// triangles (Poisson's invented surface across holes).
void trimFarFromPoints(const Prepared& data, double max_distance,
                       const std::vector<Eigen::Vector3f>& vertices,
                       std::vector<Triangle>& triangles);

/// Winds every triangle counter-clockwise seen from the side its vertices' normals face (their
/// sum): for meshes whose vertices are input points.
void orientByVertexNormals(const std::vector<Eigen::Vector3f>& vertices,
                           const std::vector<Eigen::Vector3f>& normals,
                           std::vector<Triangle>& triangles);

/// Reverses every triangle when most of them (by area) face against the normal of the input
/// point nearest to their centre: for a consistently wound mesh of another vertex set.
void orientByNearestPoints(const Prepared& data, const std::vector<Eigen::Vector3f>& vertices,
                           std::vector<Triangle>& triangles);

/// The mesh of the kept triangles, without degenerate ones (a repeated vertex or no area) and
/// unused vertices, with area-weighted vertex normals, in the input's frame.
TriangleMesh buildMesh(const Prepared& data, const std::vector<Eigen::Vector3f>& vertices,
                       const std::vector<Triangle>& triangles);

/// The fraction of `points` (finite) within `tolerance` of a triangle of `mesh` (exact: every
/// triangle whose box, grown by the tolerance, holds the point is tested).
double fitFraction(const PointCloud& points, const TriangleMesh& mesh, double tolerance);

/// Checks that the mesh has a triangle and sets every output.
Status publish(MeshReconstruction::Outputs& out, const Prepared& data, const Settings& settings,
               TriangleMesh mesh);

}  // namespace cdff::dfn::meshing
