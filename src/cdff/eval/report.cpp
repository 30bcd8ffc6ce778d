#include "cdff/eval/report.hpp"

#include "cdff/eval/html.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

#include <fmt/format.h>

namespace cdff::eval {

namespace {

nlohmann::json number(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

nlohmann::json statisticsJson(const ErrorStatistics& s, double scale = 1.0) {
  return {{"rmse", number(s.rmse * scale)},
          {"p95", number(s.p95 * scale)},
          {"max", number(s.max * scale)},
          {"count", s.count}};
}

std::string formatValue(double value, const char* format = "{:.4g}") {
  return std::isfinite(value) ? fmt::format(fmt::runtime(format), value) : "—";
}

// null when no estimate carried a usable covariance.
nlohmann::json consistencyJson(const CovarianceConsistency& c) {
  // A product whose attitude is never observed has a position consistency alone.
  if (c.count == 0 && c.rejected == 0 && !std::isfinite(c.position_nees_mean)) return nullptr;
  return {{"count", c.count},
          {"rejected", c.rejected},
          {"nees_mean", number(c.nees_mean)},
          {"nees_p95", number(c.nees_p95)},
          {"within_95_fraction", number(c.within_95_fraction)},
          {"position_nees_mean", number(c.position_nees_mean)},
          {"attitude_nees_mean", number(c.attitude_nees_mean)},
          {"dof", 6},
          {"bound_95", CovarianceConsistency::kChiSquare6Dof95}};
}

// One line on the covariance's honesty, empty when the product carries none.
std::string consistencyText(const CovarianceConsistency& c) {
  if (c.count == 0 && c.rejected == 0) {
    if (!std::isfinite(c.position_nees_mean)) return {};
    return fmt::format(
        "covariance: position NEES mean {} (3 if honest); the attitude is never "
        "observed",
        formatValue(c.position_nees_mean, "{:.3g}"));
  }
  std::string text = fmt::format(
      "covariance: NEES mean {} (6 if honest; position {}, attitude {}, 3 each), p95 {}, {} % "
      "within the 95 % bound {:g}",
      formatValue(c.nees_mean, "{:.3g}"), formatValue(c.position_nees_mean, "{:.3g}"),
      formatValue(c.attitude_nees_mean, "{:.3g}"), formatValue(c.nees_p95, "{:.3g}"),
      formatValue(100.0 * c.within_95_fraction, "{:.1f}"), CovarianceConsistency::kChiSquare6Dof95);
  if (c.rejected) text += fmt::format("; {} not positive definite", c.rejected);
  return text;
}

nlohmann::json bearingConsistencyJson(const BearingConsistency& c) {
  if (c.count == 0 && c.rejected == 0) return nullptr;
  return {{"count", c.count},
          {"rejected", c.rejected},
          {"nees_mean", number(c.nees_mean)},
          {"nees_p95", number(c.nees_p95)},
          {"within_95_fraction", number(c.within_95_fraction)},
          {"range_nees_mean", number(c.range_nees_mean)},
          {"dof", 2},
          {"bound_95", BearingConsistency::kChiSquare2Dof95}};
}

std::string bearingConsistencyText(const BearingConsistency& c) {
  if (c.count == 0 && c.rejected == 0) return {};
  std::string text = fmt::format(
      "covariance: NEES mean {} (2 if honest), p95 {}, {} % within the 95 % bound {:g}; range "
      "NEES mean {} (1 if honest)",
      formatValue(c.nees_mean, "{:.3g}"), formatValue(c.nees_p95, "{:.3g}"),
      formatValue(100.0 * c.within_95_fraction, "{:.1f}"), BearingConsistency::kChiSquare2Dof95,
      formatValue(c.range_nees_mean, "{:.3g}"));
  if (c.rejected) text += fmt::format("; {} not of rank 2 across the direction", c.rejected);
  return text;
}

nlohmann::json bearingJson(const BearingEvaluation& b) {
  return {
      {"channel", b.channel},
      {"truth_channel", b.truth_channel},
      {"frame", b.frame},
      {"camera_channel", b.camera_channel},
      {"focal_px", number(b.focal_px)},
      {"frames", b.frames},
      {"valid_frames", b.valid_frames},
      {"matched_frames", b.matched_frames},
      {"ranged_frames", b.ranged_frames},
      {"tracked_fraction", number(b.tracked_fraction)},
      {"bearing_error_urad", statisticsJson(b.angle_urad)},
      {"bearing_error_px", statisticsJson(b.pixels)},
      {"range_error_pct", statisticsJson(b.range_error_pct)},
      {"latency_ms", statisticsJson(b.latency_s, 1e3)},
      {"covariance_consistency", bearingConsistencyJson(b.covariance)},
      {"rate_hz", number(b.rate_hz)},
      {"min_rate_hz", number(b.min_rate_hz)},
      {"range_m", {{"min", number(b.min_range_m)}, {"max", number(b.max_range_m)}}},
  };
}

// One verdict's line under its product's statistics.
std::string verdictLine(const RequirementVerdict& v) {
  return fmt::format("  {:<13}{:<17}{:<15} {} {} {:g}  {}\n", v.id, v.quantity, toString(v.verdict),
                     v.verdict == Verdict::kNotApplicable
                         ? std::string("—")
                         : fmt::format("{} {:.4g}", v.statistic, v.measured),
                     v.comparison, v.threshold, v.note);
}

std::string bearingText(const BearingEvaluation& b, const std::vector<RequirementVerdict>& all) {
  std::string text =
      fmt::format("{}  (bearing; truth {}, frame {}; focal length {} px{})\n", b.channel,
                  b.truth_channel, b.frame, formatValue(b.focal_px, "{:.6g}"),
                  b.camera_channel.empty() ? "" : " from " + b.camera_channel);
  text += fmt::format(
      "  frames {}  valid {}  matched {}  tracked {:.1f} %  rate {} Hz (worst {} Hz)  range "
      "{}-{} m\n",
      b.frames, b.valid_frames, b.matched_frames, 100.0 * b.tracked_fraction,
      formatValue(b.rate_hz, "{:.3g}"), formatValue(b.min_rate_hz, "{:.3g}"),
      formatValue(b.min_range_m, "{:.4g}"), formatValue(b.max_range_m, "{:.4g}"));
  text += "                      rmse        p95        max\n";
  const auto row = [&](const char* name, const ErrorStatistics& s, double scale) {
    text += fmt::format("  {:<18}{:>8}   {:>8}   {:>8}\n", name, formatValue(s.rmse * scale),
                        formatValue(s.p95 * scale), formatValue(s.max * scale));
  };
  row("bearing [urad]", b.angle_urad, 1.0);
  if (b.pixels.count) row("bearing [px]", b.pixels, 1.0);
  if (b.range_error_pct.count) row("range [% range]", b.range_error_pct, 1.0);
  if (b.latency_s.count) row("latency [ms]", b.latency_s, 1e3);
  if (const std::string c = bearingConsistencyText(b.covariance); !c.empty())
    text += "  " + c + "\n";
  for (const RequirementVerdict& v : all)
    if (v.channel == b.channel) text += verdictLine(v);
  return text;
}

double thresholdFor(const std::string& quantity, double range_m) {
  using Q = RequirementSpec::Quantity;
  const RequirementSpec* spec =
      quantity == "position_error_m"  ? poseRequirementAt(Q::kPositionError, range_m)
      : quantity == "angle_error_deg" ? poseRequirementAt(Q::kAngleError, range_m)
                                      : nullptr;
  return spec ? spec->threshold : NAN;
}

}  // namespace

bool EvaluationReport::allPass() const {
  return std::none_of(requirements.begin(), requirements.end(),
                      [](const RequirementVerdict& v) { return v.verdict == Verdict::kFail; });
}

namespace {

nlohmann::json verdictJson(const RequirementVerdict& v) {
  return {
      {"id", v.id},
      {"title", v.title},
      {"channel", v.channel},
      {"quantity", v.quantity},
      {"statistic", v.statistic},
      {"comparison", v.comparison},
      {"verdict", toString(v.verdict)},
      {"measured",
       v.verdict == Verdict::kNotApplicable ? nlohmann::json(nullptr) : number(v.measured)},
      {"threshold", v.threshold},
      {"frames", v.frames},
      {"note", v.note},
  };
}

nlohmann::json handoversJson(const EvaluationReport& report) {
  nlohmann::json out = nlohmann::json::array();
  for (const Handover& h : report.handovers) {
    nlohmann::json steps = nlohmann::json::object();
    for (const auto& [channel, sigma] : h.max_step_sigma) steps[channel] = number(sigma);
    out.push_back({{"t_s", toSeconds(h.stamp - report.start)},
                   {"dfpc", h.dfpc},
                   {"type", h.type},
                   {"max_step_sigma", steps}});
  }
  return out;
}

std::string continuityText(const Continuity& c, Timestamp start) {
  if (c.steps.empty()) return "";
  return fmt::format("continuity: {} steps, largest {:.2f} sigma at {:.1f} s, {} beyond {:g} sigma",
                     c.steps.size(), c.max_sigma, toSeconds(c.worst_stamp - start), c.jumps,
                     Continuity::kJumpSigma);
}

std::string handoversText(const EvaluationReport& report) {
  if (report.handovers.empty()) return "";
  std::string text = fmt::format(
      "hand-overs (the DFPCs' rules; each pose product's largest step in the next {:g} s):\n",
      Handover::kWindowS);
  for (const Handover& h : report.handovers) {
    text += fmt::format("  {:7.1f} s  {} {}", toSeconds(h.stamp - report.start), h.dfpc, h.type);
    for (const auto& [channel, sigma] : h.max_step_sigma)
      text += fmt::format("; {} {:.2f} sigma", channel, sigma);
    text += "\n";
  }
  return text;
}

std::string phaseRange(const PhaseSpec& phase) {
  return std::isfinite(phase.max_range_m)
             ? fmt::format("{:g}-{:g} m", phase.min_range_m, phase.max_range_m)
             : fmt::format("from {:g} m", phase.min_range_m);
}

}  // namespace

nlohmann::json toJson(const EvaluationReport& report) {
  nlohmann::json products = nlohmann::json::array();
  for (const PoseEvaluation& p : report.products) {
    products.push_back({
        {"channel", p.channel},
        {"truth_channel", p.truth_channel},
        {"transform", p.parent_frame + "_T_" + p.child_frame},
        {"frames", p.frames},
        {"valid_frames", p.valid_frames},
        {"matched_frames", p.matched_frames},
        {"tracked_fraction", number(p.tracked_fraction)},
        {"position_error_m", statisticsJson(p.position_error_m)},
        {"position_error_pct_range", statisticsJson(p.position_error_pct_range)},
        {"angle_error_deg", statisticsJson(p.angle_error_deg)},
        {"latency_ms", statisticsJson(p.latency_s, 1e3)},
        {"covariance_consistency", consistencyJson(p.covariance)},
        {"continuity",
         {{"steps", p.continuity.steps.size()},
          {"max_step_sigma", number(p.continuity.max_sigma)},
          {"worst_s", p.continuity.steps.empty()
                          ? nlohmann::json(nullptr)
                          : nlohmann::json(toSeconds(p.continuity.worst_stamp - report.start))},
          {"steps_beyond_3_sigma", p.continuity.jumps}}},
        {"rate_hz", number(p.rate_hz)},
        {"min_rate_hz", number(p.min_rate_hz)},
        {"range_m", {{"min", number(p.min_range_m)}, {"max", number(p.max_range_m)}}},
    });
  }
  nlohmann::json bearings = nlohmann::json::array();
  for (const BearingEvaluation& b : report.bearings) bearings.push_back(bearingJson(b));
  nlohmann::json requirements = nlohmann::json::array();
  for (const RequirementVerdict& v : report.requirements) requirements.push_back(verdictJson(v));
  nlohmann::json phases = nlohmann::json::array();
  for (const PhaseResult& phase : report.phases) {
    nlohmann::json verdicts = nlohmann::json::array();
    for (const RequirementVerdict& v : phase.verdicts) verdicts.push_back(verdictJson(v));
    phases.push_back({
        {"name", phase.span.phase.name},
        {"range_m", {number(phase.span.phase.min_range_m), number(phase.span.phase.max_range_m)}},
        {"start_s", toSeconds(phase.span.start - report.start)},
        {"end_s", toSeconds(phase.span.end - report.start)},
        {"verdicts", verdicts},
    });
  }
  return {{"input", report.input},
          {"verdict_statistic", report.statistic},
          {"all_pass", report.allPass()},
          {"products", products},
          {"bearings", bearings},
          {"requirements", requirements},
          {"phases", phases},
          {"handovers", handoversJson(report)}};
}

std::string toText(const EvaluationReport& report) {
  std::string text;
  for (const PoseEvaluation& p : report.products) {
    text += fmt::format("{}  (truth {}, {}_T_{})\n", p.channel, p.truth_channel, p.parent_frame,
                        p.child_frame);
    text += fmt::format(
        "  frames {}  valid {}  matched {}  tracked {:.1f} %  rate {} Hz (worst {} Hz)  range "
        "{}-{} m\n",
        p.frames, p.valid_frames, p.matched_frames, 100.0 * p.tracked_fraction,
        formatValue(p.rate_hz, "{:.3g}"), formatValue(p.min_rate_hz, "{:.3g}"),
        formatValue(p.min_range_m, "{:.3g}"), formatValue(p.max_range_m, "{:.3g}"));
    text += "                      rmse        p95        max\n";
    const auto row = [&](const char* name, const ErrorStatistics& s, double scale) {
      text += fmt::format("  {:<18}{:>8}   {:>8}   {:>8}\n", name, formatValue(s.rmse * scale),
                          formatValue(s.p95 * scale), formatValue(s.max * scale));
    };
    row("position [mm]", p.position_error_m, 1e3);
    row("position [% range]", p.position_error_pct_range, 1.0);
    row("angle [deg]", p.angle_error_deg, 1.0);
    if (p.latency_s.count) row("latency [ms]", p.latency_s, 1e3);
    if (const std::string c = consistencyText(p.covariance); !c.empty()) text += "  " + c + "\n";
    if (const std::string c = continuityText(p.continuity, report.start); !c.empty())
      text += "  " + c + "\n";
    // Each product's verdicts right under its statistics.
    for (const RequirementVerdict& v : report.requirements)
      if (v.channel == p.channel) text += verdictLine(v);
  }
  for (const BearingEvaluation& b : report.bearings) text += bearingText(b, report.requirements);
  text += handoversText(report);
  if (!report.phases.empty()) text += "phases (seed Table 1, by the true range):\n";
  for (const PhaseResult& phase : report.phases) {
    text += fmt::format("{}  ({}; {:.1f}-{:.1f} s)\n", phase.span.phase.name,
                        phaseRange(phase.span.phase), toSeconds(phase.span.start - report.start),
                        toSeconds(phase.span.end - report.start));
    if (phase.verdicts.empty()) text += "  no product made a valid estimate\n";
    std::string channel;
    for (const RequirementVerdict& v : phase.verdicts) {
      if (v.channel != channel) text += fmt::format("  {}\n", channel = v.channel);
      text += "  " + verdictLine(v);
    }
  }
  return text;
}

namespace {

// The page's head: title and style sheet.
std::string htmlHead() {
  return std::string(R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>CDFF evaluation</title>
<style>
)") + kPageCss +
         "</style></head><body>\n";
}

// One product's summary: its truth and rates, its error statistics.
std::string productHtml(const PoseEvaluation& p, Timestamp start) {
  std::string html;
  html += fmt::format(
      "<h2>{}</h2><p>Truth: <code>{}</code> ({}_T_{}). {} frames, {} valid, "
      "{} matched with truth; tracked {:.1f} %; rate {} Hz (worst {} Hz).</p>\n",
      escapeHtml(p.channel), escapeHtml(p.truth_channel), escapeHtml(p.parent_frame),
      escapeHtml(p.child_frame), p.frames, p.valid_frames, p.matched_frames,
      100.0 * p.tracked_fraction, formatValue(p.rate_hz, "{:.3g}"),
      formatValue(p.min_rate_hz, "{:.3g}"));
  html += "<table><tr><th>error</th><th>RMSE</th><th>p95</th><th>max</th></tr>\n";
  const auto row = [&](const char* name, const ErrorStatistics& s, double scale) {
    html += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n", name,
                        formatValue(s.rmse * scale), formatValue(s.p95 * scale),
                        formatValue(s.max * scale));
  };
  row("position [mm]", p.position_error_m, 1e3);
  row("position [% of range]", p.position_error_pct_range, 1.0);
  row("angle [deg]", p.angle_error_deg, 1.0);
  if (p.latency_s.count) row("latency [ms]", p.latency_s, 1e3);
  html += "</table>\n";
  if (const std::string c = consistencyText(p.covariance); !c.empty())
    html += fmt::format("<p>The product's {}.</p>\n", escapeHtml(c));
  if (const std::string c = continuityText(p.continuity, start); !c.empty())
    html += fmt::format(
        "<p>Its {} (from one valid estimate to the next, under the first's "
        "covariance).</p>\n",
        escapeHtml(c));
  return html;
}

// One product's plots: errors over time and over range, NEES.
/// The time origin of a report's plots (its first truth sample) and its phases' starts.
struct TimeAxis {
  Timestamp t0 = 0;
  std::vector<PlotMarker> markers;
  static constexpr const char* kLabel = "time since the run's start [s]";
};

TimeAxis timeAxis(const EvaluationReport& report) {
  TimeAxis axis{report.start, {}};
  for (const PhaseResult& phase : report.phases)
    axis.markers.push_back({toSeconds(phase.span.start - report.start), phase.span.phase.name});
  return axis;
}

std::string productPlotsHtml(const PoseEvaluation& p, const TimeAxis& axis) {
  std::string html;
  PlotSeries position, angle, percent_by_range, nees;
  const Timestamp t0 = axis.t0;
  for (const MatchedError& e : p.errors) {
    const double t = toSeconds(e.stamp - t0);
    position.x.push_back(t);
    position.y.push_back(e.position_error_m);
    if (std::isfinite(e.angle_error_deg)) {
      angle.x.push_back(t);
      angle.y.push_back(e.angle_error_deg);
    }
    if (std::isfinite(e.nees)) {
      nees.x.push_back(t);
      nees.y.push_back(e.nees);
    }
    if (e.range_m > 0) {
      percent_by_range.x.push_back(e.range_m);
      percent_by_range.y.push_back(100.0 * e.position_error_m / e.range_m);
    }
  }
  // The requirement line only when one threshold holds over the whole plotted span.
  const double range_lo = p.min_range_m, range_hi = p.max_range_m;
  const auto oneThreshold = [&](const std::string& quantity) {
    const double a = thresholdFor(quantity, range_lo);
    const double b = thresholdFor(quantity, range_hi);
    return a == b ? a : NAN;
  };
  html += "<div>";
  html += svgPlot("Position error over time", TimeAxis::kLabel, "position error [m]", position,
                  oneThreshold("position_error_m"), true, axis.markers);
  html += svgPlot("Angle error over time", TimeAxis::kLabel, "angle error [deg]", angle,
                  oneThreshold("angle_error_deg"), true, axis.markers);
  html += svgPlot("Position error over range", "true range [m]", "position error [% of range]",
                  percent_by_range, NAN, false);
  if (!nees.x.empty())
    html +=
        svgPlot("Normalised error (NEES) over time, 95 % bound dashed", TimeAxis::kLabel,
                "NEES (6 dof)", nees, CovarianceConsistency::kChiSquare6Dof95, true, axis.markers);
  html += "</div>\n";
  return html;
}

double bearingThreshold(RequirementSpec::Quantity quantity) {
  for (const RequirementSpec& spec : bearingRequirements())
    if (spec.quantity == quantity) return spec.threshold;
  return NAN;
}

// One bearing product: its summary and its plots (error over time and over range, NEES, range).
std::string bearingHtml(const BearingEvaluation& b, const TimeAxis& axis) {
  std::string html = fmt::format(
      "<h2>{} (bearing)</h2><p>Truth: <code>{}</code>, the direction to the target's centre of "
      "mass in <code>{}</code>; focal length {} px{}. {} frames, {} valid, {} matched with "
      "truth, {} with a range; tracked {:.1f} %; rate {} Hz (worst {} Hz).</p>\n",
      escapeHtml(b.channel), escapeHtml(b.truth_channel), escapeHtml(b.frame),
      formatValue(b.focal_px, "{:.6g}"),
      b.camera_channel.empty() ? "" : " (" + escapeHtml(b.camera_channel) + ")", b.frames,
      b.valid_frames, b.matched_frames, b.ranged_frames, 100.0 * b.tracked_fraction,
      formatValue(b.rate_hz, "{:.3g}"), formatValue(b.min_rate_hz, "{:.3g}"));
  html += "<table><tr><th>error</th><th>RMSE</th><th>p95</th><th>max</th></tr>\n";
  const auto row = [&](const char* name, const ErrorStatistics& s, double scale) {
    html += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n", name,
                        formatValue(s.rmse * scale), formatValue(s.p95 * scale),
                        formatValue(s.max * scale));
  };
  row("bearing [µrad]", b.angle_urad, 1.0);
  if (b.pixels.count) row("bearing [px]", b.pixels, 1.0);
  if (b.range_error_pct.count) row("range [% of range]", b.range_error_pct, 1.0);
  if (b.latency_s.count) row("latency [ms]", b.latency_s, 1e3);
  html += "</table>\n";
  if (const std::string c = bearingConsistencyText(b.covariance); !c.empty())
    html += fmt::format("<p>The product's {}.</p>\n", escapeHtml(c));

  const bool in_px = b.pixels.count > 0;
  PlotSeries over_time, over_range, nees, range;
  const Timestamp t0 = axis.t0;
  for (const BearingError& e : b.errors) {
    const double t = toSeconds(e.stamp - t0), value = in_px ? e.pixels : e.angle_urad;
    over_time.x.push_back(t);
    over_time.y.push_back(value);
    over_range.x.push_back(e.range_m);
    over_range.y.push_back(value);
    if (std::isfinite(e.nees)) {
      nees.x.push_back(t);
      nees.y.push_back(e.nees);
    }
    if (std::isfinite(e.range_error_pct)) {
      range.x.push_back(t);
      range.y.push_back(std::abs(e.range_error_pct));
    }
  }
  const char* unit = in_px ? "bearing error [px]" : "bearing error [µrad]";
  const double threshold = in_px ? bearingThreshold(RequirementSpec::Quantity::kBearingError) : NAN;
  html += "<div>";
  html += svgPlot("Bearing error over time", TimeAxis::kLabel, unit, over_time, threshold, true,
                  axis.markers);
  html += svgPlot("Bearing error over range", "true range [m]", unit, over_range, threshold, false);
  if (!nees.x.empty())
    html += svgPlot("Normalised error (NEES) over time, 95 % bound dashed", TimeAxis::kLabel,
                    "NEES (2 dof)", nees, BearingConsistency::kChiSquare2Dof95, true, axis.markers);
  if (!range.x.empty())
    html += svgPlot("Range error over time", TimeAxis::kLabel, "|range error| [% of range]", range,
                    bearingThreshold(RequirementSpec::Quantity::kRangeError), true, axis.markers);
  html += "</div>\n";
  return html;
}

}  // namespace

namespace {

std::string verdictRowHtml(const RequirementVerdict& v) {
  return fmt::format(
      "<tr class='{}'><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{} {:g}</td><td>{}</td>"
      "<td>{}</td><td>{}</td></tr>\n",
      toString(v.verdict), escapeHtml(v.id), escapeHtml(v.channel), escapeHtml(v.quantity),
      v.verdict == Verdict::kNotApplicable ? "—"
                                           : fmt::format("{} {:.4g}", v.statistic, v.measured),
      v.comparison, v.threshold, v.frames, toString(v.verdict), escapeHtml(v.note));
}

// Each phase's span and the verdicts of the products that served it.
std::string phasesHtml(const EvaluationReport& report) {
  if (report.phases.empty()) return "";
  std::string html =
      "<h2>Phases (seed Table 1, by the true range)</h2><p>Each product's verdicts over the "
      "estimates it made during the phase; the plots mark each phase's start.</p>\n";
  for (const PhaseResult& phase : report.phases) {
    html += fmt::format("<h3>{} ({}; {:.1f}-{:.1f} s)</h3>\n", escapeHtml(phase.span.phase.name),
                        escapeHtml(phaseRange(phase.span.phase)),
                        toSeconds(phase.span.start - report.start),
                        toSeconds(phase.span.end - report.start));
    if (phase.verdicts.empty()) {
      html += "<p>No product made a valid estimate.</p>\n";
      continue;
    }
    html +=
        "<table><tr><th>id</th><th>channel</th><th>quantity</th><th>measured</th><th>threshold"
        "</th><th>frames</th><th>verdict</th><th>note</th></tr>\n";
    for (const RequirementVerdict& v : phase.verdicts) html += verdictRowHtml(v);
    html += "</table>\n";
  }
  return html;
}

}  // namespace

std::string toHtml(const EvaluationReport& report) {
  std::string html = htmlHead();
  html += fmt::format(
      "<h1>CDFF evaluation</h1><p>Input: <code>{}</code>. Verdicts use the {} of "
      "the errors in each requirement's range band.</p>\n",
      escapeHtml(report.input), escapeHtml(report.statistic));
  html +=
      "<h2>Requirements (seed §7.1, §2.2.2)</h2><table><tr><th>id</th><th>channel</th><th>quantity"
      "</th><th>measured</th><th>threshold</th><th>frames</th><th>verdict</th><th>note</th>"
      "</tr>\n";
  for (const RequirementVerdict& v : report.requirements) html += verdictRowHtml(v);
  html += "</table>\n";
  if (const std::string h = handoversText(report); !h.empty())
    html += "<h2>Hand-overs</h2><pre>" + escapeHtml(h) + "</pre>\n";
  html += phasesHtml(report);
  const TimeAxis axis = timeAxis(report);

  for (const PoseEvaluation& p : report.products) {
    html += productHtml(p, report.start);
    html += productPlotsHtml(p, axis);
  }
  for (const BearingEvaluation& b : report.bearings) html += bearingHtml(b, axis);
  html += "</body></html>\n";
  return html;
}

}  // namespace cdff::eval
