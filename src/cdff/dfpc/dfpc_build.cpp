// Building a DFPC from its checked graph: the DFN instances in execution order, their ports
// wired to each other and to the DFPC's inputs and outputs, their triggers and conditions.
#include <algorithm>
#include <limits>
#include <map>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/dfn/registry.hpp"
#include "cdff/dfpc/dfpc.hpp"

namespace cdff::dfpc {

namespace {
constexpr std::size_t kNoIndex = std::numeric_limits<std::size_t>::max();
}  // namespace

Result<std::unique_ptr<Dfpc>> Dfpc::create(GraphSpec spec) {
  std::vector<Status> problems = checkGraph(spec);
  if (!problems.empty()) {
    std::vector<std::string> lines;
    for (const Status& s : problems) lines.push_back(s.message());
    return Status(problems.front().code(), fmt::format("{}", fmt::join(lines, "\n")));
  }
  std::unique_ptr<Dfpc> dfpc(new Dfpc(std::move(spec)));
  CDFF_RETURN_IF_ERROR(dfpc->build());
  return dfpc;
}

Status Dfpc::createNode(Instance& inst, const std::string& dfi, const YAML::Node& parameters,
                        const std::string& source, std::unique_ptr<dfn::Node>& out) const {
  Result<std::unique_ptr<dfn::Node>> node = dfn::Registry::instance().create(inst.spec->dfn, dfi);
  if (!node)
    return node.status().withContext("instance '" + inst.spec->name + "'").at(inst.spec->at());
  node.value()->setName(spec_.name + "." + inst.spec->name);
  Status configured = node.value()->configure(parameters, source);
  if (!configured)  // a parameter's own location (its line) stays first, else the instance's
    return configured
        .withContext(fmt::format("instance '{}' ({}/{})", inst.spec->name, inst.spec->dfn, dfi))
        .at(inst.spec->at("parameters"));
  out = std::move(node).value();
  return Status::ok();
}

Result<Dfpc::BoundCondition> Dfpc::bindCondition(const std::string& text,
                                                 const SourceLocation& at) const {
  Result<Condition> parsed = Condition::parse(text, at);
  if (!parsed) return parsed.status();
  BoundCondition b{std::move(parsed).value(), {}};
  std::vector<TypeId> types;
  for (const Condition::Ref& r : b.condition.refs()) {
    if (r.instance.empty()) {
      b.refs.emplace_back(-1, -1);
      types.push_back(TypeId::of<TrackState>());
      continue;
    }
    const std::size_t n = index_.at(r.instance);
    const dfn::Node& node = *instances_[n].node;
    const auto& outs = node.outputs();
    std::size_t o = 0;
    while (o < outs.size() && outs[o]->name() != r.port) ++o;
    if (o == outs.size())
      return Status(StatusCode::kNotFound, fmt::format("no output '{}'", r.text()), at);
    b.refs.emplace_back(static_cast<int>(n), static_cast<int>(o));
    types.push_back(outs[o]->type());
  }
  CDFF_RETURN_IF_ERROR(b.condition.bind(types, at));
  return b;
}

namespace {

std::size_t inputPortIndex(const dfn::Node& node, const std::string& port) {
  for (std::size_t i = 0; i < node.inputs().size(); ++i)
    if (node.inputs()[i]->name() == port) return i;
  return kNoIndex;
}

std::size_t outputPortIndex(const dfn::Node& node, const std::string& port) {
  for (std::size_t i = 0; i < node.outputs().size(); ++i)
    if (node.outputs()[i]->name() == port) return i;
  return kNoIndex;
}

}  // namespace

Status Dfpc::build() {
  Result<std::vector<std::size_t>> order = executionOrder();
  if (!order) return order.status();
  CDFF_RETURN_IF_ERROR(createInstances(*order));
  input_edges_.resize(spec_.inputs.size());
  for (const DfpcInputSpec& in : spec_.inputs) input_types_.push_back(findType(in.type));
  outputs_.resize(spec_.outputs.size());
  for (std::size_t o = 0; o < spec_.outputs.size(); ++o) {
    outputs_[o].type = findType(spec_.outputs[o].type);
    has_watchdog_ = has_watchdog_ || spec_.outputs[o].timeout_s > 0;
  }
  const std::vector<std::vector<bool>> fed_without_delay = connectPorts();
  configureTriggers(fed_without_delay);
  // Conditions last: they refer to instances by index.
  CDFF_RETURN_IF_ERROR(bindConditions());
  clearRuntime();
  first_pending_ = instances_.size();
  return Status::ok();
}

Result<std::vector<std::size_t>> Dfpc::executionOrder() const {
  // Topological order of the instances over connections without delay (stable: declaration
  // order among independent instances). checkGraph() has ruled out cycles.
  const std::size_t count = spec_.instances.size();
  std::map<std::string, std::size_t> declared;
  for (std::size_t i = 0; i < count; ++i) declared[spec_.instances[i].name] = i;
  std::vector<std::set<std::size_t>> successors(count);
  std::vector<int> indegree(count, 0);
  for (const ConnectionSpec& c : spec_.connections) {
    if (c.delay || c.from.isDfpcPort() || c.to.isDfpcPort()) continue;
    const std::size_t a = declared.at(c.from.instance), b = declared.at(c.to.instance);
    if (successors[a].insert(b).second) ++indegree[b];
  }
  std::vector<std::size_t> order;
  std::vector<bool> placed(count, false);
  while (order.size() < count) {
    std::size_t next = kNoIndex;
    for (std::size_t i = 0; i < count && next == kNoIndex; ++i)
      if (!placed[i] && indegree[i] == 0) next = i;
    if (next == kNoIndex) return Status(StatusCode::kInternal, "cycle left in a checked graph");
    placed[next] = true;
    order.push_back(next);
    for (std::size_t s : successors[next]) --indegree[s];
  }
  return order;
}

Status Dfpc::createInstances(const std::vector<std::size_t>& order) {
  instances_.resize(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    Instance& inst = instances_[k];
    inst.spec = &spec_.instances[order[k]];
    inst.dfi = inst.spec->dfi;
    index_[inst.spec->name] = k;
    CDFF_RETURN_IF_ERROR(
        createNode(inst, inst.dfi, inst.spec->parameters, inst.spec->parameters_source, inst.node));
    if (inst.spec->fallback) {  // configure the fallback once now, so its parameters are checked
      std::unique_ptr<dfn::Node> probe;
      CDFF_RETURN_IF_ERROR(createNode(inst, inst.spec->fallback->dfi,
                                      inst.spec->fallback->parameters,
                                      inst.spec->fallback->parameters_source, probe));
    }
    inst.inputs.resize(inst.node->inputs().size());
    inst.outputs.resize(inst.node->outputs().size());
    inst.before.resize(inst.node->outputs().size());
  }
  return Status::ok();
}

std::vector<std::vector<bool>> Dfpc::connectPorts() {
  std::vector<std::vector<bool>> fed_without_delay(instances_.size());
  for (std::size_t k = 0; k < instances_.size(); ++k)
    fed_without_delay[k].assign(instances_[k].inputs.size(), false);
  for (const ConnectionSpec& c : spec_.connections) {
    if (c.to.isDfpcPort()) {  // instance output -> DFPC output
      const std::size_t n = index_.at(c.from.instance);
      const std::size_t o = outputPortIndex(*instances_[n].node, c.from.port);
      for (std::size_t d = 0; d < spec_.outputs.size(); ++d)
        if (spec_.outputs[d].name == c.to.port) instances_[n].outputs[o].dfpc_outputs.push_back(d);
      continue;
    }
    const std::size_t target = index_.at(c.to.instance);
    const Edge edge{target, inputPortIndex(*instances_[target].node, c.to.port), c.delay > 0};
    if (!edge.delayed) fed_without_delay[target][edge.input] = true;
    if (c.from.isDfpcPort()) {
      for (std::size_t i = 0; i < spec_.inputs.size(); ++i)
        if (spec_.inputs[i].name == c.from.port) input_edges_[i].push_back(edge);
    } else {
      const std::size_t n = index_.at(c.from.instance);
      instances_[n].outputs[outputPortIndex(*instances_[n].node, c.from.port)].edges.push_back(
          edge);
    }
  }
  if (spec_.track_state && !spec_.track_state->from.port.empty()) {
    const std::size_t n = index_.at(spec_.track_state->from.instance);
    const std::size_t o = outputPortIndex(*instances_[n].node, spec_.track_state->from.port);
    instances_[n].outputs[o].feeds_track_state = true;
    track_state_source_ = std::make_pair(n, o);
  }
  return fed_without_delay;
}

void Dfpc::configureTriggers(const std::vector<std::vector<bool>>& fed_without_delay) {
  for (std::size_t k = 0; k < instances_.size(); ++k) {
    Instance& inst = instances_[k];
    const TriggerSpec& t = inst.spec->trigger;
    for (std::size_t i = 0; i < inst.inputs.size(); ++i) {
      const std::string& port = inst.node->inputs()[i]->name();
      inst.inputs[i].trigger = t.on_given ? std::count(t.on.begin(), t.on.end(), port) > 0
                                          : static_cast<bool>(fed_without_delay[k][i]);
    }
    if (t.sync != SyncPolicy::kNone) {
      has_sync_ = true;
      for (const std::string& port : t.on) {
        const std::size_t i = inputPortIndex(*inst.node, port);
        inst.inputs[i].sync = static_cast<int>(inst.sync_inputs.size());
        inst.sync_inputs.push_back(i);
      }
      inst.queues.resize(inst.sync_inputs.size());
      inst.tolerance = t.sync == SyncPolicy::kNearest ? fromSeconds(t.tolerance_s) : 0;
      inst.queue_limit = static_cast<std::size_t>(t.queue);
    }
    if (t.period_s > 0) {
      has_periodic_ = true;
      inst.period = std::max<Timestamp>(fromSeconds(t.period_s), 1);
      if (!t.time_input.empty())
        inst.time_input = static_cast<int>(inputPortIndex(*inst.node, t.time_input));
    }
  }
}

Status Dfpc::bindConditions() {
  for (Instance& inst : instances_) {
    auto bind = [&](const std::string& text, const char* field,
                    std::optional<BoundCondition>& out) -> Status {
      if (text.empty()) return Status::ok();
      Result<BoundCondition> b = bindCondition(text, inst.spec->at(field));
      if (!b) return b.status();
      out = std::move(b).value();
      return Status::ok();
    };
    CDFF_RETURN_IF_ERROR(bind(inst.spec->active_when, "active_when", inst.active_when));
    CDFF_RETURN_IF_ERROR(bind(inst.spec->diverged_when, "diverged_when", inst.diverged_when));
    CDFF_RETURN_IF_ERROR(bind(inst.spec->trigger.tick_when, "tick_when", inst.tick_when));
  }
  return Status::ok();
}

}  // namespace cdff::dfpc
