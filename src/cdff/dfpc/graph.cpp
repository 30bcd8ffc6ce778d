#include "cdff/dfpc/graph.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/dfn/port.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/dfpc/condition.hpp"

namespace cdff::dfpc {

// ---------------------------------------------------------------------------------------------
// Small types

SourceLocation SourceLocation::of(const std::string& file, const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  if (mark.is_null()) return {file, 0, 0};
  return {file, mark.line + 1, mark.column + 1};
}

SourceLocation SourceLocation::of(const std::source_location& where) {
  return {where.file_name(), static_cast<int>(where.line()), static_cast<int>(where.column())};
}

std::string SourceLocation::prefix() const {
  const std::string name = file.empty() ? "<graph>" : file;
  if (line <= 0) return name + ": ";
  if (column <= 0) return fmt::format("{}:{}: ", name, line);
  return fmt::format("{}:{}:{}: ", name, line, column);
}

PortRef PortRef::parse(const std::string& text) {
  const std::size_t dot = text.find('.');
  if (dot == std::string::npos) return {"", text};
  return {text.substr(0, dot), text.substr(dot + 1)};
}

const char* toString(SyncPolicy policy) {
  switch (policy) {
    case SyncPolicy::kNone:
      return "none";
    case SyncPolicy::kExact:
      return "exact";
    case SyncPolicy::kNearest:
      return "nearest";
  }
  return "?";
}

const char* toString(FaultKind kind) {
  switch (kind) {
    case FaultKind::kError:
      return "error";
    case FaultKind::kOverBudget:
      return "over_budget";
    case FaultKind::kDivergence:
      return "divergence";
    case FaultKind::kNoProduct:
      return "no_product";
  }
  return "?";
}

const char* toString(RecoveryActionKind kind) {
  switch (kind) {
    case RecoveryActionKind::kReinitialise:
      return "reinitialise";
    case RecoveryActionKind::kWake:
      return "wake";
    case RecoveryActionKind::kSwitchDfi:
      return "switch_dfi";
    case RecoveryActionKind::kSetTrackState:
      return "set_track_state";
  }
  return "?";
}

const SourceLocation& InstanceSpec::at(const std::string& field) const {
  auto it = where.find(field);
  if (it != where.end()) return it->second;
  it = where.find("");
  static const SourceLocation unknown;
  return it != where.end() ? it->second : unknown;
}

const InstanceSpec* GraphSpec::findInstance(const std::string& n) const {
  for (const auto& i : instances)
    if (i.name == n) return &i;
  return nullptr;
}

const DfpcInputSpec* GraphSpec::findInput(const std::string& n) const {
  for (const auto& i : inputs)
    if (i.name == n) return &i;
  return nullptr;
}

const DfpcOutputSpec* GraphSpec::findOutput(const std::string& n) const {
  for (const auto& o : outputs)
    if (o.name == n) return &o;
  return nullptr;
}

std::string GraphSpec::outputChannel(const DfpcOutputSpec& output) const {
  return output.channel.empty() ? fmt::format("/cdff/{}/{}", name, output.name) : output.channel;
}

// ---------------------------------------------------------------------------------------------
// YAML front end

namespace {

bool isIdentifier(const std::string& s) {
  if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0]))) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

const char* yamlKind(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Map:
      return "a map";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Scalar:
      return "a scalar";
    case YAML::NodeType::Null:
      return "empty";
    default:
      return "undefined";
  }
}

// Reads one file; the first error stops the parse (later ones often follow from it).
class GraphReader {
 public:
  explicit GraphReader(std::string file) : file_(std::move(file)) {}

  Result<GraphSpec> read(const YAML::Node& root) {
    GraphSpec g;
    g.source_file = file_;
    g.at = at(root);
    if (!root.IsMap())
      return fail(root, fmt::format("a DFPC graph must be a YAML map; got {}", yamlKind(root)));
    CDFF_RETURN_IF_ERROR(
        onlyKeys(root, "DFPC graph",
                 {"name", "doc", "inputs", "outputs", "nodes", "connections", "track_state"}));
    CDFF_RETURN_IF_ERROR(scalar(root, "name", g.name, true));
    if (!isIdentifier(g.name))
      return fail(root["name"], fmt::format("DFPC name '{}' must be an identifier "
                                            "(letters, digits, _)",
                                            g.name));
    CDFF_RETURN_IF_ERROR(scalar(root, "doc", g.doc, false));

    if (YAML::Node inputs = root["inputs"]) {
      CDFF_RETURN_IF_ERROR(expectSequence(inputs, "inputs"));
      for (const YAML::Node& n : inputs) {
        DfpcInputSpec in;
        in.at = at(n);
        CDFF_RETURN_IF_ERROR(expectMap(n, "a DFPC input"));
        CDFF_RETURN_IF_ERROR(onlyKeys(n, "DFPC input", {"name", "type", "channel", "optional"}));
        CDFF_RETURN_IF_ERROR(scalar(n, "name", in.name, true));
        CDFF_RETURN_IF_ERROR(scalar(n, "type", in.type, true));
        CDFF_RETURN_IF_ERROR(scalar(n, "channel", in.channel, true));
        CDFF_RETURN_IF_ERROR(boolean(n, "optional", in.optional));
        g.inputs.push_back(std::move(in));
      }
    }
    if (YAML::Node outputs = root["outputs"]) {
      CDFF_RETURN_IF_ERROR(expectSequence(outputs, "outputs"));
      for (const YAML::Node& n : outputs) {
        DfpcOutputSpec out;
        out.at = at(n);
        CDFF_RETURN_IF_ERROR(expectMap(n, "a DFPC output"));
        CDFF_RETURN_IF_ERROR(
            onlyKeys(n, "DFPC output",
                     {"name", "type", "channel", "role", "history", "timeout_s", "on_timeout"}));
        CDFF_RETURN_IF_ERROR(scalar(n, "name", out.name, true));
        CDFF_RETURN_IF_ERROR(scalar(n, "type", out.type, true));
        CDFF_RETURN_IF_ERROR(scalar(n, "channel", out.channel, false));
        CDFF_RETURN_IF_ERROR(scalar(n, "role", out.role, false));
        int history = 0;
        CDFF_RETURN_IF_ERROR(integer(n, "history", history, 1));
        out.history = static_cast<std::size_t>(history);
        CDFF_RETURN_IF_ERROR(number(n, "timeout_s", out.timeout_s, 0.0));
        if (YAML::Node r = n["on_timeout"]) {
          CDFF_RETURN_IF_ERROR(recovery(r, out.on_timeout));
          if (out.timeout_s <= 0)
            return fail(r, fmt::format("output '{}': on_timeout needs timeout_s > 0", out.name));
        }
        g.outputs.push_back(std::move(out));
      }
    }
    if (YAML::Node ts = root["track_state"]) {
      TrackStateSpec t;
      t.at = at(ts);
      CDFF_RETURN_IF_ERROR(expectMap(ts, "track_state"));
      CDFF_RETURN_IF_ERROR(onlyKeys(ts, "track_state", {"from", "initial"}));
      std::string from;
      CDFF_RETURN_IF_ERROR(scalar(ts, "from", from, false));
      if (!from.empty()) t.from = PortRef::parse(from);
      CDFF_RETURN_IF_ERROR(scalar(ts, "initial", t.initial, false));
      g.track_state = std::move(t);
    }
    YAML::Node nodes = root["nodes"];
    if (!nodes) return fail(root, "a DFPC graph needs 'nodes' (its DFN instances)");
    if (!nodes.IsMap())
      return fail(nodes, fmt::format("'nodes' must be a map of instance name -> instance; got {}",
                                     yamlKind(nodes)));
    for (auto it = nodes.begin(); it != nodes.end(); ++it) {
      Result<InstanceSpec> inst = instance(it->first, it->second);
      if (!inst) return inst.status();
      g.instances.push_back(std::move(inst).value());
    }
    if (YAML::Node conns = root["connections"]) {
      CDFF_RETURN_IF_ERROR(expectSequence(conns, "connections"));
      for (const YAML::Node& n : conns) {
        Result<ConnectionSpec> c = connection(n);
        if (!c) return c.status();
        g.connections.push_back(std::move(c).value());
      }
    }
    return g;
  }

 private:
  SourceLocation at(const YAML::Node& n) const { return SourceLocation::of(file_, n); }
  Status fail(const YAML::Node& n, const std::string& what) const {
    return invalidParameter("{}{}", at(n).prefix(), what);
  }

  Status expectMap(const YAML::Node& n, const char* what) const {
    return n.IsMap() ? Status::ok()
                     : fail(n, fmt::format("{} must be a map; got {}", what, yamlKind(n)));
  }
  Status expectSequence(const YAML::Node& n, const char* what) const {
    return n.IsSequence() ? Status::ok()
                          : fail(n, fmt::format("'{}' must be a list; got {}", what, yamlKind(n)));
  }

  Status onlyKeys(const YAML::Node& map, const char* what,
                  std::initializer_list<const char*> keys) const {
    std::set<std::string> seen;
    for (auto it = map.begin(); it != map.end(); ++it) {
      const std::string key = it->first.as<std::string>("");
      if (std::none_of(keys.begin(), keys.end(), [&](const char* k) { return key == k; }))
        return fail(it->first, fmt::format("{}: unknown key '{}'; expected one of {{{}}}", what,
                                           key, fmt::join(keys, ", ")));
      if (!seen.insert(key).second)
        return fail(it->first, fmt::format("{}: key '{}' is given twice", what, key));
    }
    return Status::ok();
  }

  Status scalar(const YAML::Node& map, const char* key, std::string& out, bool required) const {
    const YAML::Node n = map[key];
    if (!n)
      return required ? fail(map, fmt::format("missing required key '{}'", key)) : Status::ok();
    if (!n.IsScalar())
      return fail(n, fmt::format("'{}' must be a scalar; got {}", key, yamlKind(n)));
    out = n.Scalar();
    if (required && out.empty()) return fail(n, fmt::format("'{}' must not be empty", key));
    return Status::ok();
  }

  Status number(const YAML::Node& map, const char* key, double& out, double min) const {
    const YAML::Node n = map[key];
    if (!n) return Status::ok();
    double v = 0;
    if (!n.IsScalar() || !YAML::convert<double>::decode(n, v) || !std::isfinite(v))
      return fail(n, fmt::format("'{}' = {} is not a number; expected a number >= {}", key,
                                 n.IsScalar() ? n.Scalar() : yamlKind(n), min));
    if (v < min)
      return fail(n,
                  fmt::format("'{}' = {} is out of range; expected >= {}", key, n.Scalar(), min));
    out = v;
    return Status::ok();
  }

  Status integer(const YAML::Node& map, const char* key, int& out, int min) const {
    const YAML::Node n = map[key];
    if (!n) return Status::ok();
    int v = 0;
    if (!n.IsScalar() || !YAML::convert<int>::decode(n, v))
      return fail(n, fmt::format("'{}' = {} is not an integer; expected an integer >= {}", key,
                                 n.IsScalar() ? n.Scalar() : yamlKind(n), min));
    if (v < min)
      return fail(n, fmt::format("'{}' = {} is out of range; expected >= {}", key, v, min));
    out = v;
    return Status::ok();
  }

  Status boolean(const YAML::Node& map, const char* key, bool& out) const {
    const YAML::Node n = map[key];
    if (!n) return Status::ok();
    if (!n.IsScalar() || !YAML::convert<bool>::decode(n, out))
      return fail(n, fmt::format("'{}' = {} is not a bool; expected true or false", key,
                                 n.IsScalar() ? n.Scalar() : yamlKind(n)));
    return Status::ok();
  }

  Status stringList(const YAML::Node& n, const char* key, std::vector<std::string>& out) const {
    if (n.IsScalar()) {
      out = {n.Scalar()};
      return Status::ok();
    }
    if (!n.IsSequence())
      return fail(n, fmt::format("'{}' must be a port name or a list of port names; got {}", key,
                                 yamlKind(n)));
    for (const YAML::Node& item : n) {
      if (!item.IsScalar())
        return fail(item,
                    fmt::format("'{}' entries must be port names; got {}", key, yamlKind(item)));
      out.push_back(item.Scalar());
    }
    return Status::ok();
  }

  Status parameters(const YAML::Node& n, YAML::Node& out, std::string& source) const {
    source = file_;
    if (n.IsNull()) return Status::ok();
    if (n.IsMap()) {
      out = n;
      return Status::ok();
    }
    if (n.IsScalar()) {  // a parameter file, relative to the graph file
      std::filesystem::path path(n.Scalar());
      if (path.is_relative() && !file_.empty())
        path = std::filesystem::path(file_).parent_path() / path;
      try {
        out = YAML::LoadFile(path.string());
      } catch (const YAML::BadFile&) {
        return fail(n, fmt::format("cannot open parameter file '{}'; expected a readable YAML "
                                   "file (relative to the graph file)",
                                   path.string()));
      } catch (const YAML::Exception& e) {
        return invalidParameter("{}:{}:{}: YAML syntax error: {}", path.string(), e.mark.line + 1,
                                e.mark.column + 1, e.msg);
      }
      source = path.string();
      return Status::ok();
    }
    return fail(
        n, fmt::format("'parameters' must be a map or a parameter file name; got {}", yamlKind(n)));
  }

  Status action(const YAML::Node& n, RecoveryAction& a) const {
    a.at = at(n);
    auto kindOf = [&](const std::string& word, const YAML::Node& where) -> Status {
      if (word == "reinitialise")
        a.kind = RecoveryActionKind::kReinitialise;
      else if (word == "wake")
        a.kind = RecoveryActionKind::kWake;
      else if (word == "switch_dfi")
        a.kind = RecoveryActionKind::kSwitchDfi;
      else if (word == "set_track_state")
        a.kind = RecoveryActionKind::kSetTrackState;
      else
        return fail(where, fmt::format("unknown recovery '{}'; expected one of {{reinitialise, "
                                       "wake, switch_dfi, set_track_state}}",
                                       word));
      return Status::ok();
    };
    if (n.IsScalar()) return kindOf(n.Scalar(), n);
    if (n.IsMap() && n.size() == 1) {
      auto it = n.begin();
      CDFF_RETURN_IF_ERROR(kindOf(it->first.as<std::string>(""), it->first));
      if (!it->second.IsScalar() || it->second.Scalar().empty())
        return fail(it->second, fmt::format("recovery '{}' needs an instance name (or a track "
                                            "state value for set_track_state)",
                                            toString(a.kind)));
      a.argument = it->second.Scalar();
      return Status::ok();
    }
    return fail(n, fmt::format("a recovery is a name (reinitialise, switch_dfi) or a one-key map "
                               "such as {{wake: detector}}; got {}",
                               yamlKind(n)));
  }

  Status recovery(const YAML::Node& n, RecoverySpec& r) const {
    r.at = at(n);
    YAML::Node actions = n;
    if (n.IsMap()) {
      CDFF_RETURN_IF_ERROR(onlyKeys(n, "recovery", {"after", "do"}));
      CDFF_RETURN_IF_ERROR(integer(n, "after", r.after, 1));
      actions = n["do"];
      if (!actions) return fail(n, "a recovery map needs 'do' (the list of actions)");
    }
    if (actions.IsScalar() || actions.IsMap()) {
      RecoveryAction a;
      CDFF_RETURN_IF_ERROR(action(actions, a));
      r.actions.push_back(std::move(a));
      return Status::ok();
    }
    if (!actions.IsSequence() || actions.size() == 0)
      return fail(actions, "a recovery needs a non-empty list of actions");
    for (const YAML::Node& item : actions) {
      RecoveryAction a;
      CDFF_RETURN_IF_ERROR(action(item, a));
      r.actions.push_back(std::move(a));
    }
    return Status::ok();
  }

  Result<InstanceSpec> instance(const YAML::Node& key, const YAML::Node& n) const {
    InstanceSpec s;
    s.name = key.as<std::string>("");
    s.where[""] = at(key);
    if (!isIdentifier(s.name))
      return fail(key, fmt::format("instance name '{}' must be an identifier (letters, digits, _)",
                                   s.name));
    if (!n.IsMap())
      return fail(n, fmt::format("instance '{}' must be a map with dfn, dfi...; got {}", s.name,
                                 yamlKind(n)));
    const std::string what = fmt::format("instance '{}'", s.name);
    CDFF_RETURN_IF_ERROR(onlyKeys(n, what.c_str(),
                                  {"dfn", "dfi", "parameters", "trigger", "active_when",
                                   "diverged_when", "budget_s", "fallback", "on_fault"}));
    for (auto it = n.begin(); it != n.end(); ++it)
      s.where[it->first.as<std::string>("")] = at(it->second);
    CDFF_RETURN_IF_ERROR(scalar(n, "dfn", s.dfn, true));
    CDFF_RETURN_IF_ERROR(scalar(n, "dfi", s.dfi, true));
    if (YAML::Node p = n["parameters"])
      CDFF_RETURN_IF_ERROR(parameters(p, s.parameters, s.parameters_source));
    else
      s.parameters_source = file_;
    if (YAML::Node t = n["trigger"]) {
      CDFF_RETURN_IF_ERROR(expectMap(t, "'trigger'"));
      CDFF_RETURN_IF_ERROR(
          onlyKeys(t, "trigger",
                   {"on", "period_s", "time_input", "tick_when", "sync", "tolerance_s", "queue"}));
      TriggerSpec& tr = s.trigger;
      if (YAML::Node on = t["on"]) {
        CDFF_RETURN_IF_ERROR(stringList(on, "on", tr.on));
        tr.on_given = true;
        s.where["on"] = at(on);
      }
      CDFF_RETURN_IF_ERROR(number(t, "period_s", tr.period_s, 0.0));
      CDFF_RETURN_IF_ERROR(scalar(t, "time_input", tr.time_input, false));
      if (t["time_input"]) s.where["time_input"] = at(t["time_input"]);
      CDFF_RETURN_IF_ERROR(scalar(t, "tick_when", tr.tick_when, false));
      if (t["tick_when"]) s.where["tick_when"] = at(t["tick_when"]);
      if (YAML::Node sync = t["sync"]) {
        s.where["sync"] = at(sync);
        const std::string policy = sync.IsScalar() ? sync.Scalar() : "";
        if (policy == "exact")
          tr.sync = SyncPolicy::kExact;
        else if (policy == "nearest")
          tr.sync = SyncPolicy::kNearest;
        else if (policy == "none")
          tr.sync = SyncPolicy::kNone;
        else
          return fail(sync, fmt::format("sync = '{}'; expected one of {{exact, nearest, none}}",
                                        sync.IsScalar() ? sync.Scalar() : yamlKind(sync)));
      }
      CDFF_RETURN_IF_ERROR(number(t, "tolerance_s", tr.tolerance_s, 0.0));
      CDFF_RETURN_IF_ERROR(integer(t, "queue", tr.queue, 1));
      if (t["tolerance_s"]) s.where["tolerance_s"] = at(t["tolerance_s"]);
      if ((t["tolerance_s"] || t["queue"]) && tr.sync == SyncPolicy::kNone)
        return fail(t,
                    "tolerance_s and queue apply to synchronised triggers; set sync: exact or "
                    "sync: nearest");
      if (t["tolerance_s"] && tr.sync == SyncPolicy::kExact)
        return fail(t["tolerance_s"],
                    "tolerance_s applies to sync: nearest; exact "
                    "synchronisation matches equal stamps only");
    }
    CDFF_RETURN_IF_ERROR(scalar(n, "active_when", s.active_when, false));
    CDFF_RETURN_IF_ERROR(scalar(n, "diverged_when", s.diverged_when, false));
    CDFF_RETURN_IF_ERROR(number(n, "budget_s", s.budget_s, 0.0));
    if (YAML::Node f = n["fallback"]) {
      FallbackSpec fb;
      fb.at = at(f);
      CDFF_RETURN_IF_ERROR(expectMap(f, "'fallback'"));
      CDFF_RETURN_IF_ERROR(onlyKeys(f, "fallback", {"dfi", "parameters"}));
      CDFF_RETURN_IF_ERROR(scalar(f, "dfi", fb.dfi, true));
      fb.parameters_source = file_;
      if (YAML::Node p = f["parameters"])
        CDFF_RETURN_IF_ERROR(parameters(p, fb.parameters, fb.parameters_source));
      s.fallback = std::move(fb);
    }
    if (YAML::Node faults = n["on_fault"]) {
      CDFF_RETURN_IF_ERROR(expectMap(faults, "'on_fault'"));
      CDFF_RETURN_IF_ERROR(onlyKeys(faults, "on_fault", {"error", "over_budget", "divergence"}));
      for (auto it = faults.begin(); it != faults.end(); ++it) {
        const std::string kind = it->first.as<std::string>("");
        const FaultKind k = kind == "error"         ? FaultKind::kError
                            : kind == "over_budget" ? FaultKind::kOverBudget
                                                    : FaultKind::kDivergence;
        CDFF_RETURN_IF_ERROR(recovery(it->second, s.on_fault[k]));
      }
    }
    return s;
  }

  Result<ConnectionSpec> connection(const YAML::Node& n) const {
    ConnectionSpec c;
    c.at = at(n);
    std::string from, to;
    if (n.IsScalar()) {
      const std::string text = n.Scalar();
      const std::size_t arrow = text.find("->");
      if (arrow == std::string::npos || text.find("->", arrow + 2) != std::string::npos)
        return fail(n, fmt::format("connection '{}' must read 'from -> to' (instance.port -> "
                                   "instance.port; a bare name is a DFPC input or output)",
                                   text));
      auto trim = [](std::string s) {
        const auto b = s.find_first_not_of(" \t");
        const auto e = s.find_last_not_of(" \t");
        return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
      };
      from = trim(text.substr(0, arrow));
      to = trim(text.substr(arrow + 2));
    } else if (n.IsMap()) {
      CDFF_RETURN_IF_ERROR(onlyKeys(n, "connection", {"from", "to", "delay"}));
      CDFF_RETURN_IF_ERROR(scalar(n, "from", from, true));
      CDFF_RETURN_IF_ERROR(scalar(n, "to", to, true));
      CDFF_RETURN_IF_ERROR(integer(n, "delay", c.delay, 0));
      if (c.delay > 1)
        return fail(n["delay"], fmt::format("delay = {}; expected 0 or 1 (one step)", c.delay));
    } else {
      return fail(n, fmt::format("a connection is 'from -> to' or {{from, to, delay}}; got {}",
                                 yamlKind(n)));
    }
    for (const std::string* end : {&from, &to}) {
      const PortRef r = PortRef::parse(*end);
      const bool ok = !end->empty() && std::count(end->begin(), end->end(), '.') <= 1 &&
                      (r.instance.empty() || isIdentifier(r.instance)) && isIdentifier(r.port);
      if (!ok)
        return fail(n, fmt::format("'{}' is not a port; expected instance.port or a DFPC input "
                                   "or output name",
                                   *end));
    }
    c.from = PortRef::parse(from);
    c.to = PortRef::parse(to);
    return c;
  }

  std::string file_;
};

}  // namespace

Result<GraphSpec> parseGraph(const std::string& yaml_text, const std::string& source_name) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    return invalidParameter("{}:{}:{}: YAML syntax error: {}", source_name, e.mark.line + 1,
                            e.mark.column + 1, e.msg);
  }
  try {
    return GraphReader(source_name).read(root);
  } catch (const YAML::Exception& e) {
    return invalidParameter("{}:{}:{}: {}", source_name, e.mark.line + 1, e.mark.column + 1, e.msg);
  }
}

Result<GraphSpec> loadGraphFile(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    return notFound("{}: cannot open DFPC graph file; expected a readable YAML file", path);
  } catch (const YAML::Exception& e) {
    return invalidParameter("{}:{}:{}: YAML syntax error: {}", path, e.mark.line + 1,
                            e.mark.column + 1, e.msg);
  }
  try {
    return GraphReader(path).read(root);
  } catch (const YAML::Exception& e) {
    return invalidParameter("{}:{}:{}: {}", path, e.mark.line + 1, e.mark.column + 1, e.msg);
  }
}

// ---------------------------------------------------------------------------------------------
// Checks

namespace {

const dfn::PortSpec* findSpec(const std::vector<dfn::PortSpec>& ports, const std::string& name) {
  for (const auto& p : ports)
    if (p.name == name) return &p;
  return nullptr;
}

std::string portNames(const std::vector<dfn::PortSpec>& ports) {
  std::vector<std::string> names;
  for (const auto& p : ports) names.push_back(p.name);
  return fmt::format("{{{}}}", fmt::join(names, ", "));
}

class GraphChecker {
 public:
  explicit GraphChecker(const GraphSpec& g) : g_(g), registry_(dfn::Registry::instance()) {}

  std::vector<Status> run() {
    for (const Status& s : g_.build_errors) errors_.push_back(s);
    if (g_.name.empty()) error(g_.at, "the DFPC has no name");
    if (g_.instances.empty()) error(g_.at, "the DFPC has no DFN instances ('nodes')");
    checkInterface();
    checkInstances();
    checkConnections();
    checkRequiredInputs();
    checkCycles();
    checkControl();
    return std::move(errors_);
  }

 private:
  template <typename... Args>
  void error(const SourceLocation& at, fmt::format_string<Args...> format, Args&&... args) {
    errors_.push_back(
        invalidParameter("{}{}", at.prefix(), fmt::format(format, std::forward<Args>(args)...)));
  }

  const dfn::DfnDescription* description(const std::string& instance) const {
    auto it = descriptions_.find(instance);
    return it == descriptions_.end() ? nullptr : it->second;
  }

  void checkInterface() {
    std::set<std::string> names;
    for (const auto& in : g_.inputs) {
      if (!names.insert(in.name).second) error(in.at, "DFPC port '{}' is declared twice", in.name);
      if (!isIdentifier(in.name))
        error(in.at, "DFPC input name '{}' must be an identifier", in.name);
      if (!dfn::findPortType(in.type))
        error(in.at, "DFPC input '{}': unknown type '{}'; {}", in.name, in.type, typeNames());
      if (in.channel.empty()) error(in.at, "DFPC input '{}' has no channel", in.name);
    }
    for (const auto& out : g_.outputs) {
      if (!names.insert(out.name).second)
        error(out.at, "DFPC port '{}' is declared twice", out.name);
      if (!isIdentifier(out.name))
        error(out.at, "DFPC output name '{}' must be an identifier", out.name);
      if (!dfn::findPortType(out.type))
        error(out.at, "DFPC output '{}': unknown type '{}'; {}", out.name, out.type, typeNames());
      static const std::map<std::string, std::set<std::string>> roles = {
          {"target_state", {"RigidBodyState"}},
          {"target_pose", {"PoseWithCovariance", "RigidBodyState"}},
          {"target_model", {"TriangleMesh", "PointCloud"}}};
      if (!out.role.empty()) {
        auto it = roles.find(out.role);
        if (it == roles.end())
          error(out.at,
                "DFPC output '{}': unknown role '{}'; expected one of {{target_state, "
                "target_pose, target_model}}",
                out.name, out.role);
        else if (!it->second.count(out.type))
          error(out.at, "DFPC output '{}' has role '{}' but type {}; expected {}", out.name,
                out.role, out.type, fmt::join(it->second, " or "));
      }
      checkRecovery(out.on_timeout, nullptr);
    }
  }

  static std::string typeNames() {
    std::vector<std::string_view> names;
    for (const auto& t : dfn::allPortTypes()) names.push_back(t.name);
    return fmt::format("expected one of {{{}}}", fmt::join(names, ", "));
  }

  void checkInstances() {
    std::set<std::string> names;
    for (const auto& inst : g_.instances) {
      if (!names.insert(inst.name).second)
        error(inst.at(), "instance '{}' is declared twice", inst.name);
      if (inst.name == "track_state")
        error(inst.at(), "'track_state' is reserved (conditions use it); rename the instance");
      if (g_.findInput(inst.name) || g_.findOutput(inst.name))
        error(inst.at(), "instance '{}' has the name of a DFPC input or output", inst.name);
      const dfn::DfnDescription* d = registry_.findDescription(inst.dfn);
      if (!d) {
        std::vector<std::string> known;
        for (const auto* desc : registry_.descriptions()) known.push_back(desc->name);
        error(inst.at("dfn"), "instance '{}': unknown DFN '{}'; expected one of {{{}}}", inst.name,
              inst.dfn, fmt::join(known, ", "));
        continue;
      }
      descriptions_[inst.name] = d;
      auto dfiKnown = [&](const std::string& dfi, const SourceLocation& at, const char* what) {
        if (registry_.hasImplementation(inst.dfn, dfi)) return;
        std::vector<std::string> known;
        for (const auto& impl : d->implementations) known.push_back(impl.name);
        error(at, "instance '{}': DFN '{}' has no {} '{}'; expected one of {{{}}}", inst.name,
              inst.dfn, what, dfi, fmt::join(known, ", "));
      };
      dfiKnown(inst.dfi, inst.at("dfi"), "implementation");
      if (inst.fallback) dfiKnown(inst.fallback->dfi, inst.fallback->at, "fallback implementation");

      const TriggerSpec& t = inst.trigger;
      for (const std::string& port : t.on)
        if (!findSpec(d->inputs, port))
          error(inst.at("on"),
                "instance '{}': trigger port '{}' is not an input of {}; expected "
                "one of {}",
                inst.name, port, inst.dfn, portNames(d->inputs));
      if (t.on_given && t.on.empty() && t.period_s <= 0)
        error(inst.at("on"),
              "instance '{}': 'on' is empty and there is no period; it would never "
              "run",
              inst.name);
      if (!t.time_input.empty()) {
        const dfn::PortSpec* p = findSpec(d->inputs, t.time_input);
        if (!p)
          error(inst.at("time_input"),
                "instance '{}': time_input '{}' is not an input of {}; "
                "expected one of {}",
                inst.name, t.time_input, inst.dfn, portNames(d->inputs));
        else if (p->type != "Timestamp")
          error(inst.at("time_input"),
                "instance '{}': time_input '{}' has type {}; expected "
                "Timestamp",
                inst.name, t.time_input, p->type);
        if (t.period_s <= 0)
          error(inst.at("time_input"), "instance '{}': time_input needs a period_s > 0", inst.name);
      }
      if (!t.tick_when.empty() && t.period_s <= 0)
        error(inst.at("tick_when"), "instance '{}': tick_when needs a period_s > 0", inst.name);
      if (t.sync != SyncPolicy::kNone && t.on.size() < 2)
        error(inst.at("sync"), "instance '{}': sync: {} needs at least two ports in 'on'",
              inst.name, toString(t.sync));
      if (t.sync == SyncPolicy::kNearest && t.tolerance_s <= 0)
        error(inst.at("sync"), "instance '{}': sync: nearest needs tolerance_s > 0", inst.name);
      if (inst.on_fault.count(FaultKind::kOverBudget) && inst.budget_s <= 0)
        error(inst.at("on_fault"), "instance '{}': on_fault.over_budget needs budget_s > 0",
              inst.name);
      if (inst.on_fault.count(FaultKind::kDivergence) && inst.diverged_when.empty())
        error(inst.at("on_fault"), "instance '{}': on_fault.divergence needs diverged_when",
              inst.name);
      for (const auto& [kind, r] : inst.on_fault) checkRecovery(r, &inst);
    }
  }

  void checkRecovery(const RecoverySpec& r, const InstanceSpec* faulty) {
    for (const RecoveryAction& a : r.actions) {
      if (a.kind == RecoveryActionKind::kSetTrackState) continue;
      std::string target = a.argument;
      if (target.empty()) {
        if (!faulty) {
          error(a.at, "recovery '{}' needs an instance here: write {{{}: instance}}",
                toString(a.kind), toString(a.kind));
          continue;
        }
        target = faulty->name;
      }
      const InstanceSpec* inst = g_.findInstance(target);
      if (!inst) {
        error(a.at, "recovery '{}' names unknown instance '{}'", toString(a.kind), target);
        continue;
      }
      if (a.kind == RecoveryActionKind::kSwitchDfi && !inst->fallback)
        error(a.at, "recovery 'switch_dfi' on instance '{}', which has no 'fallback'", target);
      if (a.kind == RecoveryActionKind::kWake && inst->active_when.empty())
        error(a.at, "recovery 'wake' on instance '{}', which never sleeps (no active_when)",
              target);
    }
  }

  // The type of a connection end, or "" (and an error) when it does not exist.
  std::string endType(const PortRef& ref, bool source, const ConnectionSpec& c) {
    if (ref.isDfpcPort()) {
      if (source) {
        if (const DfpcInputSpec* in = g_.findInput(ref.port)) return in->type;
        if (g_.findOutput(ref.port))
          error(c.at,
                "connection source '{}' is a DFPC output; a source is a DFPC input or "
                "instance.output",
                ref.port);
        else
          error(c.at,
                "connection source '{}' is not a DFPC input; expected instance.port or "
                "one of the DFPC inputs",
                ref.port);
      } else {
        if (const DfpcOutputSpec* out = g_.findOutput(ref.port)) return out->type;
        if (g_.findInput(ref.port))
          error(c.at,
                "connection target '{}' is a DFPC input; a target is instance.input or a "
                "DFPC output",
                ref.port);
        else
          error(c.at,
                "connection target '{}' is not a DFPC output; expected instance.port or "
                "one of the DFPC outputs",
                ref.port);
      }
      return "";
    }
    const InstanceSpec* inst = g_.findInstance(ref.instance);
    if (!inst) {
      error(c.at, "connection {} '{}' names unknown instance '{}'", source ? "source" : "target",
            ref.toString(), ref.instance);
      return "";
    }
    const dfn::DfnDescription* d = description(ref.instance);
    if (!d) return "";  // its unknown DFN is already reported
    const auto& ports = source ? d->outputs : d->inputs;
    const dfn::PortSpec* p = findSpec(ports, ref.port);
    if (!p) {
      error(c.at, "connection {} '{}': {} has no {} '{}'; expected one of {}",
            source ? "source" : "target", ref.toString(), inst->dfn, source ? "output" : "input",
            ref.port, portNames(ports));
      return "";
    }
    return p->type;
  }

  void checkConnections() {
    for (const ConnectionSpec& c : g_.connections) {
      const std::string from = endType(c.from, true, c);
      const std::string to = endType(c.to, false, c);
      if (!from.empty() && !to.empty() && from != to)
        error(c.at, "type mismatch: '{}' is {} but '{}' is {}", c.from.toString(), from,
              c.to.toString(), to);
      if (c.delay > 0 && (c.from.isDfpcPort() || c.to.isDfpcPort()))
        error(c.at, "delay applies between instances; '{} -> {}' involves a DFPC port",
              c.from.toString(), c.to.toString());
      if (!c.from.isDfpcPort() && c.from.instance == c.to.instance && c.delay == 0)
        error(c.at, "instance '{}' feeds itself without a delay ('{} -> {}'); add delay: 1",
              c.from.instance, c.from.toString(), c.to.toString());
    }
    for (const auto& out : g_.outputs) {
      int feeds = 0;
      for (const ConnectionSpec& c : g_.connections)
        if (c.to.isDfpcPort() && c.to.port == out.name) ++feeds;
      if (feeds == 0)
        error(out.at,
              "DFPC output '{}' is not connected; expected a connection "
              "'instance.port -> {}'",
              out.name, out.name);
      else if (feeds > 1)
        error(out.at, "DFPC output '{}' has {} sources; expected one", out.name, feeds);
    }
    for (const auto& in : g_.inputs) {
      const bool used = std::any_of(
          g_.connections.begin(), g_.connections.end(),
          [&](const ConnectionSpec& c) { return c.from.isDfpcPort() && c.from.port == in.name; });
      if (!used) error(in.at, "DFPC input '{}' feeds nothing; connect it or remove it", in.name);
    }
  }

  void checkRequiredInputs() {
    for (const auto& inst : g_.instances) {
      const dfn::DfnDescription* d = description(inst.name);
      if (!d) continue;
      for (const dfn::PortSpec& p : d->inputs) {
        if (p.optional) continue;
        if (p.name == inst.trigger.time_input) continue;
        const bool fed =
            std::any_of(g_.connections.begin(), g_.connections.end(), [&](const ConnectionSpec& c) {
              return c.to.instance == inst.name && c.to.port == p.name;
            });
        if (!fed)
          error(inst.at(), "instance '{}' ({}): required input '{}' ({}) is not connected",
                inst.name, inst.dfn, p.name, p.type);
      }
      // Without an explicit trigger, the inputs fed without delay trigger; there must be one.
      if (!inst.trigger.on_given && inst.trigger.period_s <= 0) {
        const bool any = std::any_of(
            g_.connections.begin(), g_.connections.end(),
            [&](const ConnectionSpec& c) { return c.to.instance == inst.name && c.delay == 0; });
        if (!any)
          error(inst.at(),
                "instance '{}' never runs: no input is fed without delay and it has no "
                "trigger (on, period_s)",
                inst.name);
      }
    }
  }

  void checkCycles() {
    // Instance graph of the connections without delay; a cycle there has no step to break it.
    std::map<std::string, std::vector<const ConnectionSpec*>> out;
    for (const ConnectionSpec& c : g_.connections)
      if (c.delay == 0 && !c.from.isDfpcPort() && !c.to.isDfpcPort() &&
          c.from.instance != c.to.instance && g_.findInstance(c.from.instance) &&
          g_.findInstance(c.to.instance))
        out[c.from.instance].push_back(&c);
    std::map<std::string, int> state;  // 0 unvisited, 1 on the stack, 2 done
    std::vector<const ConnectionSpec*> path;
    bool reported = false;
    std::function<void(const std::string&)> visit = [&](const std::string& n) {
      state[n] = 1;
      for (const ConnectionSpec* c : out[n]) {
        if (reported) return;
        path.push_back(c);
        const std::string& m = c->to.instance;
        if (state[m] == 1) {
          std::vector<std::string> names;
          auto start = std::find_if(path.begin(), path.end(),
                                    [&](const ConnectionSpec* e) { return e->from.instance == m; });
          for (auto it = start; it != path.end(); ++it) names.push_back((*it)->from.instance);
          names.push_back(m);
          error(c->at, "cycle without a delay: {}; mark one of its connections 'delay: 1'",
                fmt::join(names, " -> "));
          reported = true;
        } else if (state[m] == 0) {
          visit(m);
        }
        path.pop_back();
      }
      state[n] = 2;
    };
    for (const auto& inst : g_.instances)
      if (!reported && state[inst.name] == 0) visit(inst.name);
  }

  // The type of a condition reference, or an error.
  Result<dfn::PortType> refType(const Condition::Ref& r) const {
    if (r.instance.empty()) return dfn::PortType::of<std::string>();
    if (!g_.findInstance(r.instance))
      return notFound("'{}' names unknown instance '{}'", r.text(), r.instance);
    const dfn::DfnDescription* d = description(r.instance);
    if (!d) return notFound("'{}': the DFN of '{}' is unknown", r.text(), r.instance);
    const dfn::PortSpec* p = findSpec(d->outputs, r.port);
    if (!p)
      return notFound("'{}': {} has no output '{}'; expected one of {}", r.text(), d->name, r.port,
                      portNames(d->outputs));
    return *dfn::findPortType(p->type);
  }

  void checkCondition(const std::string& text, const SourceLocation& at) {
    if (text.empty()) return;
    Result<Condition> c = Condition::parse(text, at.prefix());
    if (!c) {
      errors_.push_back(c.status());
      return;
    }
    std::vector<dfn::PortType> types;
    for (const auto& r : c->refs()) {
      Result<dfn::PortType> t = refType(r);
      if (!t) {
        error(at, "condition '{}': {}", text, t.status().message());
        return;
      }
      types.push_back(*t);
    }
    Status bound = c->bind(types, at.prefix());
    if (!bound) errors_.push_back(bound);
  }

  void checkControl() {
    for (const auto& inst : g_.instances) {
      checkCondition(inst.active_when, inst.at("active_when"));
      checkCondition(inst.diverged_when, inst.at("diverged_when"));
      checkCondition(inst.trigger.tick_when, inst.at("tick_when"));
    }
    if (g_.track_state && !g_.track_state->from.port.empty()) {
      const PortRef& from = g_.track_state->from;
      Result<dfn::PortType> t = from.isDfpcPort()
                                    ? Result<dfn::PortType>(notFound("expected instance.port"))
                                    : refType({from.instance, from.port});
      if (!t)
        error(g_.track_state->at, "track_state.from '{}': {}", from.toString(),
              t.status().message());
      else if (!(*t == dfn::PortType::of<std::string>()))
        error(g_.track_state->at, "track_state.from '{}' has type {}; expected String",
              from.toString(), t->name);
    }
  }

  const GraphSpec& g_;
  const dfn::Registry& registry_;
  std::map<std::string, const dfn::DfnDescription*> descriptions_;
  std::vector<Status> errors_;
};

}  // namespace

std::vector<Status> checkGraph(const GraphSpec& graph) {
  return GraphChecker(graph).run();
}

// ---------------------------------------------------------------------------------------------
// DOT

namespace {
std::string dotEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out;
}
}  // namespace

std::string toDot(const GraphSpec& g) {
  std::string dot = fmt::format("digraph \"{}\" {{\n  rankdir=LR;\n  node [fontname=Helvetica];\n",
                                dotEscape(g.name));
  for (const auto& in : g.inputs)
    dot += fmt::format("  \"in:{}\" [shape=ellipse, label=\"{}\\n{}\\n{}\"];\n", in.name, in.name,
                       in.type, dotEscape(in.channel));
  for (const auto& out : g.outputs)
    dot += fmt::format("  \"out:{}\" [shape=ellipse, style=bold, label=\"{}\\n{}{}\"];\n", out.name,
                       out.name, out.type, out.role.empty() ? "" : "\\nrole: " + out.role);
  for (const auto& inst : g.instances) {
    std::string label = fmt::format("{}\\n{}/{}", inst.name, inst.dfn, inst.dfi);
    if (inst.trigger.period_s > 0) label += fmt::format("\\nevery {} s", inst.trigger.period_s);
    if (inst.trigger.sync != SyncPolicy::kNone)
      label += fmt::format("\\nsync {} [{}]", toString(inst.trigger.sync),
                           fmt::join(inst.trigger.on, ", "));
    if (!inst.active_when.empty()) label += "\\nactive when " + dotEscape(inst.active_when);
    if (inst.budget_s > 0) label += fmt::format("\\nbudget {} ms", inst.budget_s * 1e3);
    dot += fmt::format("  \"{}\" [shape=box, {}label=\"{}\"];\n", inst.name,
                       inst.active_when.empty() ? "" : "style=dashed, ", label);
  }
  for (const auto& c : g.connections) {
    const std::string from = c.from.isDfpcPort() ? "in:" + c.from.port : c.from.instance;
    const std::string to = c.to.isDfpcPort() ? "out:" + c.to.port : c.to.instance;
    std::string label = fmt::format("{} -> {}", c.from.isDfpcPort() ? "" : c.from.port,
                                    c.to.isDfpcPort() ? "" : c.to.port);
    dot += fmt::format("  \"{}\" -> \"{}\" [label=\"{}{}\"{}];\n", from, to, label,
                       c.delay ? " (delay 1)" : "", c.delay ? ", style=dashed" : "");
  }
  if (g.track_state && !g.track_state->from.port.empty())
    dot += fmt::format(
        "  \"track_state\" [shape=note, label=\"track_state\\ninitial {}\"];\n"
        "  \"{}\" -> \"track_state\" [style=dotted, label=\"{}\"];\n",
        g.track_state->initial, g.track_state->from.instance, g.track_state->from.port);
  dot += "}\n";
  return dot;
}

// ---------------------------------------------------------------------------------------------
// GraphBuilder

GraphBuilder::GraphBuilder(std::string name, std::source_location where) {
  spec_.name = std::move(name);
  spec_.at = SourceLocation::of(where);
}

GraphBuilder& GraphBuilder::input(std::string name, std::string type, std::string channel,
                                  std::source_location where) {
  spec_.inputs.push_back(
      {std::move(name), std::move(type), std::move(channel), false, SourceLocation::of(where)});
  return *this;
}

GraphBuilder& GraphBuilder::output(std::string name, std::string type, std::string channel,
                                   std::string role, std::source_location where) {
  DfpcOutputSpec out;
  out.name = std::move(name);
  out.type = std::move(type);
  out.channel = std::move(channel);
  out.role = std::move(role);
  out.at = SourceLocation::of(where);
  spec_.outputs.push_back(std::move(out));
  return *this;
}

GraphBuilder& GraphBuilder::outputWatchdog(const std::string& output, double timeout_s,
                                           std::vector<RecoveryAction> actions) {
  for (auto& out : spec_.outputs) {
    if (out.name != output) continue;
    out.timeout_s = timeout_s;
    out.on_timeout.actions = std::move(actions);
    for (auto& a : out.on_timeout.actions)
      if (a.at.file.empty()) a.at = out.at;
    return *this;
  }
  spec_.build_errors.push_back(
      invalidParameter("{}outputWatchdog: no DFPC output '{}'", spec_.at.prefix(), output));
  return *this;
}

GraphBuilder::Node GraphBuilder::node(std::string name, std::string dfn, std::string dfi,
                                      std::source_location where) {
  InstanceSpec s;
  s.name = std::move(name);
  s.dfn = std::move(dfn);
  s.dfi = std::move(dfi);
  s.parameters_source = where.file_name();
  s.where[""] = SourceLocation::of(where);
  spec_.instances.push_back(std::move(s));
  return Node(*this, spec_.instances.size() - 1);
}

GraphBuilder& GraphBuilder::connect(const std::string& from, const std::string& to, int delay,
                                    std::source_location where) {
  spec_.connections.push_back(
      {PortRef::parse(from), PortRef::parse(to), delay, SourceLocation::of(where)});
  return *this;
}

GraphBuilder& GraphBuilder::trackState(const std::string& from, std::string initial,
                                       std::source_location where) {
  TrackStateSpec t;
  if (!from.empty()) t.from = PortRef::parse(from);
  t.initial = std::move(initial);
  t.at = SourceLocation::of(where);
  spec_.track_state = std::move(t);
  return *this;
}

InstanceSpec& GraphBuilder::Node::spec() {
  return builder_.spec_.instances[index_];
}

GraphBuilder::Node& GraphBuilder::Node::parameters(const std::string& yaml) {
  try {
    spec().parameters = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    builder_.spec_.build_errors.push_back(
        invalidParameter("{}instance '{}': parameters are not valid YAML: {}", spec().at().prefix(),
                         spec().name, e.msg));
  }
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::trigger(TriggerSpec trigger) {
  spec().trigger = std::move(trigger);
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::on(std::vector<std::string> ports) {
  spec().trigger.on = std::move(ports);
  spec().trigger.on_given = true;
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::every(double period_s, std::string time_input,
                                              std::string tick_when) {
  spec().trigger.period_s = period_s;
  spec().trigger.time_input = std::move(time_input);
  spec().trigger.tick_when = std::move(tick_when);
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::sync(SyncPolicy policy, double tolerance_s, int queue) {
  spec().trigger.sync = policy;
  spec().trigger.tolerance_s = tolerance_s;
  spec().trigger.queue = queue;
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::activeWhen(std::string condition) {
  spec().active_when = std::move(condition);
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::divergedWhen(std::string condition) {
  spec().diverged_when = std::move(condition);
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::budget(double seconds) {
  spec().budget_s = seconds;
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::fallback(std::string dfi,
                                                 const std::string& parameters_yaml) {
  FallbackSpec fb;
  fb.dfi = std::move(dfi);
  fb.at = spec().at();
  fb.parameters_source = spec().parameters_source;
  try {
    if (!parameters_yaml.empty()) fb.parameters = YAML::Load(parameters_yaml);
  } catch (const YAML::Exception& e) {
    builder_.spec_.build_errors.push_back(
        invalidParameter("{}instance '{}': fallback parameters are not valid YAML: {}",
                         spec().at().prefix(), spec().name, e.msg));
  }
  spec().fallback = std::move(fb);
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::onFault(FaultKind kind, std::vector<RecoveryAction> actions,
                                                int after) {
  RecoverySpec r;
  r.after = after;
  r.at = spec().at();
  r.actions = std::move(actions);
  for (auto& a : r.actions)
    if (a.at.file.empty()) a.at = r.at;
  spec().on_fault[kind] = std::move(r);
  return *this;
}

}  // namespace cdff::dfpc
