#include "cdff/dfpc/dfpc.hpp"

#include <algorithm>
#include <limits>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/dfn/registry.hpp"

namespace cdff::dfpc {

namespace {
constexpr std::size_t kNoMessage = std::numeric_limits<std::size_t>::max();

std::size_t faultIndex(FaultKind kind) {
  return static_cast<std::size_t>(kind);
}

EventType eventOf(FaultKind kind) {
  switch (kind) {
    case FaultKind::kError:
      return EventType::kDfnError;
    case FaultKind::kOverBudget:
      return EventType::kOverBudget;
    case FaultKind::kDivergence:
      return EventType::kDivergence;
    case FaultKind::kNoProduct:
      return EventType::kNoProduct;
  }
  return EventType::kDfnError;
}
}  // namespace

const char* toString(DfpcState state) {
  switch (state) {
    case DfpcState::kInitialised:
      return "initialised";
    case DfpcState::kRunning:
      return "running";
    case DfpcState::kStopped:
      return "stopped";
  }
  return "?";
}

Dfpc::Dfpc(GraphSpec spec) : spec_(std::move(spec)) {}
Dfpc::~Dfpc() = default;

void Dfpc::clearRuntime() {
  for (Instance& inst : instances_) {
    for (auto& q : inst.queues) q.clear();
    inst.sync_loaded = false;
    inst.pending = false;
    inst.woken = false;
    inst.active = true;
    inst.consecutive = {};
    for (auto& r : inst.recent) r.clear();
    inst.warnings_seen = 0;
    inst.faults = inst.skipped = inst.sync_dropped = 0;
  }
  first_pending_ = instances_.size();
  delayed_.clear();
  delayed_next_.clear();
  started_ = false;
  track_state_ = spec_.track_state ? spec_.track_state->initial : TrackState::kUninitialised;
  last_product_.reset();
  messages_ = ignored_ = products_ = faults_ = recoveries_ = 0;
  last_fault_.clear();
}

// ---------------------------------------------------------------------------------------------
// Life cycle

Status Dfpc::init() {
  if (state_ == DfpcState::kRunning)
    return invalidInput("DFPC '{}' is running; stop it before initialising it", name());
  for (Instance& inst : instances_) {
    std::unique_ptr<dfn::Node> fresh;
    CDFF_RETURN_IF_ERROR(createNode(inst, inst.spec->dfi, inst.spec->parameters,
                                    inst.spec->parameters_source, fresh));
    inst.node = std::move(fresh);
    inst.dfi = inst.spec->dfi;
    inst.on_fallback = false;
  }
  clearRuntime();
  state_ = DfpcState::kInitialised;
  emit(EventType::kInitialised, "",
       fmt::format("{} instances created and configured", instances_.size()));
  return Status::ok();
}

Status Dfpc::start(std::optional<Timestamp> now) {
  if (state_ == DfpcState::kRunning) return invalidInput("DFPC '{}' is already running", name());
  state_ = DfpcState::kRunning;
  if (now && *now > step_stamp_) step_stamp_ = *now;
  // Periodic triggers and watchdogs start again from the next stream time: the time spent
  // stopped is neither ticked through nor a silence.
  started_ = false;
  emit(EventType::kStarted, "", "");
  // The configurations that came while it was not running, delivered at the start's time (the
  // values keep their own stamps): stream time does not go back to when they came.
  std::vector<std::optional<Message>> latched = std::move(latched_);
  latched_.clear();
  for (std::size_t i = 0; i < latched.size(); ++i) {
    if (!latched[i]) continue;
    latched[i]->stamp = step_stamp_;
    CDFF_RETURN_IF_ERROR(deliver(i, *latched[i]));
  }
  return Status::ok();
}

Status Dfpc::stop() {
  if (state_ != DfpcState::kRunning)
    return invalidInput("DFPC '{}' is {}; expected running", name(), toString(state_));
  state_ = DfpcState::kStopped;
  emit(EventType::kStopped, "", "");
  return Status::ok();
}

Status Dfpc::reset() {
  const bool was_running = state_ == DfpcState::kRunning;
  state_ = DfpcState::kStopped;
  Status s = init();
  if (!s) return s;
  emit(EventType::kReset, "", "");
  if (was_running) state_ = DfpcState::kRunning;
  return Status::ok();
}

// ---------------------------------------------------------------------------------------------
// Steps

std::optional<std::size_t> Dfpc::inputIndex(const std::string& input) const {
  for (std::size_t i = 0; i < spec_.inputs.size(); ++i)
    if (spec_.inputs[i].name == input) return i;
  return std::nullopt;
}

void Dfpc::beginStep(Timestamp t) {
  step_stamp_ = t;
  if (delayed_.empty()) return;
  delayed_next_.swap(delayed_);  // values delayed during this step wait for the next one
  for (const DelayedValue& d : delayed_next_) writeInput(d.edge, d.value, d.stamp);
  delayed_next_.clear();
}

Status Dfpc::deliver(std::size_t input, const Message& message) {
  if (input >= input_edges_.size()) return notFound("DFPC '{}' has no input #{}", name(), input);
  if (state_ != DfpcState::kRunning) {
    ++ignored_;
    if (spec_.inputs[input].latched && message.type() == input_types_[input]) {
      latched_.resize(spec_.inputs.size());
      latched_[input] = message;
    }
    return Status::ok();
  }
  if (message.type() != input_types_[input] || message.value.empty()) {
    Status s = invalidInput(
        "DFPC '{}' input '{}' (channel {}) takes {}; got {} at t = {} us", name(),
        spec_.inputs[input].name, message.channel, input_types_[input].name(),
        message.value.empty() ? "an empty message" : message.type().name(), message.stamp);
    emit(EventType::kInputRejected, "", s.message());
    return s;
  }
  advanceTo(message.stamp);
  beginStep(message.stamp);
  ++messages_;
  for (const Edge& e : input_edges_[input]) writeInput(e, message.value, message.stamp);
  runPending();
  return Status::ok();
}

void Dfpc::writeInput(const Edge& e, const Value& value, Timestamp stamp) {
  Instance& inst = instances_[e.node];
  const InputSlot& slot = inst.inputs[e.input];
  if (slot.sync >= 0) {
    pushSync(e.node, slot.sync, value, stamp);
    return;
  }
  dfn::InputPortBase& port = *inst.node->inputs()[e.input];
  (void)port.setAny(value);  // types were checked when the graph was built
  if (slot.trigger) markPending(e.node, step_stamp_);
}

void Dfpc::markPending(std::size_t n, Timestamp stamp) {
  instances_[n].pending = true;
  instances_[n].pending_stamp = stamp;
  first_pending_ = std::min(first_pending_, n);
}

void Dfpc::runPending() {
  const std::size_t count = instances_.size();
  for (;;) {
    std::size_t n = first_pending_;
    while (n < count && !instances_[n].pending) ++n;
    if (n >= count) {
      first_pending_ = count;
      return;
    }
    first_pending_ = n + 1;  // markPending() lowers it again for a new match of the same node
    instances_[n].pending = false;
    runNode(n);
    if (!instances_[n].queues.empty()) {
      instances_[n].sync_loaded = false;
      trySync(n, step_stamp_, false);
    }
  }
}

bool Dfpc::evaluate(const BoundCondition& c) const {
  return c.condition.evaluate([&](std::size_t ref) -> const void* {
    const auto [n, o] = c.refs[ref];
    if (n < 0) return &track_state_;
    return instances_[static_cast<std::size_t>(n)]
        .node->outputs()[static_cast<std::size_t>(o)]
        ->anyValue()
        .raw();
  });
}

void Dfpc::runNode(std::size_t n) {
  Instance& inst = instances_[n];
  dfn::Node& node = *inst.node;
  const Timestamp stamp = inst.pending_stamp;
  if (!updateActivation(inst)) {
    for (dfn::InputPortBase* in : node.inputs()) in->markConsumed();
    ++inst.skipped;
    return;
  }

  const auto& outs = node.outputs();
  for (std::size_t o = 0; o < outs.size(); ++o) inst.before[o] = outs[o]->anyValue().raw();
  const Timestamp t0 = execution_clock_ ? execution_clock_->now() : 0;
  const Status status = node.process();
  const dfn::Diagnostics& d = node.diagnostics();
  const double wall = execution_clock_ ? toSeconds(execution_clock_->now() - t0) : d.last_wall_s;
  reportRun(inst, stamp, wall, status.code());

  auto recoveryFor = [&](FaultKind kind) -> const RecoverySpec* {
    auto it = inst.spec->on_fault.find(kind);
    return it == inst.spec->on_fault.end() ? nullptr : &it->second;
  };
  if (!status) {
    fault(n, FaultKind::kError, status.message(), recoveryFor(FaultKind::kError));
    return;
  }
  if (inst.diverged_when && evaluate(*inst.diverged_when)) {
    // A diverged result is not passed on: its consumers keep the last sound value.
    fault(n, FaultKind::kDivergence,
          fmt::format("divergence condition '{}' holds", inst.spec->diverged_when),
          recoveryFor(FaultKind::kDivergence));
    return;
  }
  inst.woken = false;  // a woken instance has done its run; its condition governs again
  passOutputs(inst, stamp);
  if (inst.spec->budget_s > 0 && wall > inst.spec->budget_s) {
    fault(
        n, FaultKind::kOverBudget,
        fmt::format("call took {:.3f} ms; budget {:.3f} ms", wall * 1e3, inst.spec->budget_s * 1e3),
        recoveryFor(FaultKind::kOverBudget));
    return;
  }
  inst.consecutive = {};
}

bool Dfpc::updateActivation(Instance& inst) {
  if (!inst.active_when) return true;
  const bool active = inst.woken || evaluate(*inst.active_when);
  if (active != inst.active) {
    inst.active = active;
    emit(active ? EventType::kActivated : EventType::kDeactivated, inst.spec->name,
         fmt::format("{} '{}'",
                     active ? (inst.woken ? "woken" : "condition holds")
                            : "asleep: condition does not hold",
                     inst.spec->active_when));
  }
  return active;
}

void Dfpc::reportRun(Instance& inst, Timestamp stamp, double wall, StatusCode code) {
  const dfn::Diagnostics& d = inst.node->diagnostics();
  if (timing_enabled_ && observer_)
    observer_->onTiming(
        {stamp, spec_.name, inst.spec->name, inst.spec->dfn, inst.dfi, wall, d.last_cpu_s, code});
  if (d.warning_count != inst.warnings_seen) {
    const std::uint64_t fresh = d.warning_count - inst.warnings_seen;
    const std::size_t kept = d.warnings.size();
    for (std::size_t i = kept - std::min<std::size_t>(kept, fresh); i < kept; ++i)
      emit(EventType::kDfnWarning, inst.spec->name, d.warnings[i]);
    inst.warnings_seen = d.warning_count;
  }
}

void Dfpc::passOutputs(Instance& inst, Timestamp stamp) {
  const auto& outs = inst.node->outputs();
  for (std::size_t o = 0; o < outs.size(); ++o) {
    const Value& value = outs[o]->anyValue();
    if (value.raw() == inst.before[o] || value.empty()) continue;
    const OutputSlot& slot = inst.outputs[o];
    for (const Edge& e : slot.edges) {
      if (e.delayed)
        delayed_.push_back({e, value, stamp});
      else
        writeInput(e, value, stamp);
    }
    for (std::size_t dfpc_output : slot.dfpc_outputs) {
      ++products_;
      last_product_ = stamp;
      outputs_[dfpc_output].watch_since = stamp;
      if (observer_) observer_->onProduct(*this, dfpc_output, stamp, value);
    }
    if (slot.feeds_track_state) setTrackState(*value.get<TrackState>());
  }
}

// ---------------------------------------------------------------------------------------------
// Synchronisation

void Dfpc::dropSync(std::size_t n, int queue, Timestamp stamp, const char* why) {
  Instance& inst = instances_[n];
  ++inst.sync_dropped;
  emit(EventType::kSyncDropped, inst.spec->name,
       fmt::format("input '{}': message at t = {} us dropped ({})",
                   inst.node->inputs()[inst.sync_inputs[static_cast<std::size_t>(queue)]]->name(),
                   stamp, why));
}

void Dfpc::pushSync(std::size_t n, int queue, const Value& value, Timestamp stamp) {
  Instance& inst = instances_[n];
  auto& q = inst.queues[static_cast<std::size_t>(queue)];
  auto pos = std::upper_bound(q.begin(), q.end(), stamp,
                              [](Timestamp t, const SyncEntry& e) { return t < e.stamp; });
  q.insert(pos, {stamp, value});
  if (q.size() > inst.queue_limit) {
    dropSync(n, queue, q.front().stamp, "queue full");
    q.pop_front();
  }
  trySync(n, step_stamp_, false);
}

void Dfpc::trySync(std::size_t n, Timestamp now, bool final) {
  Instance& inst = instances_[n];
  if (inst.sync_loaded) return;  // the previous match has not run yet
  auto& pivot = inst.queues[0];
  while (!pivot.empty()) {
    const Timestamp p = pivot.front().stamp;
    // Pivots come in non-decreasing order: what is older than p - tolerance can match none.
    for (std::size_t k = 1; k < inst.queues.size(); ++k) {
      auto& q = inst.queues[k];
      while (!q.empty() && q.front().stamp < p - inst.tolerance) {
        dropSync(n, static_cast<int>(k), q.front().stamp, "no partner within the tolerance");
        q.pop_front();
      }
    }
    // A better partner may still come for a queue without an entry at or after p, until stream
    // time has passed p + tolerance (messages arrive in timestamp order).
    const bool time_passed = final || now > p + inst.tolerance;
    for (std::size_t k = 1; k < inst.queues.size(); ++k) {
      const auto& q = inst.queues[k];
      if ((q.empty() || q.back().stamp < p) && !time_passed) return;
    }
    std::vector<std::size_t> best(inst.queues.size(), kNoMessage);
    bool complete = true;
    for (std::size_t k = 1; k < inst.queues.size(); ++k) {
      const auto& q = inst.queues[k];
      Timestamp best_gap = std::numeric_limits<Timestamp>::max();
      for (std::size_t i = 0; i < q.size(); ++i) {
        const Timestamp gap = std::abs(q[i].stamp - p);
        if (gap <= inst.tolerance && gap < best_gap) {
          best_gap = gap;
          best[k] = i;
        }
      }
      complete = complete && best[k] != kNoMessage;
    }
    if (!complete) {
      dropSync(
          n, 0, p,
          inst.tolerance ? "no partner within the tolerance" : "no partner with the same stamp");
      pivot.pop_front();
      continue;
    }
    dfn::Node& node = *inst.node;
    (void)node.inputs()[inst.sync_inputs[0]]->setAny(pivot.front().value);
    pivot.pop_front();
    for (std::size_t k = 1; k < inst.queues.size(); ++k) {
      auto& q = inst.queues[k];
      for (std::size_t i = 0; i < best[k]; ++i)
        dropSync(n, static_cast<int>(k), q[i].stamp, "older than the matched message");
      dfn::InputPortBase& port = *node.inputs()[inst.sync_inputs[k]];
      (void)port.setAny(q[best[k]].value);
      q.erase(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(best[k]) + 1);
    }
    inst.sync_loaded = true;
    markPending(n, p);
    return;
  }
}

void Dfpc::advanceTo(Timestamp t) {
  if (state_ != DfpcState::kRunning) return;
  if (!started_) {
    started_ = true;
    for (Instance& inst : instances_) inst.next_tick = t;
    for (OutputState& o : outputs_) o.watch_since = t;
  }
  if (t < stream_time_) t = stream_time_;  // stream time never goes back
  if (has_periodic_) {
    for (;;) {
      Timestamp tick = std::numeric_limits<Timestamp>::max();
      for (const Instance& inst : instances_)
        if (inst.period > 0) tick = std::min(tick, inst.next_tick);
      if (tick > t) break;
      beginStep(tick);
      for (std::size_t n = 0; n < instances_.size(); ++n) {
        Instance& inst = instances_[n];
        if (inst.period == 0 || inst.next_tick != tick) continue;
        inst.next_tick += inst.period;
        if (inst.tick_when && !evaluate(*inst.tick_when)) continue;
        if (inst.time_input >= 0) {
          dfn::InputPortBase& port =
              *inst.node->inputs()[static_cast<std::size_t>(inst.time_input)];
          (void)port.setAny(Value::of<Timestamp>(tick));
        }
        markPending(n, tick);
      }
      runPending();
    }
  }
  stream_time_ = t;
  step_stamp_ = t;
  if (has_sync_) {
    for (std::size_t n = 0; n < instances_.size(); ++n)
      if (!instances_[n].queues.empty()) trySync(n, t, false);
    runPending();
  }
  if (has_watchdog_) {
    for (std::size_t o = 0; o < outputs_.size(); ++o) {
      const DfpcOutputSpec& out = spec_.outputs[o];
      if (out.timeout_s <= 0) continue;
      const Timestamp silent = t - outputs_[o].watch_since;
      if (silent <= fromSeconds(out.timeout_s)) continue;
      outputs_[o].watch_since = t;  // re-armed: the next fault after another timeout
      fault(std::nullopt, FaultKind::kNoProduct,
            fmt::format("output '{}' produced nothing for {:.3f} s (timeout {} s)", out.name,
                        toSeconds(silent), out.timeout_s),
            out.on_timeout.actions.empty() ? nullptr : &out.on_timeout);
    }
  }
}

void Dfpc::finish() {
  if (state_ != DfpcState::kRunning || !has_sync_) return;
  for (std::size_t n = 0; n < instances_.size(); ++n) {
    while (!instances_[n].queues.empty() && !instances_[n].queues[0].empty()) {
      instances_[n].sync_loaded = false;
      trySync(n, stream_time_, true);
      if (!instances_[n].pending) break;
      runPending();
    }
    auto& queues = instances_[n].queues;
    for (std::size_t k = 0; k < queues.size(); ++k) {
      for (const SyncEntry& e : queues[k])
        dropSync(n, static_cast<int>(k), e.stamp, "unmatched at the end of the stream");
      queues[k].clear();
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Faults and recovery

void Dfpc::fault(std::optional<std::size_t> n, FaultKind kind, const std::string& message,
                 const RecoverySpec* recovery) {
  ++faults_;
  const std::string instance = n ? instances_[*n].spec->name : "";
  last_fault_ = fmt::format("{} at t = {} us{}: {}", toString(kind), step_stamp_,
                            instance.empty() ? "" : " in " + instance, message);
  emit(eventOf(kind), instance, message);
  if (n) ++instances_[*n].faults;
  if (!recovery) return;
  if (n) {
    Instance& inst = instances_[*n];
    if (recovery->within_s > 0) {
      std::deque<Timestamp>& recent = inst.recent[faultIndex(kind)];
      recent.push_back(step_stamp_);
      while (recent.front() < step_stamp_ - fromSeconds(recovery->within_s)) recent.pop_front();
      if (static_cast<int>(recent.size()) < recovery->after) return;
      recent.clear();
    } else {
      int& consecutive = inst.consecutive[faultIndex(kind)];
      if (++consecutive < recovery->after) return;
      consecutive = 0;
    }
  }
  recover(*recovery, n);
}

void Dfpc::recover(const RecoverySpec& recovery, std::optional<std::size_t> faulty) {
  for (const RecoveryAction& a : recovery.actions) {
    ++recoveries_;
    if (a.kind == RecoveryActionKind::kSetTrackState) {
      emit(EventType::kSetTrackState, faulty ? instances_[*faulty].spec->name : "", a.argument);
      setTrackState(parseTrackState(a.argument).value_or(track_state_));  // checkGraph checked it
      continue;
    }
    const std::size_t target = a.argument.empty() ? *faulty : index_.at(a.argument);
    Instance& inst = instances_[target];
    std::string why;
    switch (a.kind) {
      case RecoveryActionKind::kReinitialise:
        if (recreate(target, inst.on_fallback, why))
          emit(EventType::kReinitialise, inst.spec->name,
               fmt::format("re-created {}/{} and re-configured it", inst.spec->dfn, inst.dfi));
        else
          emit(EventType::kRecoveryFailed, inst.spec->name, "reinitialise: " + why);
        break;
      case RecoveryActionKind::kSwitchDfi:
        if (inst.on_fallback) {
          emit(EventType::kRecoveryFailed, inst.spec->name,
               fmt::format("switch_dfi: already on its fallback {}", inst.dfi));
        } else {
          const std::string from = inst.dfi;
          if (recreate(target, true, why))
            emit(EventType::kSwitchDfi, inst.spec->name,
                 fmt::format("{}/{} -> {}/{}", inst.spec->dfn, from, inst.spec->dfn, inst.dfi));
          else
            emit(EventType::kRecoveryFailed, inst.spec->name, "switch_dfi: " + why);
        }
        break;
      case RecoveryActionKind::kWake:
        inst.woken = true;
        emit(EventType::kWake, inst.spec->name, "woken until it completes a run");
        break;
      case RecoveryActionKind::kSetTrackState:
        break;
    }
  }
}

bool Dfpc::recreate(std::size_t n, bool fallback, std::string& why) {
  Instance& inst = instances_[n];
  const std::string& dfi = fallback ? inst.spec->fallback->dfi : inst.spec->dfi;
  const YAML::Node& parameters = fallback ? inst.spec->fallback->parameters : inst.spec->parameters;
  const std::string& source =
      fallback ? inst.spec->fallback->parameters_source : inst.spec->parameters_source;
  std::unique_ptr<dfn::Node> fresh;
  Status s = createNode(inst, dfi, parameters, source, fresh);
  if (!s) {
    why = s.message();
    return false;
  }
  // The new instance sees the inputs the old one had (not as fresh: nothing new arrived).
  for (std::size_t i = 0; i < fresh->inputs().size(); ++i) {
    const Value& value = inst.node->inputs()[i]->anyValue();
    if (value.empty()) continue;
    (void)fresh->inputs()[i]->setAny(value);
    fresh->inputs()[i]->markConsumed();
  }
  inst.node = std::move(fresh);
  inst.dfi = dfi;
  inst.on_fallback = fallback;
  inst.consecutive = {};
  for (auto& r : inst.recent) r.clear();
  inst.warnings_seen = 0;
  for (auto& q : inst.queues) q.clear();
  inst.sync_loaded = false;
  inst.pending = false;
  return true;
}

void Dfpc::setTrackState(TrackState value) {
  if (value == track_state_) return;
  emit(EventType::kTrackStateChanged, "",
       fmt::format("{} -> {}", toString(track_state_), toString(value)));
  track_state_ = value;
}

void Dfpc::emit(EventType type, const std::string& instance, std::string message) {
  if (!observer_) return;
  observer_->onEvent({step_stamp_, type, spec_.name, instance, std::move(message)});
}

// ---------------------------------------------------------------------------------------------
// Status

DfpcStatus Dfpc::status() const {
  DfpcStatus s;
  s.name = spec_.name;
  s.state = state_;
  // A DFPC that declares no track state has none to report (not a permanent UNINITIALISED).
  if (spec_.track_state) s.track_state = track_state_;
  s.stream_time = stream_time_;
  s.last_product = last_product_;
  s.messages = messages_;
  s.ignored_messages = ignored_;
  s.products = products_;
  s.faults = faults_;
  s.recoveries = recoveries_;
  s.last_fault = last_fault_;
  for (const Instance& inst : instances_) {
    const dfn::Diagnostics& d = inst.node->diagnostics();
    InstanceStatus i;
    i.name = inst.spec->name;
    i.dfn = inst.spec->dfn;
    i.dfi = inst.dfi;
    i.active = inst.active;
    i.on_fallback = inst.on_fallback;
    i.calls = d.call_count;
    i.errors = d.error_count;
    i.faults = inst.faults;
    i.skipped = inst.skipped;
    i.sync_dropped = inst.sync_dropped;
    i.mean_wall_s = d.meanWallSeconds();
    i.max_wall_s = d.max_wall_s;
    i.last_error = d.last_error;
    s.instances.push_back(std::move(i));
  }
  return s;
}

dfn::Node* Dfpc::instance(const std::string& name) const {
  auto it = index_.find(name);
  return it == index_.end() ? nullptr : instances_[it->second].node.get();
}

}  // namespace cdff::dfpc
