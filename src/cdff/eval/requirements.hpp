#pragma once
// The seed's DFPC requirements (§7.1) that a pose product can be measured against, and the
// verdicts `cdff eval` gives.
//
// Accuracy requirements apply to the estimates whose true range lies in the requirement's band
// (the seed's validation distances, Table 1: close range 0.5-2 m, mid range 2-17 m and beyond);
// the measured value is a statistic of those errors (p95 by default: "within the requirement 95 %
// of the time"; max is stricter). The update-rate requirement is measured on the worst interval
// between consecutive valid estimates, so that a track loss counts against it.

#include <string>
#include <vector>

#include "cdff/eval/bearing_evaluation.hpp"
#include "cdff/eval/pose_evaluation.hpp"

namespace cdff::eval {

struct RequirementSpec {
  std::string id;     // "SR_DFPC_0100"
  std::string title;  // as in the seed
  enum class Quantity {
    kPositionError,
    kAngleError,
    kUpdateRate,
    kBearingError,  // px on the camera
    kRangeError,    // % of the true range
  } quantity;
  double threshold = 0;                     // m, deg, Hz, px or %
  double min_range_m = 0, max_range_m = 0;  // band of true range (accuracy requirements)
};

/// SR_DFPC_0100 (mid range: < 1 m, < 10 deg), SR_DFPC_0101 (close range: < 0.05 m, < 5 deg),
/// SR_DFPC_0102 (update rate >= 0.1 Hz), one entry per measured quantity.
const std::vector<RequirementSpec>& poseRequirements();
/// The pose requirement on `quantity` whose band of true range holds `range_m`; null when none.
const RequirementSpec* poseRequirementAt(RequirementSpec::Quantity quantity, double range_m);

/// Far-range tracking's bearing products (seed §2.2.2, issue 18): the bearing of the target's
/// centre within 1 px on the sensor ("in the order of magnitude of 1 pixel"), an update at least
/// every second (the seed's 1 Hz navigation), the radar range within 1 % where there is one.
const std::vector<RequirementSpec>& bearingRequirements();

enum class Verdict { kPass, kFail, kNotApplicable };
const char* toString(Verdict verdict);

enum class Statistic { kRmse, kP95, kMax };
const char* toString(Statistic statistic);

struct RequirementVerdict {
  std::string id;
  std::string title;
  std::string channel;     // the product channel it was measured on
  std::string quantity;    // "position_error_m", "angle_error_deg", "update_rate_hz",
                           // "bearing_error_px", "range_error_pct"
  std::string comparison;  // "<" or ">="
  std::string statistic;   // "p95", "max", "rmse" or "min" (rates)
  Verdict verdict = Verdict::kNotApplicable;
  double measured = 0;
  double threshold = 0;
  std::size_t frames = 0;  // estimates the measurement is over
  std::string note;        // why not applicable, the range band...
};

/// Verdicts of every requirement of poseRequirements() for one evaluated product.
std::vector<RequirementVerdict> checkRequirements(const PoseEvaluation& evaluation,
                                                  Statistic statistic = Statistic::kP95);

/// Verdicts of every requirement of bearingRequirements() for one evaluated bearing product.
std::vector<RequirementVerdict> checkRequirements(const BearingEvaluation& evaluation,
                                                  Statistic statistic = Statistic::kP95);

}  // namespace cdff::eval
