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

bool isIdentifier(const std::string& s) {
  if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0]))) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
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
        toString(g.track_state->initial), g.track_state->from.instance, g.track_state->from.port);
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
  spec_.inputs.push_back({std::move(name), std::move(type), std::move(channel), false, false,
                          SourceLocation::of(where)});
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
  spec_.build_errors.push_back(Status(StatusCode::kInvalidParameter,
                                      fmt::format("outputWatchdog: no DFPC output '{}'", output),
                                      spec_.at));
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

GraphBuilder& GraphBuilder::trackState(const std::string& from, TrackState initial,
                                       std::source_location where) {
  TrackStateSpec t;
  if (!from.empty()) t.from = PortRef::parse(from);
  t.initial = initial;
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
        Status(StatusCode::kInvalidParameter,
               fmt::format("instance '{}': parameters are not valid YAML: {}", spec().name, e.msg),
               spec().at()));
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
        Status(StatusCode::kInvalidParameter,
               fmt::format("instance '{}': fallback parameters are not valid YAML: {}", spec().name,
                           e.msg),
               spec().at()));
  }
  spec().fallback = std::move(fb);
  return *this;
}

GraphBuilder::Node& GraphBuilder::Node::onFault(FaultKind kind, std::vector<RecoveryAction> actions,
                                                int after, double within_s) {
  RecoverySpec r;
  r.after = after;
  r.within_s = within_s;
  r.at = spec().at();
  r.actions = std::move(actions);
  for (auto& a : r.actions)
    if (a.at.file.empty()) a.at = r.at;
  spec().on_fault[kind] = std::move(r);
  return *this;
}

}  // namespace cdff::dfpc
