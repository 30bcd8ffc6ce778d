#include "cdff/dfpc/recording_streams.hpp"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

namespace cdff::dfpc {

// ---------------------------------------------------------------------------------------------
// Input

McapInputStream::McapInputStream() = default;
McapInputStream::~McapInputStream() = default;

Status McapInputStream::open(const std::vector<std::string>& paths,
                             const io::ReplayOptions& options) {
  CDFF_RETURN_IF_ERROR(replay_.open(paths, options));
  channels_.clear();
  types_.clear();
  skipped_.clear();
  done_ = false;
  for (const io::ReplayChannel& c : replay_.channels()) {
    if (!c.type) {
      skipped_[c.topic] =
          fmt::format("schema '{}' ({}) is not a CDFF type", c.schema_name, c.message_encoding);
      continue;
    }
    types_.emplace(c.topic, c.type);
    channels_.push_back({c.topic, c.type, c.message_count});
  }
  return Status::ok();
}

Result<std::optional<Message>> McapInputStream::next() {
  if (done_) return std::optional<Message>();
  while (replay_.next()) {
    const io::ReplayMessage& m = replay_.message();
    if (!types_.count(m.channel())) continue;
    Result<Value> value = m.decode();
    if (!value) return value.status();
    return std::optional<Message>(Message{m.channel(), m.logTime(), std::move(value).value()});
  }
  done_ = true;
  Status damage = replay_.status();
  if (!damage.isOk())
    return damage.withContext(
        "the input recording is damaged; every message before the damage "
        "was replayed");
  return std::optional<Message>();
}

std::vector<ChannelInfo> McapInputStream::channels() const {
  return channels_;
}

std::optional<std::pair<Timestamp, Timestamp>> McapInputStream::timeRange() const {
  if (channels_.empty() || replay_.endTime() < replay_.startTime()) return std::nullopt;
  return std::make_pair(replay_.startTime(), replay_.endTime());
}

// ---------------------------------------------------------------------------------------------
// Output

const char* eventLevel(EventType type) {
  switch (type) {
    case EventType::kDfnError:
    case EventType::kRecoveryFailed:
      return "error";
    default:
      break;
  }
  switch (kindOf(type)) {
    case EventKind::kFault:
    case EventKind::kWarning:
      return "warning";
    default:
      return "info";
  }
}

Status McapSink::open(const std::string& path, const McapSinkOptions& options) {
  options_ = options;
  timing_channels_.clear();
  messages_written_ = events_written_ = 0;
  return recorder_.open(path, options.writer);
}

Status McapSink::close() {
  if (!recorder_.isOpen()) return Status::ok();
  return recorder_.close();
}

Status McapSink::writeMessage(const Message& message) {
  if (message.value.empty())
    return invalidInput("channel '{}': a message without a value at t = {} us", message.channel,
                        message.stamp);
  CDFF_RETURN_IF_ERROR(recorder_.write(message.channel, message.value, message.stamp)
                           .withContext(fmt::format("recording channel '{}' at t = {} us",
                                                    message.channel, message.stamp)));
  ++messages_written_;
  return Status::ok();
}

nlohmann::json eventRecord(const Event& event) {
  const std::string source =
      event.instance.empty() ? event.dfpc : fmt::format("{}.{}", event.dfpc, event.instance);
  return {{"level", eventLevel(event.type)}, {"source", source},   {"kind", toString(event.kind())},
          {"type", toString(event.type)},    {"dfpc", event.dfpc}, {"instance", event.instance},
          {"message", event.message}};
}

nlohmann::json statusRecord(const DfpcStatus& s) {
  nlohmann::json instances = nlohmann::json::array();
  for (const InstanceStatus& i : s.instances)
    instances.push_back({{"name", i.name},
                         {"dfn", i.dfn},
                         {"dfi", i.dfi},
                         {"active", i.active},
                         {"on_fallback", i.on_fallback},
                         {"calls", i.calls},
                         {"errors", i.errors},
                         {"faults", i.faults},
                         {"skipped", i.skipped},
                         {"sync_dropped", i.sync_dropped},
                         {"mean_wall_s", i.mean_wall_s},
                         {"max_wall_s", i.max_wall_s},
                         {"last_error", i.last_error}});
  return {{"name", s.name},
          {"state", toString(s.state)},
          {"track_state",
           s.track_state ? nlohmann::json(std::string(toString(*s.track_state))) : nullptr},
          {"stream_time_us", s.stream_time},
          {"last_product_us", s.last_product ? nlohmann::json(*s.last_product) : nullptr},
          {"messages", s.messages},
          {"ignored_messages", s.ignored_messages},
          {"products", s.products},
          {"faults", s.faults},
          {"recoveries", s.recoveries},
          {"last_fault", s.last_fault},
          {"instances", std::move(instances)}};
}

nlohmann::json timingRecord(const TimingRecord& timing) {
  return {{"dfn", std::string(timing.instance)},
          {"dfn_type", std::string(timing.dfn)},
          {"dfi", std::string(timing.dfi)},
          {"wall_s", timing.wall_s},
          {"cpu_s", timing.cpu_s},
          {"status", toString(timing.status)}};
}

std::string timingChannel(std::string_view dfpc) {
  return fmt::format("/cdff/{}/timing", dfpc);
}

Status McapSink::writeEvent(const Event& event) {
  CDFF_RETURN_IF_ERROR(
      recorder_.writeJson(options_.event_channel, event.stamp, eventRecord(event)));
  ++events_written_;
  return Status::ok();
}

Status McapSink::writeTiming(const TimingRecord& timing) {
  auto channel = timing_channels_.find(timing.dfpc);
  if (channel == timing_channels_.end())
    channel = timing_channels_.emplace(std::string(timing.dfpc), timingChannel(timing.dfpc)).first;
  return recorder_.writeJson(channel->second, timing.stamp, timingRecord(timing));
}

Status McapSink::flush() {
  return recorder_.flush();
}

Result<ReplayResult> replayFiles(const std::vector<std::string>& inputs, const std::string& output,
                                 const ReplayOptions& options) {
  McapInputStream input;
  CDFF_RETURN_IF_ERROR(input.open(inputs));
  McapSink sink;
  CDFF_RETURN_IF_ERROR(sink.open(output));
  Result<ReplayResult> result = replay(input, sink, options);
  const Status closed = sink.close();
  if (result && !closed) return closed;
  return result;
}

}  // namespace cdff::dfpc
