#pragma once
// Point-to-plane ICP against a model with normals: association (association.hpp), Gauss-Newton
// steps on source_T_model with an iteratively reweighted robust kernel whose scale adapts to
// the residuals (as in KISS-ICP), a point-to-point coarse phase while the correspondence
// distance is large, a correspondence distance that shrinks as the alignment improves, an
// optional Gaussian prior on the pose, and the stopping rules.
//
// Perturbations follow docs/conventions.md: t = t_hat + dt, R = exp(dtheta) R_hat in the source
// frame; steps are [dt, dtheta].

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/registration/association.hpp"
#include "cdff/registration/robust_kernel.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/status.hpp"

namespace cdff::registration {

struct IcpOptions {
  double max_correspondence_distance = 0.5;  // m, where a new run starts
  double min_correspondence_distance = 0.1;  // m, the floor of the shrinking distance
  double translation_epsilon = 1e-4;         // m: a smaller step (and rotation_epsilon) stops
  double rotation_epsilon = 1e-4;            // rad
  /// A step shorter than this many standard deviations of the estimate also stops (0: off).
  double convergence_sigma = 0.1;
  int min_correspondences = 20;       // fewer pairs starve the run
  double point_to_point_above = 0.8;  // m: point-to-point error above this distance (0: never)
  RobustKernel kernel = RobustKernel::kGemanMcClure;
  double kernel_scale = 0;         // m; 0 adapts it to 1.4826 x the median absolute residual
  double min_kernel_scale = 0.01;  // m, the adaptive scale's floor
  AssociationOptions association;
};

/// The state of one ICP run, which a later call continues (an acquisition start's short run,
/// then its refinement).
struct IcpRun {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // source_T_model
  double distance = 0;                                     // the current correspondence distance, m
  bool converged = false, starved = false;
  int iterations = 0;
  std::size_t last_pairs = 0;  // pairs of the association that starved the run
  Vector6d previous_step = Vector6d::Zero();
  // A Gaussian prior on the pose (a hypothesis followed into the next scan, which a sparse
  // scan alone lets slide along its poorly constrained directions): the offset from `anchor`
  // ([dt, dtheta], as the steps) weighted by `anchor_precision`, in the residuals' squared
  // units. Zero: none.
  Eigen::Isometry3d anchor = Eigen::Isometry3d::Identity();
  Vector6d anchor_precision = Vector6d::Zero();

  /// A run starting at `pose` with correspondence distance `distance`.
  static IcpRun startingAt(const Eigen::Isometry3d& pose, double distance);
  /// The run's pose moved to the rotation and translation of `at`.
  void setPose(const Eigen::Isometry3d& at);
  /// The offset from the anchor, [dt, dtheta].
  Vector6d fromAnchor() const;
};

class Icp {
 public:
  void configure(const IcpOptions& options);
  void setModel(const ModelSearch& model);
  const IcpOptions& options() const { return options_; }

  /// `run` continued by at most `max_iterations` more iterations on `points`, until it
  /// converges or starves (fewer than min_correspondences pairs). An error when a Gauss-Newton
  /// step is not finite.
  Result<IcpRun> iterate(std::span<const Eigen::Vector3f> points, IcpRun run, int max_iterations,
                         NearestPoints nearest = NearestPoints::kGridWhereItReaches);

  /// Each point's model point in the last association: hints for evaluate().
  const std::vector<std::uint32_t>& lastMatches() const { return association_.lastMatches(); }

 private:
  struct NormalEquations {
    Matrix6d h = Matrix6d::Zero();
    Vector6d g = Vector6d::Zero();
    bool point_to_plane = false;
    double weighted_r2 = 0, weight_sum = 0;
  };
  /// The robustly weighted Gauss-Newton system of the pairs (and the run's prior).
  NormalEquations normalEquations(Correspondences& pairs, const IcpRun& run);

  IcpOptions options_;
  Association association_;
};

}  // namespace cdff::registration
