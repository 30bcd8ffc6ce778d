#pragma once
// Accuracy of estimated bearings (far-range tracking's product, seed §2.2.2) against ground
// truth: the direction to the target's centre of mass, and the range where a radar gives one.
//
// The truth is a pose series servicer_T_target whose parent frame is the bearing's frame: its
// translation points from the servicer to the target's origin, which the simulator puts at the
// centre of mass. It is interpolated at each estimate's time as for poses (pose_evaluation.hpp).
//
// The bearing error is the angle between the estimated and the true direction, in microradians
// and, where a camera's focal length is known, in pixels (angle × f: the seed states its
// expectation on the sensor, "about one pixel"). Its covariance (rank 2, across the direction)
// gives a 2-dof NEES: honest, it averages 2 and 95 % of the values lie below 5.99. The range's
// error is reported in % of the true range with its own 1-dof NEES (1 when honest).

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/types/bearing.hpp"

namespace cdff::eval {

/// One bearing product, whether its DFPC called it valid, and its step's latency when known.
struct BearingSample {
  Bearing bearing;
  bool valid = true;
  std::optional<double> latency_s;
};

/// The error of one matched bearing.
struct BearingError {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  Timestamp stamp = 0;
  double range_m = 0;             // |translation| of the truth
  double angle_urad = 0;          // angle between the estimated and the true direction
  double pixels = kNaN;           // angle_urad × focal length; NaN without one
  double nees = kNaN;             // 2-dof NEES of the direction; NaN without a usable covariance
  double range_error_pct = kNaN;  // 100 (range_est - range_true) / range_true; NaN without range
  double range_nees = kNaN;       // (range error)^2 / variance; NaN without a variance
};

/// How honest the directions' and ranges' covariances are (NaN statistics when none is usable).
struct BearingConsistency {
  static constexpr double kChiSquare2Dof95 = 5.991;  // 95 % quantile of chi-square, 2 dof
  std::size_t count = 0;                             // directions with a usable covariance
  std::size_t rejected = 0;  // covariances not of rank 2 across the direction
  double nees_mean = std::numeric_limits<double>::quiet_NaN();           // 2 when honest
  double nees_p95 = std::numeric_limits<double>::quiet_NaN();            // 5.99 when honest
  double within_95_fraction = std::numeric_limits<double>::quiet_NaN();  // 0.95 when honest
  double range_nees_mean = std::numeric_limits<double>::quiet_NaN();     // 1 when honest
};

/// Everything `cdff eval` says about one bearing product channel.
struct BearingEvaluation {
  std::string channel;
  std::string truth_channel;
  std::string frame;           // the bearings' frame (the truth's parent frame)
  std::string camera_channel;  // where the focal length came from ("" when given or unknown)
  double focal_px = std::numeric_limits<double>::quiet_NaN();

  std::size_t frames = 0, valid_frames = 0, matched_frames = 0;
  double tracked_fraction = 0;    // valid_frames / frames
  std::size_t ranged_frames = 0;  // matched estimates that carry a range

  ErrorStatistics angle_urad;
  ErrorStatistics pixels;           // count 0 without a focal length
  ErrorStatistics range_error_pct;  // of |error|; count 0 without ranges
  ErrorStatistics latency_s;
  BearingConsistency covariance;

  double rate_hz = 0, min_rate_hz = 0;
  double min_range_m = 0, max_range_m = 0;

  std::vector<BearingError> errors;  // per matched estimate, in time order (for plots)
};

/// Compares `estimates` with `truth` (both sorted by time; checked); `focal_px` NaN when no
/// camera's focal length is known. Fails when the truth's parent frame is not the bearings'
/// frame or a series is not in time order.
Result<BearingEvaluation> evaluateBearings(
    const std::vector<BearingSample>& estimates, const std::vector<Transform>& truth,
    double focal_px = std::numeric_limits<double>::quiet_NaN(),
    const PoseEvaluationOptions& options = {});

}  // namespace cdff::eval
