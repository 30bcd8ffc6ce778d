// The campaign file (campaign.hpp): its reader, the plan of one run, and the checks made before
// any run starts.

#include "cdff/campaign/campaign.hpp"

#include <filesystem>
#include <fstream>
#include <iterator>

#include <fmt/format.h>

#include "cdff/dfpc/graph.hpp"
#include "cdff/dfpc/orchestrator.hpp"
#include "cdff/dfpc/replay.hpp"
#include "cdff/dfpc/run_set.hpp"
#include "cdff/dfpc/stereo_pairing.hpp"
#include "cdff/egse/rng.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/eval/draws.hpp"
#include "cdff/schema/field.hpp"
#include "cdff/schema/table.hpp"

namespace cdff::campaign {
namespace {

using schema::Field;
using schema::Table;

/// "key=value" overrides from a map of scenario keys (`set: {sensors.tof.enabled: false}`).
Status readOverrides(const Field& f, std::vector<std::string>& out) {
  if (!f.isMap()) return f.fail("a map of scenario keys to values ({sensors.tof.enabled: false})");
  for (const Field::Entry& e : f.entries()) {
    if (!e.value.defined() || e.value.isMap())
      return e.value.fail("a value (a number, a word, true/false or a list)");
    out.push_back(e.key + "=" + e.value.text());
  }
  return Status::ok();
}

Status readDispersions(const Field& f, std::vector<Dispersion>& out);

const Table<ScenarioEntry>& scenarioTable() {
  static const Table<ScenarioEntry> table =
      Table<ScenarioEntry>("a scenario entry")
          .required("name", schema::text(&ScenarioEntry::name),
                    "a library scenario name or a YAML file")
          .optional("label", schema::text(&ScenarioEntry::label))
          .optional("duration",
                    [](const Field& f, ScenarioEntry& s) {
                      double d = 0;
                      CDFF_RETURN_IF_ERROR(f.read(d, schema::Range::above(0, "s")));
                      s.duration = d;
                      return Status::ok();
                    })
          .optional("set", [](const Field& f, ScenarioEntry& s) { return readOverrides(f, s.set); })
          .optional("dispersions", [](const Field& f, ScenarioEntry& s) {
            return readDispersions(f, s.dispersions);
          });
  return table;
}

Status readDistribution(const Field& f, Dispersion& d) {
  const bool uniform = f.has("uniform"), normal = f.has("normal"), choice = f.has("choice");
  if (uniform + normal + choice != 1)
    return f.fail("exactly one of uniform: [low, high], normal: [mean, sigma], choice: [...]",
                  uniform + normal + choice == 0 ? "no distribution" : "several distributions");
  std::vector<double> v;
  if (uniform) {
    d.kind = DistributionKind::kUniform;
    CDFF_RETURN_IF_ERROR(f["uniform"].numbers(v, 2, 2));
    if (!(v[0] <= v[1])) return f["uniform"].fail("[low, high] with low <= high");
    d.low = v[0];
    d.high = v[1];
  } else if (normal) {
    d.kind = DistributionKind::kNormal;
    CDFF_RETURN_IF_ERROR(f["normal"].numbers(v, 2, 2));
    if (!(v[1] >= 0)) return f["normal"].fail("[mean, sigma] with sigma >= 0");
    d.mean = v[0];
    d.sigma = v[1];
  } else {
    d.kind = DistributionKind::kChoice;
    const Field c = f["choice"];
    if (!c.isList() || c.size() == 0) return c.fail("a non-empty list of values");
    for (const Field& e : c.elements()) {
      if (!e.isScalar() && !e.isList()) return e.fail("a value (a number, a word or a list)");
      d.values.push_back(e.text());
    }
  }
  return Status::ok();
}

const Table<Dispersion>& dispersionTable() {
  static const Table<Dispersion> table =
      Table<Dispersion>("a dispersion")
          .required("key", schema::text(&Dispersion::key), "a scenario key, dotted")
          .optional("uniform", [](const Field&, Dispersion&) { return Status::ok(); })
          .optional("normal", [](const Field&, Dispersion&) { return Status::ok(); })
          .optional("choice", [](const Field&, Dispersion&) { return Status::ok(); });
  return table;
}

const Table<InitialStateEntry>& initialStateTable() {
  static const Table<InitialStateEntry> table =
      Table<InitialStateEntry>("an initial state")
          .required("channel", schema::text(&InitialStateEntry::channel),
                    "the channel of the tracker's initial state")
          .optional("at", schema::text(&InitialStateEntry::at))
          .optional("truth", schema::text(&InitialStateEntry::truth))
          .optional("velocity_sigma", schema::number(&InitialStateEntry::velocity_sigma,
                                                     schema::Range::closed(0, 100, "m/s")))
          .optional("angular_velocity_sigma_deg",
                    schema::number(&InitialStateEntry::angular_velocity_sigma_deg,
                                   schema::Range::closed(0, 1000, "deg/s")))
          .optional("position_fraction", schema::number(&InitialStateEntry::position_fraction,
                                                        schema::Range::closed(0, 10)))
          .optional("angle_deg", schema::number(&InitialStateEntry::angle_deg,
                                                schema::Range::closed(0, 180, "deg")))
          .optional("distribution", [](const Field& f, InitialStateEntry& e) {
            std::string d;
            CDFF_RETURN_IF_ERROR(f.choice(d, {"gaussian", "fixed"}));
            e.fixed_size = d == "fixed";
            return Status::ok();
          });
  return table;
}

/// A word or a list of words, each checked by the parser `cdff run` uses for the same option, so
/// that a malformed one is reported at its place in the campaign file.
template <typename Parse>
Status checkedWords(const Field& f, std::vector<std::string>& out, std::string_view expected,
                    Parse parse) {
  CDFF_RETURN_IF_ERROR(f.words(out, expected));
  for (const std::string& word : out)
    if (auto parsed = parse(word); !parsed)
      return Status(StatusCode::kInvalidParameter, parsed.status().message(), f.location());
  return Status::ok();
}

const Table<DfpcEntry>& dfpcTable() {
  static const Table<DfpcEntry> table =
      Table<DfpcEntry>("a DFPC entry")
          .required("graph", schema::text(&DfpcEntry::graph), "a DFPC graph file")
          .optional("set",
                    [](const Field& f, DfpcEntry& e) {
                      return f.words(e.settings, "settings NODE.PARAM=VALUE");
                    })
          .optional("map",
                    [](const Field& f, DfpcEntry& e) {
                      return checkedWords(f, e.maps, "input maps DFPC.INPUT=/channel",
                                          dfpc::parseRemap);
                    })
          .optional("pair",
                    [](const Field& f, DfpcEntry& e) {
                      return checkedWords(f, e.pairs, "stereo pairs /PAIR=/LEFT,/RIGHT",
                                          dfpc::parseStereoPairing);
                    })
          .optional("run_while",
                    [](const Field& f, DfpcEntry& e) {
                      return checkedWords(f, e.run_while, "rules DFPC=TRACKER:STATE[,STATE...]",
                                          dfpc::parseActivationRule);
                    })
          .optional("initial_state", [](const Field& f, DfpcEntry& e) {
            InitialStateEntry entry;
            CDFF_RETURN_IF_ERROR(initialStateTable().read(f, entry));
            e.initial_state = entry;
            return Status::ok();
          });
  return table;
}

Status readDispersions(const Field& f, std::vector<Dispersion>& out) {
  if (!f.isList()) return f.fail("a list of dispersions ({key: ..., uniform: [low, high]})");
  for (const Field& e : f.elements()) {
    Dispersion d;
    CDFF_RETURN_IF_ERROR(dispersionTable().read(e, d));
    CDFF_RETURN_IF_ERROR(readDistribution(e, d));
    d.where = e.location();
    for (const Dispersion& other : out)
      if (other.key == d.key)
        return e["key"].fail("a key not dispersed twice", "already dispersed above");
    out.push_back(std::move(d));
  }
  return Status::ok();
}

/// Each scenario entry has a label of its own (the report's rows); a scenario's own dispersions
/// may not repeat the campaign's (one key, one distribution).
Status checkScenarioEntries(Campaign& c, const schema::Field& list) {
  for (std::size_t i = 0; i < c.scenarios.size(); ++i) {
    ScenarioEntry& s = c.scenarios[i];
    if (s.label.empty()) s.label = s.name;
    for (std::size_t j = 0; j < i; ++j)
      if (c.scenarios[j].label == s.label)
        return list[i].fail(
            "a label of its own for each scenario entry",
            fmt::format("entries {} and {} are both '{}' (add label: ...)", j, i, s.label));
  }
  for (const ScenarioEntry& s : c.scenarios)
    for (const Dispersion& d : s.dispersions)
      for (const Dispersion& other : c.dispersions)
        if (other.key == d.key)
          return Status(StatusCode::kInvalidParameter,
                        fmt::format("dispersions: '{}' is dispersed for every scenario already "
                                    "(line {}); expected a key not dispersed twice",
                                    d.key, other.where.line),
                        d.where);
  return Status::ok();
}

const Table<Campaign>& campaignTable() {
  static const Table<Campaign> table =
      Table<Campaign>("a campaign")
          .required("name", schema::text(&Campaign::name), "the campaign's name")
          .optional("doc", schema::text(&Campaign::doc))
          .required(
              "runs",
              [](const Field& f, Campaign& c) {
                std::int64_t n = 0;
                CDFF_RETURN_IF_ERROR(f.read(n, 1, 1'000'000));
                c.runs = static_cast<std::uint64_t>(n);
                return Status::ok();
              },
              "the number of runs (1 to 1000000)")
          .optional("first_draw",
                    [](const Field& f, Campaign& c) {
                      std::int64_t n = 0;
                      CDFF_RETURN_IF_ERROR(f.read(n, 1, std::int64_t{1} << 62));
                      c.first_draw = static_cast<std::uint64_t>(n);
                      return Status::ok();
                    })
          .optional("keep", schema::named(&Campaign::keep,
                                          {{"evaluation", Keep::kEvaluation}, {"all", Keep::kAll}}))
          .required("scenarios",
                    schema::listOf(&Campaign::scenarios, scenarioTable(), "scenario entries"),
                    "a list of scenario entries ({name: mid_range_approach})")
          .optional("dispersions",
                    [](const Field& f, Campaign& c) { return readDispersions(f, c.dispersions); })
          .required("dfpcs", schema::listOf(&Campaign::dfpcs, dfpcTable(), "DFPC entries"),
                    "a list of DFPC entries ({graph: dfpcs/lidar_tracking.yaml})");
  return table;
}

/// Draws are numbered as in data/evaluation/draws.yaml: a campaign starts after the tuning draws
/// (1..10000) by default, so that no figure it gives was tuned on.
constexpr std::uint64_t kDefaultFirstDraw = 1'000'001;

std::string drawValue(const Dispersion& d, std::uint64_t draw) {
  egse::Rng rng = egse::Rng::stream(draw, "campaign.dispersion." + d.key);
  switch (d.kind) {
    case DistributionKind::kUniform:
      return fmt::format("{}", rng.uniform(d.low, d.high));
    case DistributionKind::kNormal:
      return fmt::format("{}", rng.normal(d.mean, d.sigma));
    case DistributionKind::kChoice:
      return d.values[rng.below(d.values.size())];
  }
  return {};
}

}  // namespace

std::string shellQuoted(const std::string& word) {
  if (!word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789-_./=:,+@%") == std::string::npos)
    return word;
  std::string out = "'";
  for (char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::uint64_t Campaign::identity() const {
  return egse::hashName(text);
}

Result<Campaign> parseCampaign(const std::string& text, const std::string& source) {
  Result<schema::Document> doc = schema::Document::parse(text, source);
  if (!doc) return doc.status();
  Campaign c;
  c.first_draw = kDefaultFirstDraw;
  CDFF_RETURN_IF_ERROR(campaignTable().read(doc->root(), c));
  if (c.scenarios.empty())
    return doc->root()["scenarios"].fail("at least one scenario entry", "an empty list");
  if (c.dfpcs.empty()) return doc->root()["dfpcs"].fail("at least one DFPC entry", "an empty list");
  CDFF_RETURN_IF_ERROR(checkScenarioEntries(c, doc->root()["scenarios"]));
  c.source = source;
  c.text = text;
  return c;
}

Result<Campaign> loadCampaign(const std::string& path) {
  std::ifstream in(path);
  // The schema reader says why a file cannot be read, in the one error format.
  if (!in) return schema::Document::loadFile(path, "campaign").status();
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parseCampaign(text, path);
}

RunPlan planRun(const Campaign& campaign, std::uint64_t index) {
  RunPlan plan;
  plan.index = index;
  plan.draw = campaign.first_draw + index;
  plan.scenario = &campaign.scenarios[index % campaign.scenarios.size()];
  plan.overrides = plan.scenario->set;
  for (const std::vector<Dispersion>* list : {&campaign.dispersions, &plan.scenario->dispersions})
    for (const Dispersion& d : *list) {
      std::string value = drawValue(d, plan.draw);
      plan.overrides.push_back(d.key + "=" + value);
      plan.dispersed.emplace_back(d.key, std::move(value));
    }
  return plan;
}

Status checkCampaign(const Campaign& campaign) {
  for (const ScenarioEntry& s : campaign.scenarios) {
    Result<std::filesystem::path> path = egse::resolveScenario(s.name);
    if (!path) return path.status();
    if (Result<egse::Scenario> sc = egse::loadScenario(*path, s.set); !sc) return sc.status();
    std::vector<Dispersion> dispersions = campaign.dispersions;
    dispersions.insert(dispersions.end(), s.dispersions.begin(), s.dispersions.end());
    for (const Dispersion& d : dispersions) {
      std::vector<std::string> extremes;
      if (d.kind == DistributionKind::kUniform)
        extremes = {fmt::format("{}", d.low), fmt::format("{}", d.high)};
      if (d.kind == DistributionKind::kNormal)
        extremes = {fmt::format("{}", d.mean - 3 * d.sigma),
                    fmt::format("{}", d.mean + 3 * d.sigma)};
      if (d.kind == DistributionKind::kChoice) extremes = d.values;
      for (const std::string& v : extremes) {
        std::vector<std::string> overrides = s.set;
        overrides.push_back(d.key + "=" + v);
        Result<egse::Scenario> sc = egse::loadScenario(*path, overrides);
        if (!sc)
          return Status(StatusCode::kInvalidParameter,
                        fmt::format("dispersion '{}' of scenario '{}' at {}: {}", d.key, s.name, v,
                                    sc.status().message()),
                        d.where);
      }
    }
  }
  for (const DfpcEntry& e : campaign.dfpcs) {
    if (dfpc::isRunSetFile(e.graph)) {  // its graphs, settings, maps and rules, as a run loads them
      dfpc::ReplayOptions options;
      options.graph_files = {e.graph};
      options.parameter_settings = e.settings;
      CDFF_RETURN_IF_ERROR(dfpc::checkRun(options).withContext(e.graph));
      continue;
    }
    Result<dfpc::GraphSpec> graph = dfpc::loadGraphFile(e.graph, e.settings);
    if (!graph) return graph.status();
    for (const Status& problem : dfpc::checkGraph(*graph))
      if (!problem.isOk()) return problem;
  }
  return Status::ok();
}

std::string reproduceCommand(const Campaign& campaign, const RunPlan& plan) {
  std::string sim =
      fmt::format("cdff sim {} -o sim.mcap --seed {}", shellQuoted(plan.scenario->name), plan.draw);
  if (plan.scenario->duration) sim += fmt::format(" --duration {}", *plan.scenario->duration);
  for (const std::string& o : plan.overrides) sim += " --set " + shellQuoted(o);
  std::string init, inputs = " -i sim.mcap";
  for (std::size_t k = 0; k < campaign.dfpcs.size(); ++k) {
    const std::optional<InitialStateEntry>& i = campaign.dfpcs[k].initial_state;
    if (!i) continue;
    init += fmt::format(
        " && cdff initial-state sim.mcap -o init{}.mcap --channel {} --at {} "
        "--truth {} --position-fraction {} --angle-deg {} --velocity-sigma {} "
        "--angular-velocity-sigma-deg {} --distribution {} --seed {}",
        k, shellQuoted(i->channel), shellQuoted(i->at), shellQuoted(i->truth), i->position_fraction,
        i->angle_deg, i->velocity_sigma, i->angular_velocity_sigma_deg,
        i->fixed_size ? "fixed" : "gaussian", eval::drawOf(plan.draw).initial_error_seed);
    inputs += fmt::format(" -i init{}.mcap", k);
  }
  std::string run = "cdff run";
  for (const DfpcEntry& e : campaign.dfpcs) {
    run += " " + shellQuoted(e.graph);
    for (const std::string& s : e.settings) run += " --set " + shellQuoted(s);
    for (const std::string& m : e.maps) run += " --map " + shellQuoted(m);
    for (const std::string& p : e.pairs) run += " --pair " + shellQuoted(p);
    for (const std::string& w : e.run_while) run += " --run-while " + shellQuoted(w);
  }
  run += inputs + " -o out.mcap";
  return sim + init + " && " + run + " && cdff eval out.mcap";
}

}  // namespace cdff::campaign
