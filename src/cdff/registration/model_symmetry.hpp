#pragma once
// The near-symmetries of a model: rigid motions that map most of its surface onto itself. A
// man-made target (a box bus between two wings, a hexagonal bus) looks nearly the same turned
// by such a motion, so a registration or template match from one pose can end in the other:
// PoseRefinement starts every candidate at its near-symmetric poses too and compares them.
//
// A rotational symmetry of finite order n turns by 360/n degrees about an axis. The axes
// searched are those a man-made shape has them along: its dominant surface normals (the faces'),
// their bisectors and cross products, and its principal axes. For each axis direction and order,
// the axis's position is searched over a grid across the model (it need not pass through the
// centroid: a one-winged bus's axis does not), scored by how many surface samples land on the
// model's surface; the best positions are refined by point-to-plane ICP of the model onto itself
// and kept when they map at least `min_overlap` of the surface within the tolerance.

#include <vector>

#include <Eigen/Geometry>

#include "cdff/registration/model_index.hpp"

namespace cdff::registration {

struct SymmetryOptions {
  /// The fraction of the model's surface (samples uniform by area) that a kept motion maps
  /// within `tolerance` of the surface, normals along the same line (a mesh's winding need not be
  /// consistent).
  double min_overlap = 0.5;
  int max_order = 6;          // turns by 360 k / n degrees for n = 2 .. max_order
  std::size_t samples = 400;  // surface samples scored
  /// m; 0: the larger of twice the model's point spacing and 2 % of its bounding radius.
  double tolerance = 0;
};

/// One near-symmetry: x -> motion * x in the model frame.
struct NearSymmetry {
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
  double overlap = 0;  // of the surface samples, mapped onto the surface
  double angle = 0;    // rad, of the rotation
};

/// The model's near-symmetries other than the identity, each with its inverse, best overlap
/// first; motions within 5 degrees and 2 tolerances (at the model's rim) of one another are one.
std::vector<NearSymmetry> nearSymmetries(const ModelIndex& index,
                                         const SymmetryOptions& options = {});

/// The motions of `symmetries`, in their order.
std::vector<Eigen::Isometry3d> motionsOf(const std::vector<NearSymmetry>& symmetries);

/// The fraction of `samples` (model points with their normals) that `motion` maps within
/// `tolerance` of a model point whose normal lies within 30 degrees of the same line.
double symmetryOverlap(const ModelIndex& index, const Eigen::Isometry3d& motion,
                       const std::vector<Eigen::Vector3f>& points,
                       const std::vector<Eigen::Vector3f>& normals, double tolerance);

}  // namespace cdff::registration
