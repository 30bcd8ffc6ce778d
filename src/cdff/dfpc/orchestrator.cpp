#include "cdff/dfpc/orchestrator.hpp"

#include <fnmatch.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace cdff::dfpc {

bool matchesChannelPattern(const std::string& channel, const std::string& pattern) {
  if (pattern.find_first_of("*?[") == std::string::npos) return channel.rfind(pattern, 0) == 0;
  return fnmatch(pattern.c_str(), channel.c_str(), 0) == 0;
}

double RunProgress::fraction() const {
  if (!range) return -1.0;
  const auto [first, last] = *range;
  if (last <= first) return 1.0;
  return std::clamp(static_cast<double>(stamp - first) / static_cast<double>(last - first), 0.0,
                    1.0);
}

namespace {

constexpr const char* kRuleForms =
    "expected DFPC=TRACKER:STATE[,STATE...] (e.g. detection=visual_tracking:UNINITIALISED,LOST) "
    "or DFPC: CONDITION (e.g. 'visual_tracking: lidar_tracking.track_state == TRACKING and "
    "lidar_tracking.range < 5')";

std::string trimmed(const std::string& text) {
  const std::size_t first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

Result<ActivationRule> parseConditionRule(const std::string& text, std::size_t colon) {
  ActivationRule rule;
  rule.dfpc = trimmed(text.substr(0, colon));
  rule.condition = trimmed(text.substr(colon + 1));
  if (rule.dfpc.empty() || rule.condition.empty())
    return invalidParameter("run-while rule '{}': {} is empty; {}", text,
                            rule.dfpc.empty() ? "the DFPC's name" : "the condition", kRuleForms);
  Result<Condition> parsed = Condition::parse(rule.condition, {});
  if (!parsed) return invalidParameter("run-while rule '{}': {}", text, parsed.status().message());
  return rule;
}

}  // namespace

Result<ActivationRule> parseActivationRule(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return invalidParameter("run-while rule '{}': {}; {}", text, why, kRuleForms);
  };
  const std::size_t eq = text.find('=');
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos) return bad("no ':'");
  if (eq == std::string::npos || eq > colon) return parseConditionRule(text, colon);
  ActivationRule rule;
  rule.dfpc = text.substr(0, eq);
  rule.tracker = text.substr(eq + 1, colon - eq - 1);
  if (rule.dfpc.empty() || rule.tracker.empty()) return bad("a DFPC name is empty");
  std::string states = text.substr(colon + 1);
  for (std::size_t start = 0; start <= states.size();) {
    const std::size_t end = std::min(states.find(',', start), states.size());
    const std::string name = states.substr(start, end - start);
    const std::optional<TrackState> state = parseTrackState(name);
    if (!state)
      return bad(fmt::format("'{}' is not a track state ({})", name,
                             joinTrackStates(allTrackStates(), ", ")));
    rule.states.push_back(*state);
    start = end + 1;
  }
  return rule;
}

Orchestrator::Orchestrator(OrchestratorOptions options)
    : options_(std::move(options)), products_(options_.products) {
  if (!products_) products_ = std::make_shared<DataProductManager>();
}

Orchestrator::~Orchestrator() = default;

std::string Orchestrator::productName(const std::string& dfpc, const std::string& output) {
  return dfpc + "/" + output;
}

Orchestrator::Entry* Orchestrator::find(const std::string& dfpc) {
  for (Entry& e : entries_)
    if (e.dfpc->name() == dfpc) return &e;
  return nullptr;
}

const Orchestrator::Entry* Orchestrator::find(const std::string& dfpc) const {
  for (const Entry& e : entries_)
    if (e.dfpc->name() == dfpc) return &e;
  return nullptr;
}

Status Orchestrator::unknown(const std::string& dfpc) const {
  std::vector<std::string> names;
  for (const Entry& e : entries_) names.push_back(e.dfpc->name());
  return notFound("no DFPC '{}'; expected one of {{{}}}", dfpc, fmt::join(names, ", "));
}

Status Orchestrator::add(std::unique_ptr<Dfpc> dfpc) {
  if (!dfpc) return invalidInput("no DFPC to add");
  std::lock_guard lock(mutex_);
  if (find(dfpc->name())) return invalidInput("a DFPC named '{}' is already loaded", dfpc->name());
  Entry entry;
  for (const DfpcOutputSpec& out : dfpc->spec().outputs) {
    OutputBinding b;
    b.product = productName(dfpc->name(), out.name);
    b.message.channel = dfpc->spec().outputChannel(out);
    if (out.history > 0) CDFF_RETURN_IF_ERROR(products_->setHistoryLimit(b.product, out.history));
    entry.outputs.push_back(std::move(b));
  }
  dfpc->setObserver(this);
  dfpc->setExecutionClock(options_.execution_clock);
  dfpc->setTimingEnabled(options_.record_timing && options_.sink != nullptr);
  entry.dfpc = std::move(dfpc);
  entries_.push_back(std::move(entry));
  rebuildRoutes();
  return Status::ok();
}

Status Orchestrator::addGraphFile(const std::string& path) {
  Result<GraphSpec> spec = loadGraphFile(path);
  if (!spec) return spec.status();
  Result<std::unique_ptr<Dfpc>> dfpc = Dfpc::create(std::move(spec).value());
  if (!dfpc) return dfpc.status();
  return add(std::move(dfpc).value());
}

void Orchestrator::rebuildRoutes() {
  routes_.clear();
  for (Entry& e : entries_)
    for (std::size_t i = 0; i < e.dfpc->spec().inputs.size(); ++i)
      routes_[e.dfpc->spec().inputs[i].channel].push_back({e.dfpc.get(), i});
  for (Entry& e : entries_)
    for (OutputBinding& b : e.outputs) {
      auto it = routes_.find(b.message.channel);
      b.routes = it == routes_.end() ? std::vector<Route>() : it->second;
    }
}

std::vector<std::string> Orchestrator::dfpcNames() const {
  std::lock_guard lock(mutex_);
  std::vector<std::string> names;
  for (const Entry& e : entries_) names.push_back(e.dfpc->name());
  return names;
}

bool Orchestrator::contains(const std::string& dfpc) const {
  std::lock_guard lock(mutex_);
  return find(dfpc) != nullptr;
}

#define CDFF_LIFECYCLE(Method)                           \
  Status Orchestrator::Method(const std::string& dfpc) { \
    std::lock_guard lock(mutex_);                        \
    Entry* e = find(dfpc);                               \
    if (!e) return unknown(dfpc);                        \
    CDFF_RETURN_IF_ERROR(e->dfpc->Method());             \
    return sink_status_;                                 \
  }
CDFF_LIFECYCLE(init)
CDFF_LIFECYCLE(start)
CDFF_LIFECYCLE(stop)
CDFF_LIFECYCLE(reset)
#undef CDFF_LIFECYCLE

Status Orchestrator::initAll() {
  std::lock_guard lock(mutex_);
  for (Entry& e : entries_) {
    if (e.dfpc->state() == DfpcState::kRunning) CDFF_RETURN_IF_ERROR(e.dfpc->stop());
    CDFF_RETURN_IF_ERROR(e.dfpc->init());
  }
  return sink_status_;
}

Status Orchestrator::startAll() {
  std::lock_guard lock(mutex_);
  for (Entry& e : entries_)
    if (e.dfpc->state() != DfpcState::kRunning) CDFF_RETURN_IF_ERROR(e.dfpc->start());
  return sink_status_;
}

Status Orchestrator::stopAll() {
  std::lock_guard lock(mutex_);
  for (Entry& e : entries_)
    if (e.dfpc->state() == DfpcState::kRunning) CDFF_RETURN_IF_ERROR(e.dfpc->stop());
  return sink_status_;
}

Status Orchestrator::resetAll() {
  std::lock_guard lock(mutex_);
  for (Entry& e : entries_) CDFF_RETURN_IF_ERROR(e.dfpc->reset());
  return sink_status_;
}

Status Orchestrator::runWhile(ActivationRule rule) {
  std::lock_guard lock(mutex_);
  const Entry* dfpc = find(rule.dfpc);
  if (!dfpc) return unknown(rule.dfpc).withContext("run-while rule");
  for (const RuleState& r : activation_rules_)
    if (r.rule.dfpc == rule.dfpc)
      return invalidInput("DFPC '{}' already runs under the rule '{}'; one rule per DFPC",
                          rule.dfpc, r.rule.condition.empty() ? r.rule.tracker : r.rule.condition);
  RuleState state{std::move(rule), dfpc->dfpc.get(), nullptr, std::nullopt, {}};
  if (!state.rule.condition.empty()) {
    CDFF_RETURN_IF_ERROR(bindCondition(state));
    activation_rules_.push_back(std::move(state));
    return Status::ok();
  }
  const ActivationRule& r = state.rule;
  const Entry* tracker = find(r.tracker);
  if (!tracker) return unknown(r.tracker).withContext("run-while rule");
  if (r.dfpc == r.tracker)
    return invalidInput("run-while rule: DFPC '{}' cannot follow its own track state", r.dfpc);
  if (!tracker->dfpc->spec().track_state)
    return invalidInput("run-while rule for '{}': DFPC '{}' declares no track_state to follow",
                        r.dfpc, r.tracker);
  if (r.states.empty())
    return invalidInput("run-while rule for '{}': no track state to run in", r.dfpc);
  state.tracker = tracker->dfpc.get();
  activation_rules_.push_back(std::move(state));
  return Status::ok();
}

namespace {

/// The output whose position gives a DFPC's range: its first target_state or target_pose
/// product (RigidBodyState or PoseWithCovariance), else its first Bearing product.
std::optional<std::size_t> rangeOutput(const GraphSpec& spec) {
  const auto& outs = spec.outputs;
  for (std::size_t i = 0; i < outs.size(); ++i)
    if ((outs[i].role == "target_state" || outs[i].role == "target_pose") &&
        (outs[i].type == "RigidBodyState" || outs[i].type == "PoseWithCovariance"))
      return i;
  for (std::size_t i = 0; i < outs.size(); ++i)
    if (outs[i].type == "Bearing") return i;
  return std::nullopt;
}

}  // namespace

Result<Orchestrator::RuleRef> Orchestrator::bindRuleRef(const Condition::Ref& ref,
                                                        TypeId& type) const {
  RuleRef out;
  out.entry = find(ref.instance);
  if (!out.entry) return unknown(ref.instance).withContext(fmt::format("'{}'", ref.text()));
  const GraphSpec& spec = out.entry->dfpc->spec();
  // The DFPC's track state first: it always has a value (its initial one), where an output of
  // the same name is unset until first produced.
  if (ref.port == "track_state" && spec.track_state) {
    out.kind = RuleRef::Kind::kTrackState;
    type = TypeId::of<TrackState>();
    return out;
  }
  for (std::size_t i = 0; i < spec.outputs.size(); ++i)
    if (spec.outputs[i].name == ref.port) {
      out.output = i;
      type = findType(spec.outputs[i].type);
      return out;
    }
  if (ref.port == "track_state")
    return invalidInput("'{}': DFPC '{}' declares no track_state", ref.text(), ref.instance);
  std::vector<std::string> names{"track_state"};
  if (ref.port == "range") {
    const std::optional<std::size_t> o = rangeOutput(spec);
    if (!o)
      return invalidInput(
          "'{}': DFPC '{}' has no product to take a range from; expected an output with role "
          "target_state or target_pose (RigidBodyState, PoseWithCovariance) or of type Bearing",
          ref.text(), ref.instance);
    out.kind = RuleRef::Kind::kRange;
    out.output = *o;
    type = TypeId::of<double>();
    return out;
  }
  if (rangeOutput(spec)) names.push_back("range");
  for (const DfpcOutputSpec& o : spec.outputs) names.push_back(o.name);
  return notFound("'{}': DFPC '{}' has no output '{}'; expected one of {{{}}}", ref.text(),
                  ref.instance, ref.port, fmt::join(names, ", "));
}

Status Orchestrator::bindCondition(RuleState& rule) const {
  const std::string where = fmt::format("run-while rule for '{}'", rule.rule.dfpc);
  Result<Condition> parsed = Condition::parse(rule.rule.condition, {});
  if (!parsed) return parsed.status().withContext(where);
  std::vector<TypeId> types;
  for (Condition::Ref ref : parsed->refs()) {
    if (ref.instance.empty()) ref.instance = rule.rule.dfpc;  // a bare track_state: its own
    TypeId type;
    Result<RuleRef> bound = bindRuleRef(ref, type);
    if (!bound) return bound.status().withContext(where);
    bound->type = type;
    rule.refs.push_back(*bound);
    types.push_back(type);
  }
  CDFF_RETURN_IF_ERROR(parsed->bind(types, {}).withContext(where));
  rule.condition = std::move(parsed).value();
  return Status::ok();
}

const void* Orchestrator::ruleValue(RuleRef& ref, Timestamp stamp) const {
  const Dfpc& dfpc = *ref.entry->dfpc;
  if (ref.kind == RuleRef::Kind::kTrackState) {
    ref.track_state = dfpc.trackState();
    return &ref.track_state;
  }
  const std::string& product = ref.entry->outputs[ref.output].product;
  Result<Product> latest = products_->latest(product);
  if (!latest) return nullptr;
  if (ref.kind == RuleRef::Kind::kProduct) {
    ref.held = latest->value;  // keeps the value alive while the rule reads it
    return ref.held.raw();
  }
  const double timeout = dfpc.spec().outputs[ref.output].timeout_s;
  if (timeout > 0 && toSeconds(stamp - latest->stamp) > timeout) return nullptr;
  if (const auto bearing = latest->as<Bearing>()) {
    ref.range = bearing->range;
  } else if (const auto state = latest->as<RigidBodyState>()) {
    ref.range = state->pose.translation.norm();
  } else if (const auto pose = latest->as<PoseWithCovariance>()) {
    ref.range = pose->pose.translation.norm();
  } else {
    return nullptr;
  }
  return std::isfinite(ref.range) ? &ref.range : nullptr;
}

namespace {

/// A value a rule read, for its event: a track state's name, a range, a scalar product's value.
std::string describeValue(bool range, TypeId type, const void* value) {
  if (!value) return "unset";
  if (range) return fmt::format("{:.2f} m", *static_cast<const double*>(value));
  if (type == TypeId::of<TrackState>())
    return std::string(toString(*static_cast<const TrackState*>(value)));
  if (type == TypeId::of<double>())
    return fmt::format("{:.6g}", *static_cast<const double*>(value));
  if (type == TypeId::of<int>()) return fmt::format("{}", *static_cast<const int*>(value));
  if (type == TypeId::of<bool>()) return *static_cast<const bool*>(value) ? "true" : "false";
  if (type == TypeId::of<std::string>())
    return fmt::format("'{}'", *static_cast<const std::string*>(value));
  return "set";
}

}  // namespace

bool Orchestrator::ruleHolds(RuleState& r, Timestamp stamp, std::string& why) const {
  if (!r.condition) {
    const TrackState followed = r.tracker->trackState();
    why = fmt::format("'{}' is {}; '{}' runs while it is {}", r.rule.tracker, toString(followed),
                      r.rule.dfpc, joinTrackStates(r.rule.states, " or "));
    return std::find(r.rule.states.begin(), r.rule.states.end(), followed) != r.rule.states.end();
  }
  std::vector<const void*> values;
  for (RuleRef& ref : r.refs) values.push_back(ruleValue(ref, stamp));
  const bool holds = r.condition->evaluate([&](std::size_t i) { return values[i]; });
  std::vector<std::string> read;
  for (std::size_t i = 0; i < r.refs.size(); ++i) {
    read.push_back(fmt::format(
        "{} = {}", r.condition->refs()[i].text(),
        describeValue(r.refs[i].kind == RuleRef::Kind::kRange, r.refs[i].type, values[i])));
  }
  why = fmt::format("'{}' {} ({}); '{}' runs while it holds", r.rule.condition,
                    holds ? "holds" : "does not hold", fmt::join(read, ", "), r.rule.dfpc);
  return holds;
}

Status Orchestrator::applyActivationRules(Timestamp stamp) {
  for (RuleState& r : activation_rules_) {
    const DfpcState state = r.dfpc->state();
    const bool running = state == DfpcState::kRunning;
    if (!running && !(state == DfpcState::kStopped && r.stopped_by_rule)) continue;
    std::string why;
    const bool wanted = ruleHolds(r, stamp, why);
    if (wanted == running) continue;
    CDFF_RETURN_IF_ERROR(wanted ? r.dfpc->start(stamp) : r.dfpc->stop());
    r.stopped_by_rule = !wanted;
    Event event;
    event.stamp = stamp;
    event.type = wanted ? EventType::kActivated : EventType::kDeactivated;
    event.dfpc = r.rule.dfpc;
    event.message = std::move(why);
    onEvent(event);
  }
  return Status::ok();
}

Status Orchestrator::checkChannels(const std::vector<ChannelInfo>& available) const {
  std::lock_guard lock(mutex_);
  std::vector<std::string> problems;
  // Another DFPC's output feeds an input on its channel (detection's pose a tracker's).
  std::vector<std::pair<std::string, std::string>> produced;  // channel, type
  for (const Entry& e : entries_)
    for (const DfpcOutputSpec& out : e.dfpc->spec().outputs)
      produced.emplace_back(e.dfpc->spec().outputChannel(out), out.type);
  for (const Entry& e : entries_) {
    for (const DfpcInputSpec& in : e.dfpc->spec().inputs) {
      auto it = std::find_if(available.begin(), available.end(),
                             [&](const ChannelInfo& c) { return c.channel == in.channel; });
      auto product = std::find_if(produced.begin(), produced.end(),
                                  [&](const auto& p) { return p.first == in.channel; });
      if (it == available.end() && product != produced.end()) {
        if (product->second != in.type)
          problems.push_back(
              fmt::format("DFPC '{}' input '{}' takes {}; channel '{}' is a "
                          "DFPC output of type {}",
                          e.dfpc->name(), in.name, in.type, in.channel, product->second));
      } else if (it == available.end()) {
        if (!in.optional)
          problems.push_back(
              fmt::format("DFPC '{}' input '{}' needs channel '{}' ({}), which the "
                          "input does not have",
                          e.dfpc->name(), in.name, in.channel, in.type));
      } else if (it->type.name() != in.type) {
        problems.push_back(fmt::format("DFPC '{}' input '{}' takes {}; channel '{}' holds {}",
                                       e.dfpc->name(), in.name, in.type, in.channel,
                                       it->type.name()));
      }
    }
  }
  if (problems.empty()) return Status::ok();
  std::vector<std::string> names;
  for (const ChannelInfo& c : available)
    names.push_back(fmt::format("{} ({})", c.channel, c.type.name()));
  return notFound("{}; the input has {{{}}}", fmt::join(problems, "; "), fmt::join(names, ", "));
}

void Orchestrator::recordSinkError(const Status& status) {
  if (!status && sink_status_) sink_status_ = status.withContext("writing the output");
}

void Orchestrator::onProduct(const Dfpc& dfpc, std::size_t output, Timestamp stamp,
                             const Value& value) {
  for (Entry& e : entries_) {
    if (e.dfpc.get() != &dfpc) continue;
    OutputBinding& b = e.outputs[output];
    ++counters_.products;
    (void)products_->publish(b.product, stamp, value);  // types fixed at load
    b.message.stamp = stamp;
    b.message.value = value;
    if (options_.sink) recordSinkError(options_.sink->writeMessage(b.message));
    if (!b.routes.empty()) internal_.push_back(b.message);
    b.message.value.reset();
    return;
  }
}

void Orchestrator::onEvent(const Event& event) {
  ++counters_.events;
  if (event.kind() == EventKind::kFault) ++counters_.faults;
  if (event.kind() == EventKind::kRecovery) ++counters_.recoveries;
  if (options_.sink) recordSinkError(options_.sink->writeEvent(event));
}

void Orchestrator::onTiming(const TimingRecord& timing) {
  if (options_.sink) recordSinkError(options_.sink->writeTiming(timing));
}

Status Orchestrator::deliverLocked(const Message& message, bool external) {
  Status result;
  if (external) {
    for (Entry& e : entries_) e.dfpc->advanceTo(message.stamp);
  }
  auto it = routes_.find(message.channel);
  if (it != routes_.end()) {
    if (external) ++counters_.routed;
    for (const Route& r : it->second) {
      Status s = r.dfpc->deliver(r.input, message);
      if (!s && result) result = s;
    }
  }
  return result;
}

Status Orchestrator::process(const Message& message) {
  std::lock_guard lock(mutex_);
  CDFF_RETURN_IF_ERROR(sink_status_);
  if (options_.sink) {
    for (const std::string& pattern : options_.passthrough_prefixes) {
      if (!matchesChannelPattern(message.channel, pattern)) continue;
      recordSinkError(options_.sink->writeMessage(message));
      ++counters_.passed_through;
      break;
    }
  }
  CDFF_RETURN_IF_ERROR(applyActivationRules(message.stamp));
  Status result = deliverLocked(message, true);
  // Products consumed by other DFPCs, in the order they were made (FIFO; a product made while
  // routing another joins the end).
  for (std::size_t i = 0; i < internal_.size(); ++i) {
    const Message m = std::move(internal_[i]);
    Status s = deliverLocked(m, false);
    if (!s && result) result = s;
  }
  internal_.clear();
  CDFF_RETURN_IF_ERROR(sink_status_);
  return result;
}

Status Orchestrator::finish() {
  std::lock_guard lock(mutex_);
  for (Entry& e : entries_) e.dfpc->finish();
  for (std::size_t i = 0; i < internal_.size(); ++i) {
    const Message m = std::move(internal_[i]);
    (void)deliverLocked(m, false);
  }
  internal_.clear();
  return sink_status_;
}

Result<RunSummary> Orchestrator::run(InputStream& input, const RunOptions& options) {
  CDFF_RETURN_IF_ERROR(checkChannels(input.channels()));
  SteadyClock steady;
  Clock& clock = options.clock ? *options.clock : steady;
  const double speed = options.speed > 0 ? options.speed : 1.0;
  RunProgress progress;
  progress.range = input.timeRange();
  std::optional<Timestamp> wall_start, stream_start;
  RunSummary summary;
  for (;;) {
    if (options.cancel && options.cancel->load()) {
      summary.cancelled = true;
      break;
    }
    Result<std::optional<Message>> next = input.next();
    if (!next)
      return next.status().withContext(
          fmt::format("reading the input after {} messages", summary.messages));
    if (!next.value()) break;
    const Message& m = *next.value();
    if (!summary.first) summary.first = m.stamp;
    summary.last = m.stamp;
    ++summary.messages;
    if (options.realtime) {
      if (!wall_start) {
        wall_start = clock.now();
        stream_start = m.stamp;
      }
      const Timestamp due = *wall_start + static_cast<Timestamp>(
                                              static_cast<double>(m.stamp - *stream_start) / speed);
      while (clock.now() < due && !(options.cancel && options.cancel->load()))
        clock.sleepUntil(due);
    }
    Status s = process(m);
    if (!s)
      return s.withContext(
          fmt::format("message {} on '{}' at t = {} us", summary.messages, m.channel, m.stamp));
    progress.messages = summary.messages;
    progress.stamp = m.stamp;
    if (options.progress) options.progress(progress);
  }
  CDFF_RETURN_IF_ERROR(finish());
  if (options.stop_at_end) CDFF_RETURN_IF_ERROR(stopAll());
  if (options_.sink) CDFF_RETURN_IF_ERROR(options_.sink->flush());
  std::lock_guard lock(mutex_);
  summary.routed = counters_.routed;
  summary.passed_through = counters_.passed_through;
  summary.products = counters_.products;
  summary.events = counters_.events;
  summary.faults = counters_.faults;
  summary.recoveries = counters_.recoveries;
  return summary;
}

Result<DfpcStatus> Orchestrator::status(const std::string& dfpc) const {
  std::lock_guard lock(mutex_);
  const Entry* e = find(dfpc);
  if (!e) return unknown(dfpc);
  return e->dfpc->status();
}

std::vector<DfpcStatus> Orchestrator::statuses() const {
  std::lock_guard lock(mutex_);
  std::vector<DfpcStatus> out;
  for (const Entry& e : entries_) out.push_back(e.dfpc->status());
  return out;
}

std::vector<std::string> Orchestrator::productsWithRole(const std::string& role,
                                                        const std::string& dfpc) const {
  std::lock_guard lock(mutex_);
  std::vector<std::string> out;
  for (const Entry& e : entries_) {
    if (!dfpc.empty() && e.dfpc->name() != dfpc) continue;
    for (const DfpcOutputSpec& o : e.dfpc->spec().outputs)
      if (o.role == role) out.push_back(productName(e.dfpc->name(), o.name));
  }
  return out;
}

std::vector<DfpcInputSpec> Orchestrator::inputsOf(const std::string& dfpc) const {
  std::lock_guard lock(mutex_);
  const Entry* e = find(dfpc);
  return e ? e->dfpc->spec().inputs : std::vector<DfpcInputSpec>{};
}

std::optional<std::string> Orchestrator::productOfType(
    const std::string& dfpc, const std::vector<std::string>& types) const {
  std::lock_guard lock(mutex_);
  const Entry* e = find(dfpc);
  if (!e) return std::nullopt;
  for (const std::string& type : types)
    for (const DfpcOutputSpec& o : e->dfpc->spec().outputs)
      if (o.type == type) return productName(dfpc, o.name);
  return std::nullopt;
}

}  // namespace cdff::dfpc
