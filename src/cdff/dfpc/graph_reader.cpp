// The YAML front end of DFPC graphs (graph.hpp: loadGraphFile, parseGraph), with the schema
// reader's declarative tables. The first error stops the parse (later ones often follow from it).
#include <filesystem>

#include <fmt/format.h>

#include "cdff/dfpc/graph.hpp"
#include "cdff/schema/table.hpp"

namespace cdff::dfpc {

namespace {

using schema::Field;
using schema::Table;

Status name(const Field& f, std::string& out, std::string_view what) {
  CDFF_RETURN_IF_ERROR(f.read(out));
  if (!isIdentifier(out)) return f.fail(fmt::format("{} of letters, digits and _", what));
  return Status::ok();
}

Status portRef(const Field& f, const std::string& text, PortRef& out) {
  const PortRef r = PortRef::parse(text);
  const bool ok = !text.empty() && std::count(text.begin(), text.end(), '.') <= 1 &&
                  (r.instance.empty() || isIdentifier(r.instance)) && isIdentifier(r.port);
  if (!ok)
    return f.fail("a connection 'from -> to': instance.port, or a DFPC input or output name",
                  fmt::format("'{}' is not a port", text));
  out = r;
  return Status::ok();
}

// ---- recoveries

const std::vector<std::pair<std::string, RecoveryActionKind>> kActions = {
    {"reinitialise", RecoveryActionKind::kReinitialise},
    {"wake", RecoveryActionKind::kWake},
    {"switch_dfi", RecoveryActionKind::kSwitchDfi},
    {"set_track_state", RecoveryActionKind::kSetTrackState}};

Status kindOf(const Field& f, const std::string& word, RecoveryActionKind& out) {
  for (const auto& [w, kind] : kActions)
    if (w == word) {
      out = kind;
      return Status::ok();
    }
  return f.fail(
      "a recovery: one of {reinitialise, wake, switch_dfi, set_track_state}" +
      schema::didYouMean(word, {"reinitialise", "wake", "switch_dfi", "set_track_state"}));
}

Status action(const Field& f, RecoveryAction& a) {
  a.at = f.location();
  if (f.isScalar()) return kindOf(f, f.node().Scalar(), a.kind);
  const std::vector<Field::Entry> entries = f.entries();
  if (!f.isMap() || entries.size() != 1)
    return f.fail(
        "a recovery: a name (reinitialise, switch_dfi) or a one-key map such as {wake: detector}");
  CDFF_RETURN_IF_ERROR(kindOf(entries[0].key_field, entries[0].key, a.kind));
  const Field& argument = entries[0].value;
  if (!argument.isScalar() || argument.node().Scalar().empty())
    return argument.fail(a.kind == RecoveryActionKind::kSetTrackState ? "a track state"
                                                                      : "an instance name");
  a.argument = argument.node().Scalar();
  return Status::ok();
}

Status actions(const Field& f, std::vector<RecoveryAction>& out) {
  if (f.isScalar() || f.isMap()) {
    RecoveryAction a;
    CDFF_RETURN_IF_ERROR(action(f, a));
    out.push_back(std::move(a));
    return Status::ok();
  }
  if (!f.isList() || f.size() == 0) return f.fail("a non-empty list of recovery actions");
  for (const Field& element : f.elements()) {
    RecoveryAction a;
    CDFF_RETURN_IF_ERROR(action(element, a));
    out.push_back(std::move(a));
  }
  return Status::ok();
}

Status recovery(const Field& f, RecoverySpec& r) {
  static const Table<RecoverySpec> table =
      Table<RecoverySpec>("a recovery")
          .optional("after", schema::integer(&RecoverySpec::after, 1))
          .optional("within_s",
                    schema::number(&RecoverySpec::within_s, schema::Range::above(0, "s")))
          .required(
              "do", [](const Field& g, RecoverySpec& s) { return actions(g, s.actions); },
              "the list of actions");
  r.at = f.location();
  if (f.isMap() && (f.has("do") || f.has("after") || f.has("within_s"))) return table.read(f, r);
  return actions(f, r.actions);
}

// ---- inputs, outputs, track state

const Table<DfpcInputSpec>& inputTable() {
  static const Table<DfpcInputSpec> table =
      Table<DfpcInputSpec>("a DFPC input")
          .required(
              "name",
              [](const Field& f, DfpcInputSpec& in) {
                in.at = f.location();
                return name(f, in.name, "a name");
              },
              "the input's name")
          .required("type", schema::text(&DfpcInputSpec::type), "a data type name")
          .required("channel", schema::text(&DfpcInputSpec::channel), "the channel that feeds it")
          .optional("optional", schema::flag(&DfpcInputSpec::optional))
          .optional("latched", schema::flag(&DfpcInputSpec::latched));
  return table;
}

/// A goal: {quantity: angle_error_deg, below: 1.0, range_m: [5, 1000]}, or {quantity:
/// tracked_fraction, at_least: 0.99}.
Status readGoal(const Field& f, GoalSpec& goal) {
  static const Table<GoalSpec> table =
      Table<GoalSpec>("a goal {quantity, below or at_least, range_m}")
          .required(
              "quantity",
              [](const Field& q, GoalSpec& g) {
                return q.choice(g.quantity, {"position_error_m", "position_error_pct_range",
                                             "angle_error_deg", "tracked_fraction"});
              },
              "the quantity it bounds")
          .optional("below", schema::number(&GoalSpec::threshold, schema::Range::above(0)))
          .optional("at_least", schema::number(&GoalSpec::threshold, schema::Range::closed(0, 1)))
          .optional("range_m", [](const Field& r, GoalSpec& g) {
            std::vector<double> band;
            CDFF_RETURN_IF_ERROR(r.numbers(band, 2, 2, schema::Range::atLeast(0, "m")));
            if (!(band[0] < band[1])) return r.fail("[min, max] with min < max");
            g.min_range_m = band[0];
            g.max_range_m = band[1];
            return Status::ok();
          });
  goal.at = f.location();
  CDFF_RETURN_IF_ERROR(table.read(f, goal));
  const char* bound = goal.atLeast() ? "at_least" : "below";
  if (!f.has(bound) || f.has(goal.atLeast() ? "below" : "at_least"))
    return f.fail(fmt::format("'{}' for {} (the only bound it takes)", bound, goal.quantity));
  return Status::ok();
}

const Table<DfpcOutputSpec>& outputTable() {
  static const Table<DfpcOutputSpec> table =
      Table<DfpcOutputSpec>("a DFPC output")
          .required(
              "name",
              [](const Field& f, DfpcOutputSpec& out) {
                out.at = f.location();
                return name(f, out.name, "a name");
              },
              "the output's name")
          .required("type", schema::text(&DfpcOutputSpec::type), "a data type name")
          .optional("channel", schema::text(&DfpcOutputSpec::channel))
          .optional("role", schema::text(&DfpcOutputSpec::role))
          .optional("history",
                    [](const Field& f, DfpcOutputSpec& out) -> Status {
                      int history = 0;
                      CDFF_RETURN_IF_ERROR(f.read(history, 1));
                      out.history = static_cast<std::size_t>(history);
                      return Status::ok();
                    })
          .optional("timeout_s",
                    schema::number(&DfpcOutputSpec::timeout_s, schema::Range::atLeast(0, "s")))
          .optional("on_timeout",
                    [](const Field& f, DfpcOutputSpec& out) -> Status {
                      CDFF_RETURN_IF_ERROR(recovery(f, out.on_timeout));
                      if (out.timeout_s <= 0)
                        return f.fail("a timeout_s > 0 with on_timeout", "no timeout");
                      return Status::ok();
                    })
          .optional("goals", [](const Field& f, DfpcOutputSpec& out) -> Status {
            if (!f.isList()) return f.fail("a list of goals ({quantity: ..., below: ...})");
            for (const Field& e : f.elements()) {
              GoalSpec goal;
              CDFF_RETURN_IF_ERROR(readGoal(e, goal));
              out.goals.push_back(std::move(goal));
            }
            return Status::ok();
          });
  return table;
}

const Table<TrackStateSpec>& trackStateTable() {
  static const Table<TrackStateSpec> table =
      Table<TrackStateSpec>("the track state")
          .optional("from",
                    [](const Field& f, TrackStateSpec& t) -> Status {
                      std::string text;
                      CDFF_RETURN_IF_ERROR(f.read(text));
                      if (!text.empty()) t.from = PortRef::parse(text);
                      return Status::ok();
                    })
          .optional("initial", [](const Field& f, TrackStateSpec& t) -> Status {
            std::vector<std::string> names;
            for (TrackState s : allTrackStates()) names.emplace_back(toString(s));
            std::string word;
            CDFF_RETURN_IF_ERROR(f.choice(word, names));
            t.initial = *parseTrackState(word);
            return Status::ok();
          });
  return table;
}

// ---- instances

/// Inline parameters, or a parameter file relative to the graph file.
Status parameters(const Field& f, YAML::Node& out, std::string& source) {
  source = f.source();
  if (f.isMap()) {
    out = f.node();
    return Status::ok();
  }
  if (!f.isScalar()) return f.fail("a map of parameters or a parameter file name");
  std::filesystem::path path(f.node().Scalar());
  if (path.is_relative() && !source.empty())
    path = std::filesystem::path(source).parent_path() / path;
  Result<schema::Document> file = schema::Document::loadFile(path.string(), "parameter file");
  if (!file) {
    if (file.status().code() == StatusCode::kNotFound)
      return f.fail("a readable YAML parameter file (relative to the graph file)",
                    fmt::format("cannot open '{}'", path.string()));
    return file.status();
  }
  out = file->root().node();
  source = path.string();
  return Status::ok();
}

Status trigger(const Field& f, InstanceSpec& s) {
  static const Table<InstanceSpec> table =
      Table<InstanceSpec>("a trigger")
          .optional("on",
                    [](const Field& g, InstanceSpec& i) {
                      i.trigger.on_given = true;
                      i.where["on"] = g.location();
                      return g.words(i.trigger.on, "a port name or a list of port names");
                    })
          .optional("period_s",
                    [](const Field& g, InstanceSpec& i) {
                      return g.read(i.trigger.period_s, schema::Range::atLeast(0, "s"));
                    })
          .optional("time_input",
                    [](const Field& g, InstanceSpec& i) {
                      i.where["time_input"] = g.location();
                      return g.read(i.trigger.time_input);
                    })
          .optional("tick_when",
                    [](const Field& g, InstanceSpec& i) {
                      i.where["tick_when"] = g.location();
                      return g.read(i.trigger.tick_when);
                    })
          .optional("sync",
                    [](const Field& g, InstanceSpec& i) -> Status {
                      i.where["sync"] = g.location();
                      std::string policy;
                      CDFF_RETURN_IF_ERROR(g.choice(policy, {"exact", "nearest", "none"}));
                      i.trigger.sync = policy == "exact"     ? SyncPolicy::kExact
                                       : policy == "nearest" ? SyncPolicy::kNearest
                                                             : SyncPolicy::kNone;
                      return Status::ok();
                    })
          .optional("tolerance_s",
                    [](const Field& g, InstanceSpec& i) {
                      i.where["tolerance_s"] = g.location();
                      return g.read(i.trigger.tolerance_s, schema::Range::atLeast(0, "s"));
                    })
          .optional("queue",
                    [](const Field& g, InstanceSpec& i) { return g.read(i.trigger.queue, 1); });
  CDFF_RETURN_IF_ERROR(table.read(f, s));
  const TriggerSpec& t = s.trigger;
  if ((f.has("tolerance_s") || f.has("queue")) && t.sync == SyncPolicy::kNone)
    return f.fail("sync: exact or sync: nearest with tolerance_s or queue",
                  "tolerance_s and queue apply to synchronised triggers");
  if (f.has("tolerance_s") && t.sync == SyncPolicy::kExact)
    return f["tolerance_s"].fail("no tolerance_s with sync: exact (it matches equal stamps only)");
  return Status::ok();
}

Status fallback(const Field& f, InstanceSpec& s) {
  static const Table<FallbackSpec> table =
      Table<FallbackSpec>("a fallback")
          .required("dfi", schema::text(&FallbackSpec::dfi), "the fallback's DFI name")
          .optional("parameters", [](const Field& g, FallbackSpec& fb) {
            return parameters(g, fb.parameters, fb.parameters_source);
          });
  FallbackSpec fb;
  fb.at = f.location();
  fb.parameters_source = f.source();
  CDFF_RETURN_IF_ERROR(table.read(f, fb));
  s.fallback = std::move(fb);
  return Status::ok();
}

Status onFault(const Field& f, InstanceSpec& s) {
  static const Table<InstanceSpec> table =
      Table<InstanceSpec>("the recoveries per fault")
          .optional("error",
                    [](const Field& g, InstanceSpec& i) {
                      return recovery(g, i.on_fault[FaultKind::kError]);
                    })
          .optional("over_budget",
                    [](const Field& g, InstanceSpec& i) {
                      return recovery(g, i.on_fault[FaultKind::kOverBudget]);
                    })
          .optional("divergence", [](const Field& g, InstanceSpec& i) {
            return recovery(g, i.on_fault[FaultKind::kDivergence]);
          });
  return table.read(f, s);
}

const Table<InstanceSpec>& instanceTable() {
  static const Table<InstanceSpec> table =
      Table<InstanceSpec>("a DFN instance")
          .required("dfn", schema::text(&InstanceSpec::dfn), "a DFN name")
          .required("dfi", schema::text(&InstanceSpec::dfi), "a DFI name")
          .optional("parameters",
                    [](const Field& f, InstanceSpec& s) {
                      return parameters(f, s.parameters, s.parameters_source);
                    })
          .optional("trigger", trigger)
          .optional("active_when", schema::text(&InstanceSpec::active_when))
          .optional("diverged_when", schema::text(&InstanceSpec::diverged_when))
          .optional("budget_s",
                    schema::number(&InstanceSpec::budget_s, schema::Range::atLeast(0, "s")))
          .optional("fallback", fallback)
          .optional("on_fault", onFault);
  return table;
}

Result<InstanceSpec> instance(const Field::Entry& entry) {
  InstanceSpec s;
  s.name = entry.key;
  s.where[""] = entry.key_field.location();
  s.parameters_source = entry.value.source();
  if (!isIdentifier(s.name))
    return entry.key_field.fail("an instance name of letters, digits and _");
  for (const Field::Entry& e : entry.value.entries()) s.where[e.key] = e.value.location();
  CDFF_RETURN_IF_ERROR(instanceTable().read(entry.value, s));
  return s;
}

Result<ConnectionSpec> connection(const Field& f) {
  static const Table<ConnectionSpec> table =
      Table<ConnectionSpec>("a connection {from, to, delay}")
          .required(
              "from",
              [](const Field& g, ConnectionSpec& c) -> Status {
                std::string text;
                CDFF_RETURN_IF_ERROR(g.read(text));
                return portRef(g, text, c.from);
              },
              "instance.port or a DFPC input")
          .required(
              "to",
              [](const Field& g, ConnectionSpec& c) -> Status {
                std::string text;
                CDFF_RETURN_IF_ERROR(g.read(text));
                return portRef(g, text, c.to);
              },
              "instance.port or a DFPC output")
          .optional("delay", schema::integer(&ConnectionSpec::delay, 0, 1));
  ConnectionSpec c;
  c.at = f.location();
  if (f.isMap()) {
    CDFF_RETURN_IF_ERROR(table.read(f, c));
    return c;
  }
  if (!f.isScalar()) return f.fail("a connection 'from -> to' or {from, to, delay}");
  const std::string text = f.node().Scalar();
  const std::size_t arrow = text.find("->");
  if (arrow == std::string::npos || text.find("->", arrow + 2) != std::string::npos)
    return f.fail(
        "'from -> to' (instance.port -> instance.port; a bare name is a DFPC input or "
        "output)");
  auto trim = [](std::string s) {
    const auto b = s.find_first_not_of(" \t");
    const auto e = s.find_last_not_of(" \t");
    return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
  };
  CDFF_RETURN_IF_ERROR(portRef(f, trim(text.substr(0, arrow)), c.from));
  CDFF_RETURN_IF_ERROR(portRef(f, trim(text.substr(arrow + 2)), c.to));
  return c;
}

// ---- the file

template <typename Item, typename Read>
Status listOf(const Field& f, std::vector<Item>& out, std::string_view what, Read&& read) {
  if (!f.isList()) return f.fail(fmt::format("a list of {}", what));
  for (const Field& element : f.elements()) {
    Result<Item> item = read(element);
    if (!item) return item.status();
    out.push_back(std::move(item).value());
  }
  return Status::ok();
}

const Table<GraphSpec>& graphTable() {
  static const Table<GraphSpec> table =
      Table<GraphSpec>("a DFPC graph")
          .required(
              "name", [](const Field& f, GraphSpec& g) { return name(f, g.name, "a DFPC name"); },
              "the DFPC's name")
          .optional("doc", schema::text(&GraphSpec::doc))
          .optional("inputs",
                    [](const Field& f, GraphSpec& g) {
                      return listOf(f, g.inputs, "DFPC inputs",
                                    [](const Field& e) -> Result<DfpcInputSpec> {
                                      DfpcInputSpec in;
                                      CDFF_RETURN_IF_ERROR(inputTable().read(e, in));
                                      return in;
                                    });
                    })
          .optional("outputs",
                    [](const Field& f, GraphSpec& g) {
                      return listOf(f, g.outputs, "DFPC outputs",
                                    [](const Field& e) -> Result<DfpcOutputSpec> {
                                      DfpcOutputSpec out;
                                      CDFF_RETURN_IF_ERROR(outputTable().read(e, out));
                                      return out;
                                    });
                    })
          .optional("track_state",
                    [](const Field& f, GraphSpec& g) -> Status {
                      TrackStateSpec t;
                      t.at = f.location();
                      CDFF_RETURN_IF_ERROR(trackStateTable().read(f, t));
                      g.track_state = std::move(t);
                      return Status::ok();
                    })
          .required(
              "nodes",
              [](const Field& f, GraphSpec& g) -> Status {
                if (!f.isMap()) return f.fail("a map of instance name: instance");
                for (const Field::Entry& e : f.entries()) {
                  Result<InstanceSpec> inst = instance(e);
                  if (!inst) return inst.status();
                  g.instances.push_back(std::move(inst).value());
                }
                return Status::ok();
              },
              "its DFN instances, a map of name: {dfn, dfi, ...}")
          .optional("connections", [](const Field& f, GraphSpec& g) {
            return listOf(f, g.connections, "connections", connection);
          });
  return table;
}

Result<GraphSpec> read(const schema::Document& document) {
  GraphSpec g;
  g.source_file = document.source();
  const Field root = document.root();
  g.at = root.location();
  CDFF_RETURN_IF_ERROR(graphTable().read(root, g));
  return g;
}

}  // namespace

Result<GraphSpec> parseGraph(const std::string& yaml_text, const std::string& source_name) {
  Result<schema::Document> document = schema::Document::parse(yaml_text, source_name);
  if (!document) return document.status();
  return read(*document);
}

Result<GraphSpec> loadGraphFile(const std::string& path) {
  Result<schema::Document> document = schema::Document::loadFile(path, "DFPC graph file");
  if (!document) return document.status();
  return read(*document);
}

Result<ParameterSetting> parseParameterSetting(const std::string& text) {
  constexpr std::string_view kExample =
      "icp.max_iterations=30, or lidar_tracking/icp.max_iterations=30";
  ParameterSetting s;
  s.text = text;
  std::string body = text;
  const std::size_t slash = text.find('/'), eq = text.find('=');
  if (slash != std::string::npos && slash < eq) {
    s.dfpc = text.substr(0, slash);
    body = text.substr(slash + 1);
  }
  Result<schema::Override> o = schema::parseOverride(body, kExample);
  if (!o || o->key.size() < 2 ||
      (slash != std::string::npos && slash < eq && !isIdentifier(s.dfpc)) ||
      !isIdentifier(o->key[0]))
    return Status(StatusCode::kInvalidParameter,
                  fmt::format("expected [DFPC/]NODE.PARAMETER=VALUE, e.g. {}", kExample),
                  {"--set " + text, 0, 0});
  s.node = o->key[0];
  s.parameter = std::move(o).value();
  s.parameter.key.erase(s.parameter.key.begin());
  s.parameter.text = text;
  return s;
}

Result<GraphSpec> loadGraphFile(const std::string& path,
                                const std::vector<ParameterSetting>& settings,
                                std::vector<bool>& applied) {
  Result<schema::Document> document = schema::Document::loadFile(path, "DFPC graph file");
  if (!document) return document.status();
  applied.resize(settings.size(), false);
  const YAML::Node root = document->node();
  const std::string graph_name =
      root.IsMap() && root["name"].IsScalar() ? root["name"].Scalar() : std::string();
  const YAML::Node nodes = root.IsMap() ? root["nodes"] : YAML::Node();
  for (std::size_t i = 0; i < settings.size(); ++i) {
    const ParameterSetting& s = settings[i];
    if (!s.dfpc.empty() && s.dfpc != graph_name) continue;
    if (!nodes.IsMap() || !nodes[s.node].IsDefined()) continue;
    CDFF_RETURN_IF_ERROR(
        schema::applyOverride(*document, s.parameter, {"nodes", s.node, "parameters"}));
    applied[i] = true;
  }
  return read(*document);
}

Result<GraphSpec> loadGraphFile(const std::string& path,
                                const std::vector<std::string>& setting_texts) {
  std::vector<ParameterSetting> settings;
  for (const std::string& text : setting_texts) {
    Result<ParameterSetting> s = parseParameterSetting(text);
    if (!s) return s.status();
    settings.push_back(std::move(s).value());
  }
  std::vector<bool> applied;
  Result<GraphSpec> spec = loadGraphFile(path, settings, applied);
  if (!spec) return spec.status();
  for (std::size_t i = 0; i < settings.size(); ++i)
    if (!applied[i])
      return invalidInput("setting '{}' addresses no node of the graph in {}", settings[i].text,
                          path);
  return spec;
}

}  // namespace cdff::dfpc
