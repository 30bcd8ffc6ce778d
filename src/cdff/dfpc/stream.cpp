#include "cdff/dfpc/stream.hpp"

#include <algorithm>
#include <map>

#include <nlohmann/json.hpp>

namespace cdff::dfpc {

// ---------------------------------------------------------------------------------------------
// MemoryStream

MemoryStream::MemoryStream(std::vector<Message> messages) : messages_(std::move(messages)) {
  sorted_ = false;
}

void MemoryStream::add(Message message) {
  if (!messages_.empty() && message.stamp < messages_.back().stamp) sorted_ = false;
  messages_.push_back(std::move(message));
}

void MemoryStream::sortIfNeeded() {
  if (sorted_) return;
  std::stable_sort(messages_.begin() + static_cast<std::ptrdiff_t>(position_), messages_.end(),
                   [](const Message& a, const Message& b) { return a.stamp < b.stamp; });
  sorted_ = true;
}

Result<std::optional<Message>> MemoryStream::next() {
  sortIfNeeded();
  if (position_ >= messages_.size()) return std::optional<Message>();
  return std::optional<Message>(messages_[position_++]);
}

std::vector<ChannelInfo> MemoryStream::channels() const {
  std::map<std::string, ChannelInfo> by_name;
  for (const Message& m : messages_) {
    ChannelInfo& info = by_name[m.channel];
    info.channel = m.channel;
    info.type = m.type();
    ++info.message_count;
  }
  std::vector<ChannelInfo> out;
  for (auto& [name, info] : by_name) out.push_back(std::move(info));
  return out;
}

std::optional<std::pair<Timestamp, Timestamp>> MemoryStream::timeRange() const {
  if (messages_.empty()) return std::nullopt;
  Timestamp lo = messages_.front().stamp, hi = lo;
  for (const Message& m : messages_) {
    lo = std::min(lo, m.stamp);
    hi = std::max(hi, m.stamp);
  }
  return std::make_pair(lo, hi);
}

// ---------------------------------------------------------------------------------------------
// MergedStream

MergedStream::MergedStream(std::vector<std::unique_ptr<InputStream>> inputs)
    : inputs_(std::move(inputs)), heads_(inputs_.size()) {}

Result<std::optional<Message>> MergedStream::next() {
  if (!primed_) {
    for (std::size_t i = 0; i < inputs_.size(); ++i) {
      Result<std::optional<Message>> head = inputs_[i]->next();
      if (!head) return head.status().withContext(fmt::format("input {}", i + 1));
      heads_[i] = std::move(head).value();
    }
    primed_ = true;
  }
  std::size_t best = heads_.size();
  for (std::size_t i = 0; i < heads_.size(); ++i)
    if (heads_[i] && (best == heads_.size() || heads_[i]->stamp < heads_[best]->stamp)) best = i;
  if (best == heads_.size()) return std::optional<Message>();
  std::optional<Message> out = std::move(heads_[best]);
  Result<std::optional<Message>> refill = inputs_[best]->next();
  if (!refill) return refill.status().withContext(fmt::format("input {}", best + 1));
  heads_[best] = std::move(refill).value();
  return out;
}

std::vector<ChannelInfo> MergedStream::channels() const {
  std::vector<ChannelInfo> out;
  for (const auto& input : inputs_)
    for (ChannelInfo& c : input->channels()) out.push_back(std::move(c));
  return out;
}

std::optional<std::pair<Timestamp, Timestamp>> MergedStream::timeRange() const {
  std::optional<std::pair<Timestamp, Timestamp>> out;
  for (const auto& input : inputs_) {
    auto r = input->timeRange();
    if (!r) continue;
    if (!out)
      out = r;
    else
      out = std::make_pair(std::min(out->first, r->first), std::max(out->second, r->second));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// LiveStream

LiveStream::LiveStream(std::size_t capacity) : capacity_(std::max<std::size_t>(capacity, 1)) {}

Status LiveStream::push(Message message) {
  {
    std::lock_guard lock(mutex_);
    if (closed_)
      return invalidInput("live stream is closed; message on '{}' at t = {} us not accepted",
                          message.channel, message.stamp);
    if (queue_.size() >= capacity_) {
      queue_.pop_front();
      ++dropped_;
    }
    queue_.push_back(std::move(message));
  }
  arrived_.notify_one();
  return Status::ok();
}

void LiveStream::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  arrived_.notify_all();
}

Result<std::optional<Message>> LiveStream::next() {
  std::unique_lock lock(mutex_);
  arrived_.wait(lock, [&] { return !queue_.empty() || closed_; });
  if (queue_.empty()) return std::optional<Message>();
  std::optional<Message> out(std::move(queue_.front()));
  queue_.pop_front();
  return out;
}

std::uint64_t LiveStream::dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}

std::size_t LiveStream::queued() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

// ---------------------------------------------------------------------------------------------
// Events

const char* toString(EventKind kind) {
  switch (kind) {
    case EventKind::kLifecycle:
      return "lifecycle";
    case EventKind::kFault:
      return "fault";
    case EventKind::kRecovery:
      return "recovery";
    case EventKind::kActivation:
      return "activation";
    case EventKind::kWarning:
      return "warning";
  }
  return "?";
}

const char* toString(EventType type) {
  switch (type) {
    case EventType::kInitialised:
      return "initialised";
    case EventType::kStarted:
      return "started";
    case EventType::kStopped:
      return "stopped";
    case EventType::kReset:
      return "reset";
    case EventType::kTrackStateChanged:
      return "track_state_changed";
    case EventType::kDfnError:
      return "dfn_error";
    case EventType::kOverBudget:
      return "over_budget";
    case EventType::kDivergence:
      return "divergence";
    case EventType::kNoProduct:
      return "no_product";
    case EventType::kReinitialise:
      return "reinitialise";
    case EventType::kWake:
      return "wake";
    case EventType::kSwitchDfi:
      return "switch_dfi";
    case EventType::kSetTrackState:
      return "set_track_state";
    case EventType::kRecoveryFailed:
      return "recovery_failed";
    case EventType::kActivated:
      return "activated";
    case EventType::kDeactivated:
      return "deactivated";
    case EventType::kSyncDropped:
      return "sync_dropped";
    case EventType::kDfnWarning:
      return "dfn_warning";
    case EventType::kInputRejected:
      return "input_rejected";
    case EventType::kInputLost:
      return "input_lost";
  }
  return "?";
}

EventKind kindOf(EventType type) {
  switch (type) {
    case EventType::kInitialised:
    case EventType::kStarted:
    case EventType::kStopped:
    case EventType::kReset:
    case EventType::kTrackStateChanged:
      return EventKind::kLifecycle;
    case EventType::kDfnError:
    case EventType::kOverBudget:
    case EventType::kDivergence:
    case EventType::kNoProduct:
      return EventKind::kFault;
    case EventType::kReinitialise:
    case EventType::kWake:
    case EventType::kSwitchDfi:
    case EventType::kSetTrackState:
    case EventType::kRecoveryFailed:
      return EventKind::kRecovery;
    case EventType::kActivated:
    case EventType::kDeactivated:
      return EventKind::kActivation;
    case EventType::kSyncDropped:
    case EventType::kDfnWarning:
    case EventType::kInputRejected:
    case EventType::kInputLost:
      return EventKind::kWarning;
  }
  return EventKind::kWarning;
}

std::string toJson(const Event& event) {
  nlohmann::json j = {{"stamp_us", event.stamp},      {"kind", toString(event.kind())},
                      {"type", toString(event.type)}, {"dfpc", event.dfpc},
                      {"instance", event.instance},   {"message", event.message}};
  return j.dump();
}

std::string toJson(const TimingRecord& t) {
  nlohmann::json j = {{"stamp_us", t.stamp},
                      {"dfpc", std::string(t.dfpc)},
                      {"instance", std::string(t.instance)},
                      {"dfn", std::string(t.dfn)},
                      {"dfi", std::string(t.dfi)},
                      {"wall_s", t.wall_s},
                      {"cpu_s", t.cpu_s},
                      {"status", toString(t.status)}};
  return j.dump();
}

// ---------------------------------------------------------------------------------------------
// MemorySink

Status MemorySink::writeMessage(const Message& message) {
  std::lock_guard lock(mutex_);
  messages_.push_back(message);
  return Status::ok();
}

Status MemorySink::writeEvent(const Event& event) {
  std::lock_guard lock(mutex_);
  events_.push_back(event);
  return Status::ok();
}

Status MemorySink::writeTiming(const TimingRecord& t) {
  std::lock_guard lock(mutex_);
  timings_.push_back({t.stamp, std::string(t.dfpc), std::string(t.instance), std::string(t.dfn),
                      std::string(t.dfi), t.wall_s, t.cpu_s, t.status});
  return Status::ok();
}

std::vector<Message> MemorySink::messages() const {
  std::lock_guard lock(mutex_);
  return messages_;
}

std::vector<Message> MemorySink::messages(const std::string& channel) const {
  std::lock_guard lock(mutex_);
  std::vector<Message> out;
  for (const Message& m : messages_)
    if (m.channel == channel) out.push_back(m);
  return out;
}

std::vector<Event> MemorySink::events() const {
  std::lock_guard lock(mutex_);
  return events_;
}

std::vector<Event> MemorySink::events(EventType type) const {
  std::lock_guard lock(mutex_);
  std::vector<Event> out;
  for (const Event& e : events_)
    if (e.type == type) out.push_back(e);
  return out;
}

std::vector<MemorySink::Timing> MemorySink::timings() const {
  std::lock_guard lock(mutex_);
  return timings_;
}

}  // namespace cdff::dfpc
