#include "cdff/dfpc/recording_streams.hpp"

#include <fmt/format.h>

#include <functional>
#include <typeindex>
#include <unordered_map>

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
  port_types_.clear();
  skipped_.clear();
  done_ = false;
  for (const io::ReplayChannel& c : replay_.channels()) {
    if (c.cdff_type.empty()) {
      skipped_[c.topic] =
          fmt::format("schema '{}' ({}) is not a CDFF type", c.schema_name, c.message_encoding);
      continue;
    }
    const dfn::PortType* type = dfn::findPortType(c.cdff_type);
    if (type == nullptr) {
      skipped_[c.topic] = fmt::format("type '{}' is recorded but is not a port type", c.cdff_type);
      continue;
    }
    port_types_.emplace(c.topic, *type);
    channels_.push_back({c.topic, *type, c.message_count});
  }
  return Status::ok();
}

Result<std::optional<Message>> McapInputStream::next() {
  if (done_) return std::optional<Message>();
  while (replay_.next()) {
    const io::ReplayMessage& m = replay_.message();
    auto type = port_types_.find(m.channel());
    if (type == port_types_.end()) continue;
    Result<io::AnyValue> value = m.decode();
    if (!value) return value.status();
    if (value->type != type->second.cpp_type)
      return invalidInput("channel '{}': decoded a '{}' where the channel holds '{}'", m.channel(),
                          value->type_name, type->second.name);
    return std::optional<Message>(
        Message{m.channel(), m.logTime(), type->second, std::move(value->value)});
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

namespace {

using WriteFunction = std::function<Status(io::Recorder&, const Message&)>;

template <typename T>
void addStamped(std::unordered_map<std::type_index, WriteFunction>& table) {
  table[std::type_index(typeid(T))] = [](io::Recorder& r, const Message& m) {
    return r.write(m.channel, *static_cast<const T*>(m.value.get()));
  };
}
template <typename T>
void addUnstamped(std::unordered_map<std::type_index, WriteFunction>& table) {
  table[std::type_index(typeid(T))] = [](io::Recorder& r, const Message& m) {
    return r.write(m.channel, *static_cast<const T*>(m.value.get()), m.stamp);
  };
}
template <typename T>
void addScalar(std::unordered_map<std::type_index, WriteFunction>& table) {
  table[std::type_index(typeid(T))] = [](io::Recorder& r, const Message& m) {
    return r.writeScalar(m.channel, *static_cast<const T*>(m.value.get()), m.stamp);
  };
}

const std::unordered_map<std::type_index, WriteFunction>& writers() {
  static const auto table = [] {
    std::unordered_map<std::type_index, WriteFunction> t;
    addStamped<Image>(t);
    addStamped<DepthMap>(t);
    addStamped<StereoImagePair>(t);
    addStamped<PointCloud>(t);
    addStamped<Transform>(t);
    addStamped<PoseWithCovariance>(t);
    addStamped<RigidBodyState>(t);
    addStamped<TriangleMesh>(t);
    addStamped<Features2D>(t);
    addStamped<Features3D>(t);
    addStamped<ImuSample>(t);
    addStamped<Wrench>(t);
    addStamped<JointState>(t);
    addUnstamped<CameraModel>(t);
    addUnstamped<Matches>(t);
    addUnstamped<Correspondences2D>(t);
    addUnstamped<Correspondences3D>(t);
    addUnstamped<Correspondences2D3D>(t);
    addScalar<double>(t);
    addScalar<bool>(t);
    addScalar<int>(t);
    addScalar<std::int64_t>(t);
    addScalar<std::string>(t);
    return t;
  }();
  return table;
}

}  // namespace

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
  unrecordable_.clear();
  timing_channels_.clear();
  messages_written_ = events_written_ = 0;
  return recorder_.open(path, options.writer);
}

Status McapSink::close() {
  if (!recorder_.isOpen()) return Status::ok();
  return recorder_.close();
}

Status McapSink::writeMessage(const Message& message) {
  if (message.value == nullptr)
    return invalidInput("channel '{}': a message without a value at t = {} us", message.channel,
                        message.stamp);
  auto writer = writers().find(message.type.cpp_type);
  if (writer == writers().end()) {
    // A product of a type that has no channel encoding is counted and reported once as an
    // event; the run goes on and every recordable product is kept.
    if (unrecordable_[message.channel]++ == 0) {
      CDFF_RETURN_IF_ERROR(recorder_.writeJson(
          options_.event_channel, message.stamp,
          {{"level", "warning"},
           {"source", "cdff run"},
           {"kind", "warning"},
           {"type", "unrecordable_channel"},
           {"message", fmt::format("channel '{}': type '{}' has no recording encoding "
                                   "(docs/recording.md); its messages are not recorded",
                                   message.channel, message.type.name)}}));
      ++events_written_;
    }
    return Status::ok();
  }
  CDFF_RETURN_IF_ERROR(writer->second(recorder_, message)
                           .withContext(fmt::format("recording channel '{}' at t = {} us",
                                                    message.channel, message.stamp)));
  ++messages_written_;
  return Status::ok();
}

Status McapSink::writeEvent(const Event& event) {
  const std::string source =
      event.instance.empty() ? event.dfpc : fmt::format("{}.{}", event.dfpc, event.instance);
  CDFF_RETURN_IF_ERROR(recorder_.writeJson(options_.event_channel, event.stamp,
                                           {{"level", eventLevel(event.type)},
                                            {"source", source},
                                            {"kind", toString(event.kind())},
                                            {"type", toString(event.type)},
                                            {"dfpc", event.dfpc},
                                            {"instance", event.instance},
                                            {"message", event.message}}));
  ++events_written_;
  return Status::ok();
}

Status McapSink::writeTiming(const TimingRecord& timing) {
  auto channel = timing_channels_.find(timing.dfpc);
  if (channel == timing_channels_.end())
    channel = timing_channels_
                  .emplace(std::string(timing.dfpc), fmt::format("/cdff/{}/timing", timing.dfpc))
                  .first;
  return recorder_.writeJson(channel->second, timing.stamp,
                             {{"dfn", std::string(timing.instance)},
                              {"dfn_type", std::string(timing.dfn)},
                              {"dfi", std::string(timing.dfi)},
                              {"wall_s", timing.wall_s},
                              {"cpu_s", timing.cpu_s},
                              {"status", toString(timing.status)}});
}

Status McapSink::flush() {
  return recorder_.flush();
}

}  // namespace cdff::dfpc
