#include "cdff/dfpc/orchestrator.hpp"

#include <fnmatch.h>

#include <algorithm>

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

Result<ActivationRule> parseActivationRule(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return invalidParameter(
        "run-while rule '{}': {}; expected DFPC=TRACKER:STATE[,STATE...] "
        "(e.g. detection=visual_tracking:UNINITIALISED,LOST)",
        text, why);
  };
  const std::size_t eq = text.find('=');
  const std::size_t colon = text.find(':', eq == std::string::npos ? 0 : eq);
  if (eq == std::string::npos || colon == std::string::npos) return bad("no '=' and ':'");
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
  const Entry* tracker = find(rule.tracker);
  if (!tracker) return unknown(rule.tracker).withContext("run-while rule");
  if (rule.dfpc == rule.tracker)
    return invalidInput("run-while rule: DFPC '{}' cannot follow its own track state", rule.dfpc);
  if (!tracker->dfpc->spec().track_state)
    return invalidInput("run-while rule for '{}': DFPC '{}' declares no track_state to follow",
                        rule.dfpc, rule.tracker);
  if (rule.states.empty())
    return invalidInput("run-while rule for '{}': no track state to run in", rule.dfpc);
  for (const RuleState& r : activation_rules_)
    if (r.rule.dfpc == rule.dfpc)
      return invalidInput("DFPC '{}' already runs while '{}' is in given states; one rule per DFPC",
                          rule.dfpc, r.rule.tracker);
  activation_rules_.push_back({std::move(rule), dfpc->dfpc.get(), tracker->dfpc.get()});
  return Status::ok();
}

Status Orchestrator::applyActivationRules(Timestamp stamp) {
  for (RuleState& r : activation_rules_) {
    const ActivationRule& rule = r.rule;
    const DfpcState state = r.dfpc->state();
    const bool running = state == DfpcState::kRunning;
    if (!running && !(state == DfpcState::kStopped && r.stopped_by_rule)) continue;
    const TrackState followed = r.tracker->trackState();
    const bool wanted =
        std::find(rule.states.begin(), rule.states.end(), followed) != rule.states.end();
    if (wanted == running) continue;
    CDFF_RETURN_IF_ERROR(wanted ? r.dfpc->start(stamp) : r.dfpc->stop());
    r.stopped_by_rule = !wanted;
    Event event;
    event.stamp = stamp;
    event.type = wanted ? EventType::kActivated : EventType::kDeactivated;
    event.dfpc = rule.dfpc;
    event.message =
        fmt::format("'{}' is {}; '{}' runs while it is {}", rule.tracker, toString(followed),
                    rule.dfpc, joinTrackStates(rule.states, " or "));
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
