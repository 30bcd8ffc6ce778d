#pragma once
// Accuracy of estimated poses against ground truth: the numbers `cdff eval` reports.
//
// An estimate series (a DFPC's product channel) is compared with a truth series of the same
// transform (same parent and child frames). Truth is interpolated at each estimate's timestamp
// (linear in translation, slerp in rotation) when two truth samples bracket it within
// `max_truth_gap`; otherwise the estimate has no truth and is counted as unmatched, not as an
// error. Every statistic is over matched estimates that the DFPC reported as valid (tracking).

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
};

/// RMSE, 95th percentile and maximum of a set of non-negative errors; all NaN when empty.
struct ErrorStatistics {
  std::size_t count = 0;
  double rmse = 0, p95 = 0, max = 0;

  static ErrorStatistics of(std::vector<double> errors);
};

/// The error of one matched estimate.
struct MatchedError {
  Timestamp stamp = 0;
  double range_m = 0;           // |translation| of the truth pose
  double position_error_m = 0;  // |t_est - t_true|
  double angle_error_deg = 0;   // angle of R_est R_true^T
};

struct PoseEvaluationOptions {
  /// Longest gap between two truth samples across which truth is interpolated.
  double max_truth_gap_s = 0.5;
  /// An estimate within this time of a truth sample uses that sample when it cannot be
  /// interpolated (e.g. the last estimate after the last truth sample).
  double nearest_truth_tolerance_s = 1e-3;
};

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

  /// Valid estimates per second over the span from the first to the last one.
  double rate_hz = 0;
  /// 1 / (longest interval between consecutive valid estimates): the worst update rate.
  double min_rate_hz = 0;
  double min_range_m = 0, max_range_m = 0;  // truth range over matched estimates

  std::vector<MatchedError> errors;  // per matched estimate, in time order (for plots)
};

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
