#pragma once
// The evaluation report: JSON (stable keys, docs/evaluation.md), a self-contained HTML page with
// error plots (inline SVG: it opens offline), and a short text table for terminals.

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/eval/bearing_evaluation.hpp"
#include "cdff/eval/phases.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/eval/requirements.hpp"

namespace cdff::eval {

/// One phase of the run (phases.hpp) and the verdicts of every product that made valid estimates
/// during it, over those estimates alone (the update rate counts the phase's start and end).
struct PhaseResult {
  PhaseSpan span;
  std::vector<RequirementVerdict> verdicts;  // the applicable ones
};

/// A DFPC started or stopped by the Orchestrator's rules (an `activated` or `deactivated` event
/// of the DFPC as a whole), with each pose product's largest step (Continuity) in the window
/// after it: what the hand-over did to the products that carry on.
struct Handover {
  static constexpr double kWindowS = 2.0;
  Timestamp stamp = 0;
  std::string dfpc;
  std::string type;                                            // "activated" or "deactivated"
  std::vector<std::pair<std::string, double>> max_step_sigma;  // product channel, sigma
};

struct EvaluationReport {
  std::string input;              // what was evaluated (file names)
  std::string statistic = "p95";  // the statistic the verdicts use
  std::vector<PoseEvaluation> products;
  std::vector<BearingEvaluation> bearings;  // far-range tracking's bearing products
  std::vector<RequirementVerdict> requirements;
  /// The rendezvous's phases the run went through, by the truth of the target's pose
  /// (/truth/target_pose); empty when the recording has no such truth.
  std::vector<PhaseResult> phases;
  std::vector<Handover> handovers;  // in time order
  Timestamp start = 0;  // the first truth sample: the time origin of the plots and phases

  /// True when no verdict is a fail (not-applicable ones do not count).
  bool allPass() const;
};

/// The report as JSON; NaN statistics (empty sets) become null.
nlohmann::json toJson(const EvaluationReport& report);
/// A standalone HTML page: summary tables and, per product, errors over time and over range.
std::string toHtml(const EvaluationReport& report);
/// A few lines per product and one per verdict, for the terminal.
std::string toText(const EvaluationReport& report);

}  // namespace cdff::eval
