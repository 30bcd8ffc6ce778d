#pragma once
// Multi-scan confirmation of acquisition hypotheses. A sparse scan fits poses 15 degrees apart
// equally well; consecutive scans do not. The best distinct results of a scan's multi-start
// search become hypotheses; each is followed through the next scans (moved with the guess, then
// run on into the scan, damped by a prior on its own move) and its misfit (misfit.hpp, plus the
// prior's cost) is summed over the scans. A decision is made once enough scans are scored and
// the best hypothesis's summed misfit is below every other's by a margin, or at once when a
// single distinct hypothesis is left (no rival to rule out); until then the best so far is
// reported as ambiguous.
//
// Each hypothesis is also moved to its misfit's local minimum on every scan (a pattern search
// along the six pose axes, steps halving from 4 cm and 2 degrees): the ICP minimises the
// residuals alone, which on a sparse scan leave some directions loose by several degrees; the
// misfit's visibility term (surface put where the lasers saw nothing) is what constrains them,
// and it has no gradient.
//
// The confirmation knows the scan only through ScanEvidence: how badly a pose explains it, and
// a short registration run from a start. It keeps its hypotheses between calls.

#include <cmath>
#include <cstddef>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/registration/icp.hpp"
#include "cdff/registration/multi_start.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff::registration {

struct ConfirmationOptions {
  int scans = 0;       // scans scored before a decision (0: off, every scan decides alone)
  int kept = 6;        // distinct hypotheses followed
  double margin = 20;  // summed misfit by which the best must beat every other
  // The most the decided hypothesis may leave unexplained: its summed misfit at most that of
  // this fraction of the returns unmatched (0: no bound). A set whose best is above it after
  // `scans` scans holds no right pose (the search missed its basin) and is dropped.
  double max_unexplained = 0;
  double timeout = 1.0;             // s: a scan later than this after the last starts a new set
  double follow_shift_sigma = 0.3;  // m/s, the prior on a hypothesis's own move
  double follow_turn_sigma = 10.0 * M_PI / 180;  // rad/s
  // The registration's: the residuals' noise is inlier_distance / 3; a followed run starts at
  // inlier_distance + 3 shift sigmas, within [min, max] correspondence distance.
  double inlier_distance = 0.1;
  double min_correspondence_distance = 0.1;
  double max_correspondence_distance = 0.5;
};

/// A scan, as the confirmation sees it.
struct ScanEvidence {
  Timestamp stamp = 0;
  std::size_t returns = 0;  // the scan's points
  /// How badly source_T_model explains the scan (misfit()), in squared noise units.
  std::function<double(const Eigen::Isometry3d&)> misfit;
  /// A short registration run continuing `start` on the scan (its anchor prior applied).
  std::function<Result<IcpRun>(const IcpRun& start)> run;
};

/// A hypothesis followed over consecutive scans.
struct Hypothesis {
  IcpRun run;                    // its registration state on the last scan
  Eigen::Isometry3d from_guess;  // pose * guess^-1: how it moves with the next guesses
  double misfit = 0;             // summed over the scans it was followed through
};

struct ConfirmationResult {
  std::optional<IcpRun> best;  // the least summed misfit; none when no hypothesis is left
  bool ambiguous = false;      // the best is not decided yet
  double misfit_per_return = std::numeric_limits<double>::quiet_NaN();  // the best's, summed
};

class HypothesisConfirmation {
 public:
  void configure(const ConfirmationOptions& options) { options_ = options; }
  bool enabled() const { return options_.scans > 0; }

  /// Whether a scan at `stamp` follows the kept hypotheses (else it starts a new set): there
  /// are some, from an earlier scan less than `timeout` ago, and the set has not been followed
  /// for 4 x `scans` scans without a decision.
  bool following(Timestamp stamp) const;

  /// One scan: a new set from the best distinct `starts` (this scan's multi-start search, best
  /// first) when not following(), else every kept hypothesis followed into the scan from
  /// `guess`; then the decision. A decided set is dropped (a later acquisition starts anew).
  Result<ConfirmationResult> update(const ScanEvidence& scan, const Eigen::Isometry3d& guess,
                                    std::span<const Start> starts);

  /// The hypotheses kept for the next scan, best first.
  const std::vector<Hypothesis>& hypotheses() const { return hypotheses_; }

 private:
  void startSet(const ScanEvidence& scan, const Eigen::Isometry3d& guess,
                std::span<const Start> starts);
  Status follow(const ScanEvidence& scan, const Eigen::Isometry3d& guess);
  /// Hypotheses that ended in the same minimum are one: the `kept` best distinct ones are kept,
  /// best first.
  void keepDistinct();

  ConfirmationOptions options_;
  std::vector<Hypothesis> hypotheses_;  // best first
  Timestamp stamp_ = 0;                 // the scan they were last followed into
  int scans_ = 0;                       // scans scored since the set was made
  std::size_t returns_ = 0;             // returns of those scans
};

}  // namespace cdff::registration
