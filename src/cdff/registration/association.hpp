#pragma once
// Data association of the ICP: every scan point paired with its nearest visible model point
// within the correspondence distance, from the lookup grid where it reaches, else the KD-tree.

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/registration/model_index.hpp"
#include "cdff/registration/nearest_grid.hpp"
#include "cdff/types/geometry.hpp"

namespace cdff::registration {

/// The search structures over one model: its index and, when there is one, its lookup grid
/// (both shared between registrations, SharedModelCache).
struct ModelSearch {
  std::shared_ptr<const ModelIndex> index;
  std::shared_ptr<NearestGrid> grid;  // null: the KD-tree only
};

/// kGridWhereItReaches: the lookup grid for correspondences within its band, else the KD-tree;
/// kExact: the KD-tree only.
enum class NearestPoints { kGridWhereItReaches, kExact };

struct AssociationOptions {
  /// Pair a scan point only with model points whose normal faces the viewpoint.
  bool back_face_rejection = true;
  Eigen::Vector3f viewpoint = Eigen::Vector3f::Zero();  // the sensor, source frame
};

/// A scan point and its model point, in the source frame.
struct Correspondence {
  Vector6d j;              // point-to-plane Jacobian in [dt, dtheta]
  double r;                // point-to-plane residual, m
  Eigen::Vector3d offset;  // R q + t - p, the point-to-point residual
  Eigen::Vector3d rq;      // R q
};

/// The pairs of one association, with each pair's |r| and point-to-point distance.
struct Correspondences {
  std::vector<Correspondence> pairs;
  std::vector<float> abs_residuals;
  std::vector<float> distances;
};

class Association {
 public:
  static constexpr std::uint32_t kNoMatch = ~std::uint32_t{0};

  void configure(const AssociationOptions& options) { options_ = options; }
  void setModel(const ModelSearch& model) { model_ = model; }

  /// Pairs every point of `points` with its nearest (visible) model point within `distance` at
  /// source_T_model `pose`. Each search is bounded by the point's match of the previous call
  /// (the pose moved little) unless `first`. The result is kept until the next call (scratch
  /// reused without allocating); the caller may reorder its abs_residuals and distances (the
  /// robust scales' medians).
  Correspondences& match(std::span<const Eigen::Vector3f> points, const Eigen::Isometry3d& pose,
                         double distance, bool first, NearestPoints nearest);

  /// Each point's model point in the last match (kNoMatch: none): hints for evaluate().
  const std::vector<std::uint32_t>& lastMatches() const { return previous_; }

 private:
  bool facesEye(std::uint32_t index, const Eigen::Vector3f& eye) const;
  /// The nearest model point to `q` within sqrt(max_sq) (that faces `eye` when back faces are
  /// rejected, unless none does: the pose is then still far off and the plain nearest pulls the
  /// right way). `previous` (the match of the last iteration, or kNoMatch) bounds the search:
  /// the pose moved little, so the new match is at most about as far as the old one.
  bool nearestVisible(const Eigen::Vector3f& q, const Eigen::Vector3f& eye, float max_sq,
                      std::uint32_t previous, KdTree3f::Neighbour& found) const;
  /// As nearestVisible, from the lookup grid: constant time, also on thin parts where the
  /// nearest point is on the hidden side (the grid keeps the other side's nearest point).
  bool nearestFromGrid(const Eigen::Vector3f& q, const Eigen::Vector3f& eye, float max_sq,
                       KdTree3f::Neighbour& found);

  AssociationOptions options_;
  ModelSearch model_;
  Correspondences found_;
  std::vector<std::uint32_t> previous_;
};

}  // namespace cdff::registration
