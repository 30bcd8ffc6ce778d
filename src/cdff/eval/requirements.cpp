#include "cdff/eval/requirements.hpp"

#include <fmt/format.h>

#include <cmath>

namespace cdff::eval {

namespace {

constexpr double kCloseRangeMinM = 0.0;
constexpr double kMidRangeMinM = 2.0;     // the seed's boundary between its validation distances
constexpr double kMidRangeMaxM = 1000.0;  // "100's m"; beyond is far range (bearing only)

double pick(const ErrorStatistics& s, Statistic statistic) {
  switch (statistic) {
    case Statistic::kRmse:
      return s.rmse;
    case Statistic::kP95:
      return s.p95;
    case Statistic::kMax:
      return s.max;
  }
  return s.max;
}

}  // namespace

const std::vector<RequirementSpec>& poseRequirements() {
  using Q = RequirementSpec::Quantity;
  static const std::vector<RequirementSpec> requirements = {
      {"SR_DFPC_0100", "Mid-range tracking: pose accuracy w.r.t. chaser < 1 m", Q::kPositionError,
       1.0, kMidRangeMinM, kMidRangeMaxM},
      {"SR_DFPC_0100", "Mid-range tracking: pose accuracy w.r.t. chaser < 10 deg", Q::kAngleError,
       10.0, kMidRangeMinM, kMidRangeMaxM},
      {"SR_DFPC_0101", "Close-range tracking: pose accuracy w.r.t. chaser < 0.05 m",
       Q::kPositionError, 0.05, kCloseRangeMinM, kMidRangeMinM},
      {"SR_DFPC_0101", "Close-range tracking: pose accuracy w.r.t. chaser < 5 deg", Q::kAngleError,
       5.0, kCloseRangeMinM, kMidRangeMinM},
      {"SR_DFPC_0102", "Mid- and close-range tracking: pose update frequency >= 0.1 Hz",
       Q::kUpdateRate, 0.1, 0, 0},
  };
  return requirements;
}

const RequirementSpec* poseRequirementAt(RequirementSpec::Quantity quantity, double range_m) {
  for (const RequirementSpec& spec : poseRequirements())
    if (spec.quantity == quantity && range_m >= spec.min_range_m && range_m < spec.max_range_m)
      return &spec;
  return nullptr;
}

const std::vector<RequirementSpec>& bearingRequirements() {
  using Q = RequirementSpec::Quantity;
  static const std::vector<RequirementSpec> requirements = {
      {"UC1_BEARING", "Far-range tracking: bearing of the target's centre within 1 px (seed 2.2.2)",
       Q::kBearingError, 1.0, 0, 0},
      {"UC1_RATE", "Far-range tracking: bearing update frequency >= 1 Hz (seed 2.2.2)",
       Q::kUpdateRate, 1.0, 0, 0},
      {"UC1_RANGE", "Far-range tracking: range error < 1 % of the range with a radar (issue 18)",
       Q::kRangeError, 1.0, 0, 0},
  };
  return requirements;
}

const char* toString(Verdict verdict) {
  switch (verdict) {
    case Verdict::kPass:
      return "pass";
    case Verdict::kFail:
      return "fail";
    case Verdict::kNotApplicable:
      return "not_applicable";
  }
  return "?";
}

const char* toString(Statistic statistic) {
  switch (statistic) {
    case Statistic::kRmse:
      return "rmse";
    case Statistic::kP95:
      return "p95";
    case Statistic::kMax:
      return "max";
  }
  return "?";
}

namespace {

RequirementVerdict verdictOf(const RequirementSpec& spec, const std::string& channel) {
  RequirementVerdict v;
  v.id = spec.id;
  v.title = spec.title;
  v.channel = channel;
  v.threshold = spec.threshold;
  return v;
}

// The worst update rate (1 / the longest interval between valid estimates) against `spec`.
RequirementVerdict rateVerdict(const RequirementSpec& spec, const std::string& channel,
                               std::size_t valid_frames, double min_rate_hz, double rate_hz) {
  RequirementVerdict v = verdictOf(spec, channel);
  v.quantity = "update_rate_hz";
  v.comparison = ">=";
  v.statistic = "min";
  v.frames = valid_frames;
  if (valid_frames < 2) {
    v.note = fmt::format("{} valid estimate(s); a rate needs at least 2", valid_frames);
  } else {
    v.measured = min_rate_hz;
    v.verdict = v.measured >= spec.threshold ? Verdict::kPass : Verdict::kFail;
    v.note =
        fmt::format("1 / longest interval between valid estimates (mean rate {:.3g} Hz)", rate_hz);
  }
  return v;
}

// An accuracy verdict: `statistic` of `errors` below the threshold; not applicable without
// errors, saying why (`missing`).
RequirementVerdict accuracyVerdict(const RequirementSpec& spec, const std::string& channel,
                                   const char* quantity, std::vector<double> errors,
                                   Statistic statistic, const std::string& note,
                                   const std::string& missing) {
  RequirementVerdict v = verdictOf(spec, channel);
  v.quantity = quantity;
  v.comparison = "<";
  v.statistic = toString(statistic);
  v.frames = errors.size();
  if (errors.empty()) {
    v.note = missing;
  } else {
    v.measured = pick(ErrorStatistics::of(std::move(errors)), statistic);
    v.verdict = v.measured < spec.threshold ? Verdict::kPass : Verdict::kFail;
    v.note = note;
  }
  return v;
}

}  // namespace

std::vector<RequirementVerdict> checkRequirements(const BearingEvaluation& evaluation,
                                                  Statistic statistic) {
  using Q = RequirementSpec::Quantity;
  std::vector<RequirementVerdict> verdicts;
  for (const RequirementSpec& spec : bearingRequirements()) {
    std::vector<double> errors;
    if (spec.quantity == Q::kUpdateRate) {
      verdicts.push_back(rateVerdict(spec, evaluation.channel, evaluation.valid_frames,
                                     evaluation.min_rate_hz, evaluation.rate_hz));
    } else if (spec.quantity == Q::kBearingError) {
      for (const BearingError& e : evaluation.errors)
        if (std::isfinite(e.pixels)) errors.push_back(e.pixels);
      verdicts.push_back(accuracyVerdict(
          spec, evaluation.channel, "bearing_error_px", std::move(errors), statistic,
          fmt::format("against the centre of mass; focal length {:.6g} px", evaluation.focal_px),
          evaluation.matched_frames == 0
              ? std::string("no matched estimate")
              : std::string("no focal length: no camera calibration in the recording "
                            "(cdff eval --focal-px or --camera)")));
    } else if (spec.quantity == Q::kRangeError) {
      for (const BearingError& e : evaluation.errors)
        if (std::isfinite(e.range_error_pct)) errors.push_back(std::abs(e.range_error_pct));
      verdicts.push_back(accuracyVerdict(spec, evaluation.channel, "range_error_pct",
                                         std::move(errors), statistic, "|range error| / range",
                                         "no matched estimate with a range (no radar)"));
    }
  }
  return verdicts;
}

std::vector<RequirementVerdict> checkRequirements(const PoseEvaluation& evaluation,
                                                  Statistic statistic) {
  using Q = RequirementSpec::Quantity;
  std::vector<RequirementVerdict> verdicts;
  for (const RequirementSpec& spec : poseRequirements()) {
    if (spec.quantity == Q::kUpdateRate) {
      verdicts.push_back(rateVerdict(spec, evaluation.channel, evaluation.valid_frames,
                                     evaluation.min_rate_hz, evaluation.rate_hz));
      continue;
    }
    const std::vector<MatchedError> band =
        inRange(evaluation.errors, spec.min_range_m, spec.max_range_m);
    std::vector<double> errors;
    for (const MatchedError& e : band) {
      const double error =
          spec.quantity == Q::kPositionError ? e.position_error_m : e.angle_error_deg;
      if (std::isfinite(error)) errors.push_back(error);  // NaN: an unobserved attitude
    }
    const std::string band_text =
        fmt::format("true range in [{:g}, {:g}) m", spec.min_range_m, spec.max_range_m);
    verdicts.push_back(accuracyVerdict(
        spec, evaluation.channel,
        spec.quantity == Q::kPositionError ? "position_error_m" : "angle_error_deg",
        std::move(errors), statistic, band_text, "no matched estimate with " + band_text));
  }
  return verdicts;
}

}  // namespace cdff::eval
