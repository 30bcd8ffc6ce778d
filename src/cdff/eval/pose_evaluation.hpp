#pragma once
// Accuracy of estimated poses against ground truth: the numbers `cdff eval` reports.
//
// An estimate series (a DFPC's product channel) is compared with a truth series of the same
// transform (same parent and child frames). Truth is interpolated at each estimate's timestamp
// (linear in translation, slerp in rotation) when two truth samples bracket it within
// `max_truth_gap`; otherwise the estimate has no truth and is counted as unmatched, not as an
// error. Every statistic is over matched estimates that the DFPC reported as valid (tracking).
//
// Where an estimate carries a pose covariance, its error is also normalised by it (the NEES,
// normalised estimation error squared): over many estimates of an honest covariance the 6-dof
// NEES averages 6 and 95 % of the values lie below the chi-square bound 12.59. A mean well below
// 6 means the covariance is pessimistic, well above 6 optimistic (a filter that trusts it gates
// out good measurements, a planner that trusts it takes risks it does not know of).

#include <algorithm>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "cdff/types/geometry.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff::eval {

/// One DFPC output: the pose, whether the DFPC called it valid (tracking) and, when known, how
/// long the DFPC took to produce it from its input (processing latency).
struct EstimateSample {
  Transform pose;  // parent_T_child at pose.stamp
  bool valid = true;
  std::optional<double> latency_s;
  /// The pose's covariance, [dt, dtheta] in the parent frame (docs/conventions.md), when the
  /// product carries one.
  std::optional<Matrix6d> covariance;
  /// The twist (velocity of the child relative to the parent, in the parent frame) when the
  /// product is a state: continuity moves the estimate with it to the next one's stamp.
  std::optional<Twist> twist;
  /// The first estimate after its DFPC was started again (a rule's activation): continuity does
  /// not step into it from the estimates before the stop.
  bool restarted = false;
};

/// RMSE, 95th percentile and maximum of a set of non-negative errors; all NaN when empty.
struct ErrorStatistics {
  std::size_t count = 0;
  double rmse = 0, p95 = 0, max = 0;

  static ErrorStatistics of(std::vector<double> errors);
};

/// The update rates of a series of valid estimates, added in time order.
class UpdateRates {
 public:
  void add(Timestamp stamp) {
    if (count_ == 0) first_ = stamp;
    if (count_ > 0) longest_gap_ = std::max(longest_gap_, stamp - last_);
    last_ = stamp;
    ++count_;
  }
  std::size_t count() const { return count_; }
  /// (count - 1) / the span from the first to the last; 0 with fewer than two or no span.
  double meanHz() const { return spans() ? (count_ - 1) / toSeconds(last_ - first_) : 0.0; }
  /// 1 / the longest interval between two consecutive ones: the worst update rate.
  double worstHz() const { return spans() ? 1.0 / toSeconds(longest_gap_) : 0.0; }

 private:
  bool spans() const { return count_ >= 2 && last_ > first_; }
  std::size_t count_ = 0;
  Timestamp first_ = 0, last_ = 0, longest_gap_ = 0;
};

/// The error of one matched estimate.
/// An estimate whose attitude standard deviation exceeds this on some axis states that its
/// attitude is not observed (a placeholder: far range's target state, whose attitude no sensor
/// sees): its angle error and attitude NEES are not counted, its position is.
constexpr double kUnobservedAttitudeSigmaDeg = 45.0;

struct MatchedError {
  Timestamp stamp = 0;
  double range_m = 0;           // |translation| of the truth pose
  double position_error_m = 0;  // |t_est - t_true|
  double angle_error_deg = 0;   // angle of R_est R_true^T; NaN when the attitude is unobserved
  /// e^T C^-1 e of the error e = [t_true - t_est, log(R_true R_est^T)] under the estimate's
  /// covariance C, in all 6 dof and in position and attitude alone; NaN when the estimate has
  /// no covariance or one that is not positive definite.
  double nees = std::numeric_limits<double>::quiet_NaN();
  double position_nees = std::numeric_limits<double>::quiet_NaN();
  double attitude_nees = std::numeric_limits<double>::quiet_NaN();
};

/// How well the estimates' covariances describe their errors (over the matched valid estimates
/// with a positive-definite covariance; NaN statistics when there is none).
struct CovarianceConsistency {
  static constexpr double kChiSquare6Dof95 = 12.592;  // 95 % quantile of chi-square, 6 dof
  std::size_t count = 0;                              // estimates with a usable covariance
  std::size_t rejected = 0;  // estimates whose covariance is not positive definite
  double nees_mean = std::numeric_limits<double>::quiet_NaN();           // 6 when honest
  double nees_p95 = std::numeric_limits<double>::quiet_NaN();            // 12.59 when honest
  double within_95_fraction = std::numeric_limits<double>::quiet_NaN();  // 0.95 when honest
  double position_nees_mean = std::numeric_limits<double>::quiet_NaN();  // 3 when honest
  double attitude_nees_mean = std::numeric_limits<double>::quiet_NaN();  // 3 when honest
};

struct PoseEvaluationOptions {
  /// Longest gap between two truth samples across which truth is interpolated.
  double max_truth_gap_s = 0.5;
  /// An estimate within this time of a truth sample uses that sample when it cannot be
  /// interpolated (e.g. the last estimate after the last truth sample).
  double nearest_truth_tolerance_s = 1e-3;
};

/// How a state product (a filter's estimate, with a twist: RigidBodyState) moves from one valid
/// estimate to the next against its own covariance (issue 18: a target state never jumps by
/// more than 3 sigma, at a hand-over or elsewhere; a measurement product's samples are
/// independent draws, for which steps mean nothing, and get none): each step from
/// a valid estimate to the next valid one, the first moved to the second's stamp with its twist
/// when it has one, as the Mahalanobis distance of the change under the first's covariance (in
/// sigma, 6 dof). Steps across an invalid estimate, into a restarted one, or from one without a
/// positive-definite covariance, are not counted (a track lost and found again, or a DFPC
/// stopped and started again, starts afresh).
struct Continuity {
  static constexpr double kJumpSigma = 3.0;
  struct Step {
    Timestamp stamp = 0;  // the second estimate's
    double sigma = 0;
  };
  std::vector<Step> steps;  // in time order
  std::size_t jumps = 0;    // steps beyond kJumpSigma
  double max_sigma = std::numeric_limits<double>::quiet_NaN();
  Timestamp worst_stamp = 0;

  /// The largest step in [from, to]; NaN when there is none.
  double maxWithin(Timestamp from, Timestamp to) const;
};

/// The continuity of `estimates` (sorted by stamp); no steps when they have no twist.
Continuity continuityOf(const std::vector<EstimateSample>& estimates);

/// Everything `cdff eval` says about one product channel.
struct PoseEvaluation {
  std::string channel;
  std::string truth_channel;
  std::string parent_frame, child_frame;

  std::size_t frames = 0;          // estimates received (valid or not)
  std::size_t valid_frames = 0;    // estimates the DFPC reported as valid
  std::size_t matched_frames = 0;  // valid estimates with a truth pose at their time
  /// valid_frames / frames: how much of the time the DFPC was tracking.
  double tracked_fraction = 0;

  ErrorStatistics position_error_m;
  ErrorStatistics position_error_pct_range;
  ErrorStatistics angle_error_deg;
  ErrorStatistics latency_s;  // count 0 when the DFPC recorded no latency
  CovarianceConsistency covariance;
  Continuity continuity;

  /// Valid estimates per second over the span from the first to the last one.
  double rate_hz = 0;
  /// 1 / (longest interval between consecutive valid estimates): the worst update rate.
  double min_rate_hz = 0;
  double min_range_m = 0, max_range_m = 0;  // truth range over matched estimates

  std::vector<MatchedError> errors;  // per matched estimate, in time order (for plots)
};

/// The 6-dof NEES e^T C^-1 e of `estimate` against `truth` (same frames) under `covariance`
/// ([dt, dtheta] in the parent frame), e = [t_true - t_est, log(R_true R_est^T)]; NaN when the
/// covariance is not finite and positive definite.
double poseNees(const Transform& estimate, const Transform& truth, const Matrix6d& covariance);

/// Truth interpolated at `stamp`, or nullopt when no truth sample is close enough (see
/// PoseEvaluationOptions). `truth` is sorted by stamp.
std::optional<Transform> truthAt(const std::vector<Transform>& truth, Timestamp stamp,
                                 const PoseEvaluationOptions& options);

/// Compares `estimates` with `truth` (both sorted by time; checked). Fails when the frames of
/// the two series differ or a series is not in time order.
Result<PoseEvaluation> evaluatePoses(const std::vector<EstimateSample>& estimates,
                                     const std::vector<Transform>& truth,
                                     const PoseEvaluationOptions& options = {});

/// The errors of the matched estimates whose truth range lies in [min_range_m, max_range_m).
std::vector<MatchedError> inRange(const std::vector<MatchedError>& errors, double min_range_m,
                                  double max_range_m);

}  // namespace cdff::eval
