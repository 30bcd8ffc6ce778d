#pragma once
// The check of a tracked pose against the model's near-symmetric poses (model_symmetry.hpp).
// A registration from a pose that is wrong by a near-symmetry (a half turn of a box bus, a turn
// of a hexagonal bus) fits the scans nearly as well as the truth and is tracked as faithfully:
// the tracker's own small corrections never leave that minimum. Where the parts that break the
// symmetry (a wing, an antenna) are measured, the two poses differ in how well they explain the
// scan. Each check registers the scan from the tracked pose moved by every near-symmetry (a
// short ICP run) and scores each result and the tracked pose by their misfit (misfit.hpp); the
// differences are summed over the last `scans` checks, and a rival whose summed misfit is below
// the tracked pose's by min_significance square roots of the returns summed and by
// min_relative_advantage of it is the better pose.
//
// A rival that ends within `distinct_angle` of the tracked attitude found the tracked pose's own
// minimum and scores no difference on that check.

#include <cmath>
#include <cstddef>
#include <deque>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/registration/association.hpp"
#include "cdff/registration/icp.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff::registration {

struct SymmetryCheckOptions {
  int scans = 5;  // checks whose misfit differences are summed
  /// The least summed misfit by which a rival must beat the tracked pose, over the square root
  /// of the returns summed: a part that one pose explains and the other does not makes a
  /// difference that grows with the returns, noise one that grows with their square root.
  double min_significance = 30;
  /// The least fraction of the tracked pose's summed misfit by which a rival must beat it: on
  /// dense scans a small systematic difference between poses that fit alike (the target
  /// overflowing the view, the model's sampling) adds up over many returns.
  double min_relative_advantage = 0.25;
  /// s: a check later than this after the previous one starts the sums anew (the track was
  /// interrupted: the poses summed may not be those of the same track).
  double timeout = 3.0;
  int iterations = 10;                        // of each rival's ICP run
  double distinct_angle = 10.0 * M_PI / 180;  // rad
  double inlier_distance = 0.1;               // m, the misfit's
  IcpOptions icp;                             // the rivals' runs
};

/// One check's outcome.
struct SymmetryVerdict {
  /// A rival that explains the last `scans` checks better than the tracked pose by both bounds:
  /// its pose (source_T_model) on this scan. The sums start anew after it.
  std::optional<Eigen::Isometry3d> better;
  /// The advantage, the tracked pose's summed misfit minus the best rival's (positive: the rival
  /// explains the scans better), over the square root of the returns of the checks summed, and
  /// as a fraction of the tracked pose's summed misfit; NaN before the model has a
  /// near-symmetry.
  double significance = std::numeric_limits<double>::quiet_NaN();
  double relative_advantage = std::numeric_limits<double>::quiet_NaN();
  int scans = 0;  // checks summed
};

class SymmetryCheck {
 public:
  void configure(const SymmetryCheckOptions& options);

  /// The model to register against and its near-symmetries (motions in the model frame); the
  /// sums start anew.
  void setModel(const ModelSearch& model, std::span<const Eigen::Isometry3d> symmetries);

  /// One check of the tracked source_T_model `tracked` on the scan `points` (source frame,
  /// `stamp`); `misfit` scores a pose on the scan (misfit(), with the scan's visibility).
  Result<SymmetryVerdict> check(std::span<const Eigen::Vector3f> points,
                                const Eigen::Isometry3d& tracked, Timestamp stamp,
                                const std::function<double(const Eigen::Isometry3d&)>& misfit);

  /// Forgets the sums (a new track).
  void reset();

 private:
  SymmetryCheckOptions options_;
  Icp icp_;
  std::vector<Eigen::Isometry3d> symmetries_;
  /// One check's scores.
  struct Check {
    std::vector<double> differences;  // per symmetry: rival's misfit - tracked pose's
    double tracked_misfit = 0;
    std::size_t returns = 0;
  };
  std::deque<Check> checks_;  // the last `scans`, oldest first
  Timestamp last_ = 0;
};

}  // namespace cdff::registration
