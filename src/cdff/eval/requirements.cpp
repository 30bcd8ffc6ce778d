#include "cdff/eval/requirements.hpp"

#include <fmt/format.h>

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

std::vector<RequirementVerdict> checkRequirements(const PoseEvaluation& evaluation,
                                                  Statistic statistic) {
  using Q = RequirementSpec::Quantity;
  std::vector<RequirementVerdict> verdicts;
  for (const RequirementSpec& spec : poseRequirements()) {
    RequirementVerdict v;
    v.id = spec.id;
    v.title = spec.title;
    v.channel = evaluation.channel;
    v.threshold = spec.threshold;
    if (spec.quantity == Q::kUpdateRate) {
      v.quantity = "update_rate_hz";
      v.comparison = ">=";
      v.statistic = "min";
      v.frames = evaluation.valid_frames;
      if (evaluation.valid_frames < 2) {
        v.note =
            fmt::format("{} valid estimate(s); a rate needs at least 2", evaluation.valid_frames);
      } else {
        v.measured = evaluation.min_rate_hz;
        v.verdict = v.measured >= spec.threshold ? Verdict::kPass : Verdict::kFail;
        v.note = fmt::format("1 / longest interval between valid estimates (mean rate {:.3g} Hz)",
                             evaluation.rate_hz);
      }
      verdicts.push_back(std::move(v));
      continue;
    }
    const std::vector<MatchedError> band =
        inRange(evaluation.errors, spec.min_range_m, spec.max_range_m);
    std::vector<double> errors;
    for (const MatchedError& e : band)
      errors.push_back(spec.quantity == Q::kPositionError ? e.position_error_m : e.angle_error_deg);
    v.quantity = spec.quantity == Q::kPositionError ? "position_error_m" : "angle_error_deg";
    v.comparison = "<";
    v.statistic = toString(statistic);
    v.frames = errors.size();
    const std::string band_text =
        fmt::format("true range in [{:g}, {:g}) m", spec.min_range_m, spec.max_range_m);
    if (errors.empty()) {
      v.note = "no matched estimate with " + band_text;
    } else {
      v.measured = pick(ErrorStatistics::of(std::move(errors)), statistic);
      v.verdict = v.measured < spec.threshold ? Verdict::kPass : Verdict::kFail;
      v.note = band_text;
    }
    verdicts.push_back(std::move(v));
  }
  return verdicts;
}

}  // namespace cdff::eval
