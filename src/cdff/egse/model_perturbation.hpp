#pragma once
// Model errors: a tracker's model that differs from the simulated target the way a real one
// differs from its spacecraft (docs/simulator.md, "Model errors"; `cdff model perturb`):
//   - dimensions off: every vertex scaled per body axis about the body origin (the centre of
//     mass), so the bounding box grows by the same factors;
//   - a part missing (a named part of the model dropped: the antenna, a wing) or an extra part
//     (a box: a payload the drawings do not show);
//   - the mesh re-triangulated (the same surface in other triangles, as another CAD export
//     would give): the shared diagonal of every two coplanar triangles that form a convex quad
//     flipped, and every edge longer than `max_edge` split at its middle until none is.
// The steps run in that order: remove, scale, add, flip, split. The face model (polygons)
// follows the removal and the scale and keeps its outlines through the re-triangulation (a
// polygon has no triangles); the boxes add their faces to it.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "cdff/egse/model.hpp"

namespace cdff::egse {

/// An extra box part, axis-aligned in the model frame, in the structure material.
struct ExtraBox {
  std::string name;  // the part's name
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_extents = Eigen::Vector3d::Constant(0.1);  // m
};

struct ModelPerturbation {
  /// Relative dimension error per body axis: vertices scaled by 1 + error (0.01: 1 % larger).
  Eigen::Vector3d scale_error = Eigen::Vector3d::Zero();
  std::vector<std::string> remove_parts;
  std::vector<ExtraBox> add_boxes;
  bool flip_diagonals = false;  // re-triangulate: flip the diagonal of coplanar triangle pairs
  double max_edge = 0;          // m; > 0: re-triangulate until no edge is longer

  /// Ok when the scale errors are finite and within (-0.5, 0.5), the boxes have a name and
  /// positive finite sizes, and max_edge is finite and >= 0.
  Status validate() const;
};

/// The perturbed model; an error names an unknown part (listing the model's parts) or a bad
/// size.
Result<TargetModel> perturbModel(const TargetModel& model, const ModelPerturbation& perturbation);

/// Re-triangulates `model`: every triangle edge longer than `max_edge` (m, > 0) is split at its
/// middle until none is. Neighbours split a shared edge at the same point, so the surface stays
/// closed; the split triangles keep their material and part, new vertices interpolate normals.
Result<TargetModel> splitLongEdges(const TargetModel& model, double max_edge);

/// Re-triangulates `model` without moving or adding a vertex: two triangles that share an edge
/// (by vertex index), lie in one plane (normals within 1e-5 rad), have the same material and
/// part and form a strictly convex quad get the quad's other diagonal instead; each triangle
/// takes part in at most one flip.
TargetModel flipDiagonals(const TargetModel& model);

}  // namespace cdff::egse
