#pragma once
// The evaluation report: JSON (stable keys, docs/evaluation.md), a self-contained HTML page with
// error plots (inline SVG: it opens offline), and a short text table for terminals.

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/eval/bearing_evaluation.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/eval/requirements.hpp"

namespace cdff::eval {

struct EvaluationReport {
  std::string input;              // what was evaluated (file names)
  std::string statistic = "p95";  // the statistic the verdicts use
  std::vector<PoseEvaluation> products;
  std::vector<BearingEvaluation> bearings;  // far-range tracking's bearing products
  std::vector<RequirementVerdict> requirements;

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
