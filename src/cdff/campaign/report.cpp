// A campaign's report (report.hpp).

#include "cdff/campaign/report.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>

#include <fmt/format.h>
#include <boost/math/distributions/beta.hpp>

#include "cdff/campaign/run.hpp"
#include "cdff/dfpc/graph.hpp"
#include "cdff/eval/html.hpp"

namespace cdff::campaign {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json distribution(const std::vector<double>& v) {
  if (v.empty()) return json::object({{"count", 0}});
  return {{"count", v.size()},
          {"min", *std::min_element(v.begin(), v.end())},
          {"p5", percentile(v, 5)},
          {"p50", percentile(v, 50)},
          {"p95", percentile(v, 95)},
          {"p99", percentile(v, 99)},
          {"max", *std::max_element(v.begin(), v.end())}};
}

struct RequirementTally {
  json first;  // the first row seen: id, title, quantity, threshold, comparison, statistic
  std::uint64_t pass = 0, fail = 0, not_applicable = 0;
  std::uint64_t no_product = 0;         // of the fails: runs whose DFPCs produced no pose at all
  std::set<std::string> applicable_in;  // scenarios where some run had a verdict
  std::vector<double> measured;
  std::vector<std::pair<double, std::uint64_t>> by_run;  // measured, run index
};

/// Worse first: the largest measured value for an upper bound ("<"), the smallest for a lower.
void sortWorstFirst(RequirementTally& t) {
  const bool upper = t.first.value("comparison", "<").find('<') != std::string::npos;
  std::sort(t.by_run.begin(), t.by_run.end(), [upper](const auto& a, const auto& b) {
    return upper ? a.first > b.first : a.first < b.first;
  });
}

json requirementsOf(std::map<std::string, RequirementTally>& tallies,
                    const std::map<std::uint64_t, json>& runs, double confidence) {
  json out = json::array();
  for (auto& [key, t] : tallies) {
    // Each field with a default of its type: a result edited by hand, or of an older version,
    // still gives a report.
    const auto text = [&t](const char* key, const char* otherwise) {
      return t.first.value(key, std::string(otherwise));
    };
    json r = {{"id", text("id", "?")},
              {"title", text("title", "")},
              {"channel", text("channel", "?")},
              {"quantity", text("quantity", "?")},
              {"statistic", text("statistic", "p95")},
              {"comparison", text("comparison", "<")},
              {"threshold", t.first.value("threshold", json())},
              {"pass", t.pass},
              {"fail", t.fail},
              {"not_applicable", t.not_applicable},
              {"failed_without_product", t.no_product},
              {"measured", distribution(t.measured)}};
    std::vector<double> sorted = t.measured;
    std::sort(sorted.begin(), sorted.end());
    r["measured_values"] = sorted;
    const std::uint64_t applicable = t.pass + t.fail;
    if (applicable > 0) {
      const auto [low, high] = clopperPearson(t.pass, applicable, confidence);
      r["pass_fraction"] = static_cast<double>(t.pass) / applicable;
      r["pass_interval"] = {low, high};
    }
    sortWorstFirst(t);
    json worst = json::array();
    for (std::size_t i = 0; i < std::min<std::size_t>(3, t.by_run.size()); ++i) {
      const json& run = runs.at(t.by_run[i].second);
      worst.push_back({{"index", t.by_run[i].second},
                       {"measured", t.by_run[i].first},
                       {"reproduce", run.value("reproduce", std::string())}});
    }
    r["worst_runs"] = worst;
    out.push_back(r);
  }
  return out;
}

/// A run's evaluation (an empty object when it has none, or none that is an object), not copied.
const json& evaluationOf(const json& run) {
  static const json kNone = json::object();
  const auto it = run.find("evaluation");
  return it != run.end() && it->is_object() ? *it : kNone;
}

/// A goal a campaign's graph states for one of its pose outputs (dfpc::GoalSpec).
struct ProductGoal {
  std::string dfpc, channel;
  dfpc::GoalSpec goal;
};

/// The goals of the campaign's graphs, loaded as the runs loaded them (with their settings); a
/// graph that no longer loads is a note, and its goals are not checked.
std::vector<ProductGoal> goalsOf(const Campaign& campaign, json& notes) {
  std::vector<ProductGoal> goals;
  for (const DfpcEntry& e : campaign.dfpcs) {
    Result<dfpc::GraphSpec> graph = dfpc::loadGraphFile(e.graph, e.settings);
    if (!graph) {
      notes.push_back(
          fmt::format("the goals of {} are not checked: {}", e.graph, graph.status().message()));
      continue;
    }
    for (const dfpc::DfpcOutputSpec& out : graph->outputs)
      for (const dfpc::GoalSpec& goal : out.goals)
        goals.push_back({graph->name, graph->outputChannel(out), goal});
  }
  return goals;
}

/// A run's verdicts on the goals, as rows like its evaluation's requirement rows: a goal applies
/// to a product whose valid estimates' true range stays in the goal's band; it measures the p95
/// of an error over the run, or its tracked fraction.
json goalRows(const std::vector<ProductGoal>& goals, const json& run) {
  json rows = json::array();
  for (const json& p : evaluationOf(run).value("products", json::array())) {
    if (!p.is_object()) continue;
    for (const ProductGoal& g : goals) {
      if (p.value("channel", "") != g.channel) continue;
      const dfpc::GoalSpec& goal = g.goal;
      const json range = p.value("range_m", json::object());
      const double low = range.value("min", 0.0), high = range.value("max", 0.0);
      const bool matched = p.value("matched_frames", 0) > 0;
      const bool applies = matched && low >= goal.min_range_m && high < goal.max_range_m;
      const json stat = goal.atLeast()
                            ? p.value("tracked_fraction", json())
                            : p.value(goal.quantity, json::object()).value("p95", json());
      json row = {{"id", "goal " + g.dfpc},
                  {"title", fmt::format("{} goal: {} {} {} {} over {}-{} m", g.dfpc,
                                        goal.atLeast() ? "value" : "p95", goal.quantity,
                                        goal.atLeast() ? ">=" : "<", goal.threshold,
                                        goal.min_range_m, goal.max_range_m)},
                  {"channel", g.channel},
                  {"quantity", goal.quantity},
                  {"statistic", goal.atLeast() ? "value" : "p95"},
                  {"comparison", goal.atLeast() ? ">=" : "<"},
                  {"threshold", goal.threshold},
                  {"verdict", "not_applicable"}};
      if (applies && stat.is_number()) {
        const double v = stat.get<double>();
        row["measured"] = v;
        row["verdict"] =
            (goal.atLeast() ? v >= goal.threshold : v < goal.threshold) ? "pass" : "fail";
      }
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

/// A run's verdicts per phase of the seed's Table 1 (a run through several ranges, e.g. the
/// rendezvous: docs/evaluation.md), as requirement rows whose id names the phase
/// ("SR_DFPC_0100 in mid range"): tallied apart from the whole run's. A run within one phase has
/// none (its verdicts are the whole run's).
json phaseRows(const json& run) {
  json rows = json::array();
  const json phases = evaluationOf(run).value("phases", json::array());
  if (!phases.is_array() || phases.size() < 2) return rows;
  for (const json& phase : phases) {
    if (!phase.is_object()) continue;
    const std::string name = phase.value("name", "?");
    for (const json& v : phase.value("verdicts", json::array())) {
      if (!v.is_object()) continue;
      json row = v;
      row["id"] = fmt::format("{} in {}", v.value("id", "?"), name);
      row["title"] = fmt::format("{} ({})", v.value("title", ""), name);
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

/// The scenario entry a run belongs to (its label; results written before labels: its scenario).
std::string labelOf(const json& run) {
  return run.value("label", run.value("scenario", std::string()));
}

/// Per product channel, the distribution over the evaluated runs of each run's p95 errors and
/// tracked fraction; `label` restricts it to one scenario entry's runs ("" for all).
json productsOf(const std::map<std::uint64_t, json>& runs, const std::string& label = {}) {
  std::map<std::string, std::map<std::string, std::vector<double>>> figures;
  for (const auto& [index, run] : runs) {
    if (run.value("status", "") != "ok") continue;
    if (!label.empty() && labelOf(run) != label) continue;
    for (const json& p : evaluationOf(run).value("products", json::array())) {
      if (!p.is_object()) continue;
      auto& f = figures[p.value("channel", "?")];
      for (const char* quantity :
           {"position_error_m", "position_error_pct_range", "angle_error_deg"})
        if (p.contains(quantity) && p[quantity].contains("p95") && p[quantity]["p95"].is_number())
          f[std::string(quantity) + "_p95"].push_back(p[quantity]["p95"]);
      if (p.contains("tracked_fraction") && p["tracked_fraction"].is_number())
        f["tracked_fraction"].push_back(p["tracked_fraction"]);
      // The covariance's honesty (3 if honest) and the largest step from one estimate to the
      // next under the previous one's covariance (a hand-over's jump: docs/evaluation.md).
      const json consistency = p.value("covariance_consistency", json::object());
      if (consistency.is_object() && consistency.value("position_nees_mean", json()).is_number())
        f["position_nees_mean"].push_back(consistency["position_nees_mean"]);
      const json continuity = p.value("continuity", json::object());
      if (continuity.is_object() && continuity.value("max_step_sigma", json()).is_number())
        f["max_step_sigma"].push_back(continuity["max_step_sigma"]);
    }
  }
  json out = json::object();
  for (const auto& [channel, f] : figures)
    for (const auto& [name, values] : f) out[channel][name] = distribution(values);
  return out;
}

/// Per scenario entry: its runs by outcome, those where every applicable requirement passed, those
/// where a DFPC reported faults, and its products' figures: where the campaign's dispersed faults
/// and conditions (glare, occlusion, a failed camera) cost accuracy.
json scenariosOf(const std::map<std::uint64_t, json>& runs, const Campaign& campaign) {
  json out = json::array();
  for (const ScenarioEntry& s : campaign.scenarios) {
    std::uint64_t done = 0, ok = 0, no_product = 0, all_pass = 0, with_faults = 0;
    for (const auto& [index, run] : runs) {
      if (labelOf(run) != s.label) continue;
      ++done;
      const std::string status = run.value("status", "");
      ok += status == "ok";
      no_product += status == "no_product";
      all_pass += status == "ok" && evaluationOf(run).value("all_pass", false);
      bool faults = false;
      for (const json& d : run.value("dfpcs", json::array())) faults |= d.value("faults", 0) > 0;
      with_faults += faults;
    }
    out.push_back({{"label", s.label},
                   {"scenario", s.name},
                   {"runs", done},
                   {"ok", ok},
                   {"no_product", no_product},
                   {"failed", done - ok - no_product},
                   {"all_pass", all_pass},
                   {"with_dfpc_faults", with_faults},
                   {"products", productsOf(runs, s.label)}});
  }
  return out;
}

}  // namespace

std::pair<double, double> clopperPearson(std::uint64_t successes, std::uint64_t trials,
                                         double confidence) {
  const double alpha = 1.0 - confidence;
  const double k = static_cast<double>(successes), n = static_cast<double>(trials);
  const double low =
      successes == 0
          ? 0.0
          : boost::math::quantile(boost::math::beta_distribution<>(k, n - k + 1), alpha / 2);
  const double high =
      successes == trials
          ? 1.0
          : boost::math::quantile(boost::math::beta_distribution<>(k + 1, n - k), 1 - alpha / 2);
  return {low, high};
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  const double rank = p / 100.0 * static_cast<double>(values.size() - 1);
  const std::size_t below = static_cast<std::size_t>(std::floor(rank));
  const std::size_t above = std::min(below + 1, values.size() - 1);
  return values[below] + (rank - below) * (values[above] - values[below]);
}

namespace {

/// `reading` names the result being read while results are read (for an error thrown there).
Result<json> gatherReport(const Campaign& campaign, const fs::path& results, std::string& reading) {
  json notes = json::array();
  const std::vector<ProductGoal> goals = goalsOf(campaign, notes);
  std::map<std::uint64_t, json> runs;
  json failed = json::array();
  std::map<std::string, RequirementTally> tallies;
  for (std::uint64_t i = 0; i < campaign.runs; ++i) {
    const fs::path file = resultFile(results, i);
    if (!fs::exists(file)) continue;
    reading = file.string();
    json r = json::parse(std::ifstream(file), nullptr, false);
    if (r.is_discarded() || !r.is_object())
      return corruptData("'{}' is not a run result (a JSON object)", reading);
    runs[i] = r;
    if (r.value("status", "") == "no_product") continue;  // counted below, once all are read
    if (r.value("status", "") != "ok") {
      failed.push_back({{"index", i},
                        {"stage", r.value("stage", "")},
                        {"error", r.value("error", "")},
                        {"reproduce", r.value("reproduce", "")}});
      continue;
    }
    json rows = evaluationOf(r).value("requirements", json::array());
    for (json& row : phaseRows(r)) rows.push_back(std::move(row));
    for (json& row : goalRows(goals, r)) rows.push_back(std::move(row));
    for (const json& row : rows) {
      const std::string key =
          fmt::format("{}|{}|{}|{}", row.value("id", ""), row.value("channel", ""),
                      row.value("quantity", ""), row.value("title", ""));
      RequirementTally& t = tallies[key];
      if (t.first.is_null()) t.first = row;
      const std::string verdict = row.value("verdict", "");
      if (verdict == "pass")
        ++t.pass;
      else if (verdict == "fail")
        ++t.fail;
      else
        ++t.not_applicable;
      if (verdict == "pass" || verdict == "fail") t.applicable_in.insert(labelOf(r));
      if (row.contains("measured") && row["measured"].is_number()) {
        t.measured.push_back(row["measured"]);
        t.by_run.emplace_back(row["measured"].get<double>(), i);
      }
    }
  }
  reading.clear();  // every result read; what follows reads them again with defaults
  // A run whose DFPCs produced no pose fails every requirement that applied to the runs of its
  // scenario that did produce one (the truth's range is the scenario's): no estimate is a miss.
  json no_product = json::array();
  for (const auto& [i, r] : runs) {
    if (r.value("status", "") != "no_product") continue;
    no_product.push_back({{"index", i}, {"reproduce", r.value("reproduce", "")}});
    for (auto& [key, t] : tallies)
      if (t.applicable_in.count(labelOf(r))) {
        ++t.fail;
        ++t.no_product;
      }
  }
  std::uint64_t ok = 0, without_product = 0;
  for (const auto& [i, r] : runs) {
    ok += r.value("status", "") == "ok";
    without_product += r.value("status", "") == "no_product";
  }
  return json{{"campaign", campaign.name},
              {"source", campaign.source},
              {"runs",
               {{"planned", campaign.runs},
                {"done", runs.size()},
                {"ok", ok},
                {"no_product", without_product},
                {"failed", runs.size() - ok - without_product},
                {"missing", campaign.runs - runs.size()}}},
              {"confidence", 0.95},
              {"requirements", requirementsOf(tallies, runs, 0.95)},
              {"products", productsOf(runs)},
              {"scenarios", scenariosOf(runs, campaign)},
              {"no_product_runs", no_product},
              {"failed_runs", failed},
              {"notes", notes}};
}

}  // namespace

Result<json> campaignReport(const Campaign& campaign, const fs::path& results) {
  // A result is read with defaults where a key is missing; one whose values have other types
  // than a run writes (edited by hand, truncated) is reported with its file, not thrown.
  std::string reading;
  try {
    return gatherReport(campaign, results, reading);
  } catch (const json::exception& e) {
    return corruptData("'{}' is not a run result as `cdff campaign` writes it: {}",
                       reading.empty() ? results.string() : reading, e.what());
  }
}

std::string reportText(const json& report) {
  const json& runs = report["runs"];
  std::string out = fmt::format(
      "campaign {}: {} of {} runs done: {} evaluated, {} without a pose product (counted as "
      "failing the requirements that applied to their scenario), {} failed\n",
      report["campaign"].get<std::string>(), runs["done"].get<int>(), runs["planned"].get<int>(),
      runs["ok"].get<int>(), runs["no_product"].get<int>(), runs["failed"].get<int>());
  for (const json& r : report["requirements"]) {
    const std::uint64_t applicable =
        r["pass"].get<std::uint64_t>() + r["fail"].get<std::uint64_t>();
    if (applicable == 0) continue;
    const json& m = r["measured"];
    // A DFPC's goal says its band and statistic (its title); a requirement is known by its id.
    const bool goal = r["id"].get<std::string>().rfind("goal ", 0) == 0;
    out += fmt::format(
        "  {} {} {} {} {}{}: pass {}/{} = {:.1f} % (95 % CI {:.1f}-{:.1f} %); over runs p50 "
        "{:.4g} p95 {:.4g} max {:.4g}\n",
        r["id"].get<std::string>(), r["channel"].get<std::string>(),
        r["quantity"].get<std::string>(), r["comparison"].get<std::string>(), r["threshold"].dump(),
        goal ? " (" + r["title"].get<std::string>() + ")" : std::string(),
        r["pass"].get<std::uint64_t>(), applicable, 100 * r["pass_fraction"].get<double>(),
        100 * r["pass_interval"][0].get<double>(), 100 * r["pass_interval"][1].get<double>(),
        m.value("p50", NAN), m.value("p95", NAN), m.value("max", NAN));
  }
  // Per product, over the runs: the covariance's honesty and the largest step (continuity).
  const json products = report.value("products", json::object());  // items() needs it alive
  for (const auto& [channel, figures] : products.items()) {
    std::string line;
    for (const char* figure : {"position_nees_mean", "max_step_sigma"}) {
      const json d = figures.value(figure, json::object());
      if (d.value("count", 0) > 0)
        line += fmt::format(" {} p50 {:.3g} max {:.3g};", figure, d.value("p50", NAN),
                            d.value("max", NAN));
    }
    if (!line.empty()) out += fmt::format("  {}:{}\n", channel, line);
  }
  for (const json& sc : report.value("scenarios", json::array()))
    out += fmt::format(
        "  scenario {}: {} runs, {} evaluated ({} meeting every requirement that applied), {} "
        "without a pose, {} failed, {} with DFPC faults\n",
        sc["label"].get<std::string>(), sc["runs"].get<std::uint64_t>(),
        sc["ok"].get<std::uint64_t>(), sc["all_pass"].get<std::uint64_t>(),
        sc["no_product"].get<std::uint64_t>(), sc["failed"].get<std::uint64_t>(),
        sc["with_dfpc_faults"].get<std::uint64_t>());
  for (const json& note : report.value("notes", json::array()))
    out += "  note: " + note.get<std::string>() + "\n";
  for (const json& f : report["failed_runs"])
    out += fmt::format("  run {} failed at {}: {}\n    reproduce: {}\n", f["index"].get<int>(),
                       f["stage"].get<std::string>(), f["error"].get<std::string>(),
                       f["reproduce"].get<std::string>());
  return out;
}

namespace {

std::string requirementRowHtml(const json& r) {
  using eval::escapeHtml;
  const std::uint64_t applicable = r["pass"].get<std::uint64_t>() + r["fail"].get<std::uint64_t>();
  if (applicable == 0)
    return fmt::format(
        "<tr class='not_applicable'><td title='{}'>{}</td><td>{}</td><td>{}</td><td>{} {}</td>"
        "<td colspan='5'>applies to no run</td></tr>\n",
        escapeHtml(r["title"]), escapeHtml(r["id"]), escapeHtml(r["channel"]),
        escapeHtml(r["quantity"]), escapeHtml(r["comparison"]), r["threshold"].dump());
  const json& m = r["measured"];
  return fmt::format(
      "<tr class='{}'><td title='{}'>{}</td><td>{}</td><td>{}</td><td>{} {}</td><td>{}/{}</td>"
      "<td>{:.1f} % [{:.1f}, {:.1f}]</td><td>{:.4g}</td><td>{:.4g}</td><td>{:.4g}</td></tr>\n",
      r["fail"].get<std::uint64_t>() == 0 ? "pass" : "fail", escapeHtml(r["title"]),
      escapeHtml(r["id"]), escapeHtml(r["channel"]), escapeHtml(r["quantity"]),
      escapeHtml(r["comparison"]), r["threshold"].dump(), r["pass"].get<std::uint64_t>(),
      applicable, 100 * r["pass_fraction"].get<double>(), 100 * r["pass_interval"][0].get<double>(),
      100 * r["pass_interval"][1].get<double>(), m.value("p50", NAN), m.value("p95", NAN),
      m.value("max", NAN));
}

/// The measured values over the runs, sorted: the fraction of runs (x, %) at or below a value.
std::string requirementPlot(const json& r) {
  const std::vector<double> values = r.value("measured_values", std::vector<double>{});
  if (values.empty()) return {};
  eval::PlotSeries series;
  for (std::size_t i = 0; i < values.size(); ++i) {
    series.x.push_back(100.0 * static_cast<double>(i + 1) / static_cast<double>(values.size()));
    series.y.push_back(values[i]);
  }
  return eval::svgPlot(
      fmt::format("{} {} ({}), {}", r["id"].get<std::string>(), r["quantity"].get<std::string>(),
                  r["statistic"].get<std::string>(), r["channel"].get<std::string>()),
      "runs with a value at or below it (%)", r["quantity"].get<std::string>(), series,
      r["threshold"].is_number() ? r["threshold"].get<double>() : NAN);
}

/// One row per scenario entry and product channel: the runs by outcome and the distribution over
/// its runs of the p95 position and angle errors.
std::string scenariosHtml(const json& scenarios) {
  using eval::escapeHtml;
  if (scenarios.empty()) return {};
  std::string html =
      "<h2>By scenario</h2><table><tr><th>scenario</th><th>runs</th><th>evaluated</th>"
      "<th>all met</th><th>no pose</th><th>failed</th><th>DFPC faults</th><th>product</th>"
      "<th>p95 position (m): p50 / p95 / max</th><th>p95 angle (deg): p50 / p95 / max</th></tr>\n";
  auto triple = [](const json& d) {
    if (!d.is_object() || d.value("count", 0) == 0) return std::string("-");
    return fmt::format("{:.3g} / {:.3g} / {:.3g}", d.value("p50", NAN), d.value("p95", NAN),
                       d.value("max", NAN));
  };
  for (const json& sc : scenarios) {
    // The entry's counts once, spanning its product rows.
    const std::size_t rows = std::max<std::size_t>(1, sc["products"].size());
    std::string cells;
    for (const char* key : {"runs", "ok", "all_pass", "no_product", "failed", "with_dfpc_faults"})
      cells += fmt::format("<td rowspan='{}'>{}</td>", rows, sc[key].get<std::uint64_t>());
    std::string row =
        fmt::format("<tr><td rowspan='{}'>{}</td>{}", rows, escapeHtml(sc["label"]), cells);
    if (sc["products"].empty()) html += row + "<td colspan='3'>-</td></tr>\n";
    for (const auto& [channel, figures] : sc["products"].items()) {
      html += fmt::format("{}<td>{}</td><td>{}</td><td>{}</td></tr>\n", row, escapeHtml(channel),
                          triple(figures.value("position_error_m_p95", json())),
                          triple(figures.value("angle_error_deg_p95", json())));
      row = "<tr>";
    }
  }
  return html + "</table>\n";
}

std::string runListHtml(const json& runs, const char* title) {
  if (runs.empty()) return {};
  std::string html = fmt::format(
      "<h2>{}</h2><table><tr><th>run</th><th>why</th>"
      "<th>reproduce</th></tr>\n",
      title);
  for (const json& f : runs)
    html +=
        fmt::format("<tr><td>{}</td><td>{}</td><td><code>{}</code></td></tr>\n",
                    f["index"].get<std::uint64_t>(),
                    eval::escapeHtml(f.contains("stage") ? f["stage"].get<std::string>() + ": " +
                                                               f.value("error", std::string())
                                                         : std::string("no pose product")),
                    eval::escapeHtml(f.value("reproduce", std::string())));
  return html + "</table>\n";
}

}  // namespace

std::string reportHtml(const json& report) {
  using eval::escapeHtml;
  const json& runs = report["runs"];
  std::string html = std::string(
                         "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
                         "<title>CDFF campaign ") +
                     escapeHtml(report["campaign"]) + "</title><style>\n" + eval::kPageCss +
                     "</style></head><body>\n";
  html += fmt::format(
      "<h1>Campaign {}</h1><p>From <code>{}</code>: {} of {} runs done: {} evaluated, {} without "
      "a pose product (counted as failing the requirements that applied to their scenario), {} "
      "failed. Pass fractions with their exact 95 % (Clopper-Pearson) intervals; the measured "
      "statistic's distribution over the runs.</p>\n",
      escapeHtml(report["campaign"]), escapeHtml(report["source"]), runs["done"].get<int>(),
      runs["planned"].get<int>(), runs["ok"].get<int>(), runs["no_product"].get<int>(),
      runs["failed"].get<int>());
  html +=
      "<table><tr><th>requirement</th><th>channel</th><th>quantity</th><th>bound</th>"
      "<th>pass</th><th>fraction [95 % CI]</th><th>p50</th><th>p95</th><th>max</th></tr>\n";
  for (const json& r : report["requirements"]) html += requirementRowHtml(r);
  html += "</table>\n";
  for (const json& note : report.value("notes", json::array()))
    html += "<p class='note'>" + escapeHtml(note.get<std::string>()) + "</p>\n";
  html += scenariosHtml(report.value("scenarios", json::array()));
  for (const json& r : report["requirements"]) html += requirementPlot(r);
  html += runListHtml(report["no_product_runs"], "Runs without a pose product");
  html += runListHtml(report["failed_runs"], "Failed runs");
  return html + "</body></html>\n";
}

}  // namespace cdff::campaign
