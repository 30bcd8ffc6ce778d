#pragma once
// The form of a PolygonModel that model-based edge trackers work on: welded points, faces with
// their planes and convex pieces, and the unique edges with the faces on either side.
//
// Cylinders become prisms of `cylinder_segments` facets whose shared edges are smooth (they show
// only as silhouettes, which is where a cylinder's limbs are), circles become closed polygons of
// explicit lines. The silhouette of a tessellated cylinder of radius r lies within
// r (1 - cos(pi / segments)) of the true limb (0.4 mm for r = 0.1 m and 36 segments).

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/polygon_model.hpp"
#include "cdff/types/status.hpp"

namespace cdff::tracking {

struct TrackingModelOptions {
  int cylinder_segments = 36;    // facets around a cylinder
  int circle_segments = 36;      // segments around a circle
  double weld_tolerance = 1e-6;  // m: points closer than this are one point
};

struct TrackingModel {
  struct Face {
    std::vector<std::uint32_t> loop;  // welded point indices, counter-clockwise from outside
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, outwards
    double offset = 0;                                  // normal . x = offset on the plane
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    std::vector<std::vector<std::uint32_t>> convex_pieces;  // the loop, or its triangles
  };
  struct Edge {
    std::uint32_t a = 0, b = 0;  // welded point indices
    std::int32_t faces[2] = {-1, -1};
    int face_count = 0;          // faces bounded by the edge (may exceed 2 on non-manifold models)
    bool smooth = false;         // between facets of a curved surface: only a silhouette shows
    bool explicit_line = false;  // listed as a 3D line (or circle segment) in the model
  };

  std::vector<Eigen::Vector3d> points;
  std::vector<Face> faces;
  std::vector<Edge> edges;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // of the bounding box
  double radius = 0;                                 // of the bounding sphere about `centre`

  /// Validates `model` (PolygonModel::validate) and builds the tracking form.
  static Result<TrackingModel> build(const PolygonModel& model,
                                     const TrackingModelOptions& options = {});
};

}  // namespace cdff::tracking
