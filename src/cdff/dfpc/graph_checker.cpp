// checkGraph(): what a DFPC graph means, checked before anything runs (graph.hpp).
#include <algorithm>
#include <functional>
#include <map>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/dfn/registry.hpp"
#include "cdff/dfpc/condition.hpp"
#include "cdff/dfpc/graph.hpp"
#include "cdff/types/type_registry.hpp"

namespace cdff::dfpc {

namespace {

std::string trackStateNames() {
  return "{" + joinTrackStates(allTrackStates(), ", ") + "}";
}

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
    errors_.push_back(Status(StatusCode::kInvalidParameter,
                             fmt::format(format, std::forward<Args>(args)...), at));
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
      if (!findType(in.type))
        error(in.at, "DFPC input '{}': unknown type '{}'; expected one of {}", in.name, in.type,
              typeNames());
      if (in.channel.empty()) error(in.at, "DFPC input '{}' has no channel", in.name);
    }
    for (const auto& out : g_.outputs) {
      if (!names.insert(out.name).second)
        error(out.at, "DFPC port '{}' is declared twice", out.name);
      if (!isIdentifier(out.name))
        error(out.at, "DFPC output name '{}' must be an identifier", out.name);
      if (!findType(out.type))
        error(out.at, "DFPC output '{}': unknown type '{}'; expected one of {}", out.name, out.type,
              typeNames());
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
      // Goals are measured against the truth pose (cdff eval's products).
      static const std::set<std::string> poses = {"RigidBodyState", "PoseWithCovariance",
                                                  "Transform"};
      if (!out.goals.empty() && !poses.count(out.type))
        error(out.goals.front().at,
              "DFPC output '{}' has goals but type {}; expected a pose (RigidBodyState, "
              "PoseWithCovariance or Transform)",
              out.name, out.type);
      checkRecovery(out.on_timeout, nullptr);
    }
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
      if (a.kind == RecoveryActionKind::kSetTrackState) {
        if (!parseTrackState(a.argument))
          error(a.at, "set_track_state: '{}' is not a track state; expected one of {}", a.argument,
                trackStateNames());
        continue;
      }
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
      // An unknown type has its own error; a mismatch with it would only repeat it.
      if (!from.empty() && !to.empty() && from != to && findType(from) && findType(to))
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
  Result<TypeId> refType(const Condition::Ref& r) const {
    if (r.instance.empty()) return TypeId::of<TrackState>();
    if (!g_.findInstance(r.instance))
      return notFound("'{}' names unknown instance '{}'", r.text(), r.instance);
    const dfn::DfnDescription* d = description(r.instance);
    if (!d) return notFound("'{}': the DFN of '{}' is unknown", r.text(), r.instance);
    const dfn::PortSpec* p = findSpec(d->outputs, r.port);
    if (!p)
      return notFound("'{}': {} has no output '{}'; expected one of {}", r.text(), d->name, r.port,
                      portNames(d->outputs));
    return findType(p->type);
  }

  void checkCondition(const std::string& text, const SourceLocation& at) {
    if (text.empty()) return;
    Result<Condition> c = Condition::parse(text, at);
    if (!c) {
      errors_.push_back(c.status());
      return;
    }
    std::vector<TypeId> types;
    for (const auto& r : c->refs()) {
      Result<TypeId> t = refType(r);
      if (!t) {
        error(at, "condition '{}': {}", text, t.status().message());
        return;
      }
      types.push_back(*t);
    }
    Status bound = c->bind(types, at);
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
      Result<TypeId> t = from.isDfpcPort() ? Result<TypeId>(notFound("expected instance.port"))
                                           : refType({from.instance, from.port});
      if (!t)
        error(g_.track_state->at, "track_state.from '{}': {}", from.toString(),
              t.status().message());
      else if (*t != TypeId::of<TrackState>())
        error(g_.track_state->at, "track_state.from '{}' has type {}; expected TrackState",
              from.toString(), t->name());
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

}  // namespace cdff::dfpc
