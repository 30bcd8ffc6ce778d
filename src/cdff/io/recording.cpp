// Recorder (typed writing) and Replay (merged, typed reading).
#include <algorithm>
#include <limits>
#include <tuple>
#include <utility>

#include <nlohmann/json.hpp>

#include "cdff/io/recorder.hpp"
#include "cdff/io/replay.hpp"

namespace cdff::io {

// ---- Recorder ------------------------------------------------------------------------------

Recorder::Recorder() = default;
Recorder::~Recorder() {
  if (isOpen()) (void)close();
}

Status Recorder::open(const std::string& path, const McapWriterOptions& options) {
  std::lock_guard lock(mutex_);
  channels_.clear();
  schemas_.clear();
  return writer_.open(path, options);
}

bool Recorder::isOpen() const {
  std::lock_guard lock(mutex_);
  return writer_.isOpen();
}

Status Recorder::writeEncoded(const std::string& channel, TypeId type, Timestamp stamp) {
  if (stamp < 0)
    return invalidInput("channel '{}': stamp {} us is negative; MCAP times are unsigned", channel,
                        stamp);
  auto it = channels_.find(channel);
  if (it == channels_.end()) {
    const TypeInfo& info = type.info();
    std::uint16_t schema_id = 0;
    if (auto s = schemas_.find(info.name); s != schemas_.end()) {
      schema_id = s->second;
    } else {
      auto id = writer_.addSchema(std::string(info.schema_name), std::string(info.schemaEncoding()),
                                  info.schemaData());
      CDFF_RETURN_IF_ERROR(id.status());
      schema_id = *id;
      schemas_[info.name] = schema_id;
    }
    auto id = writer_.addChannel(channel, std::string(info.messageEncoding()), schema_id,
                                 {{std::string(kTypeMetadataKey), std::string(info.name)}});
    CDFF_RETURN_IF_ERROR(id.status());
    it = channels_.emplace(channel, ChannelEntry{*id, type}).first;
  } else if (it->second.type != type) {
    return invalidInput("channel '{}' records {} values; cannot write a {} to it", channel,
                        it->second.type.name(), type.name());
  }
  const std::vector<Bytes> parts = scratch_.parts();
  const std::uint64_t t = toMcapTime(stamp);
  return writer_.write(it->second.id, t, t, parts);
}

Status Recorder::writeTyped(const std::string& channel, TypeId type, const void* value,
                            std::optional<Timestamp> stamp) {
  const TypeInfo& info = type.info();
  const std::optional<Timestamp> own = info.own_stamp(value);
  if (!own && !stamp)
    return invalidInput(
        "channel '{}': a {} has no stamp of its own; expected the message's stamp as an argument",
        channel, info.name);
  const Timestamp log_time = own ? *own : *stamp;
  std::lock_guard lock(mutex_);
  if (!writer_.isOpen())
    return invalidInput("recorder is not open; cannot write channel '{}'", channel);
  CDFF_RETURN_IF_ERROR(
      info.encode(value, log_time, scratch_).withContext(fmt::format("channel '{}'", channel)));
  const Status s = writeEncoded(channel, type, log_time);
  scratch_.clear();  // drop the references to the caller's buffers
  return s;
}

Status Recorder::write(const std::string& channel, const Value& value, Timestamp stamp) {
  if (value.empty())
    return invalidInput("channel '{}': no value to write at t = {} us", channel, stamp);
  return writeTyped(channel, value.type(), value.raw(), stamp);
}

Status Recorder::writeCalibration(const std::string& channel, const CameraModel& value,
                                  Timestamp stamp, const std::string& frame_id) {
  std::lock_guard lock(mutex_);
  if (!writer_.isOpen())
    return invalidInput("recorder is not open; cannot write channel '{}'", channel);
  CDFF_RETURN_IF_ERROR(codec::encodeCalibration(value, stamp, frame_id, scratch_)
                           .withContext(fmt::format("channel '{}'", channel)));
  const Status s = writeEncoded(channel, TypeId::of<CameraModel>(), stamp);
  scratch_.clear();
  return s;
}

Status Recorder::writeJson(const std::string& channel, Timestamp stamp,
                           const nlohmann::json& value) {
  return write(channel, value, stamp);
}

Status Recorder::writeEvent(Timestamp stamp, const std::string& level, const std::string& source,
                            const std::string& message, const std::string& channel) {
  if (level != "info" && level != "warning" && level != "error")
    return invalidInput("event level '{}' is not one of info, warning, error", level);
  return writeJson(channel, stamp,
                   nlohmann::json{{"level", level}, {"source", source}, {"message", message}});
}

Status Recorder::writeAttachment(const std::string& name, const std::string& media_type,
                                 Timestamp stamp, Bytes data) {
  std::lock_guard lock(mutex_);
  if (stamp < 0) return invalidInput("attachment '{}': stamp {} us is negative", name, stamp);
  return writer_.writeAttachment(name, media_type, toMcapTime(stamp), data);
}

Status Recorder::writeMetadata(const std::string& name,
                               const std::map<std::string, std::string>& values) {
  std::lock_guard lock(mutex_);
  return writer_.writeMetadata(name, values);
}

Status Recorder::flush() {
  std::lock_guard lock(mutex_);
  return writer_.flush();
}

Status Recorder::close() {
  std::lock_guard lock(mutex_);
  return writer_.close();
}

Statistics Recorder::statistics() const {
  std::lock_guard lock(mutex_);
  return writer_.statistics();
}

TypeId typeOfChannel(const Channel& channel, const Schema* schema) {
  if (auto it = channel.metadata.find(std::string(kTypeMetadataKey)); it != channel.metadata.end())
    if (const TypeId type = findType(it->second)) return type;
  if (schema)
    if (const TypeId type = findTypeBySchema(schema->name, channel.message_encoding)) return type;
  if (channel.message_encoding == "json") return TypeId::of<nlohmann::json>();
  return TypeId();
}

// ---- Replay --------------------------------------------------------------------------------

std::string_view ReplayMessage::schemaName() const {
  return view_.schema ? std::string_view(view_.schema->name) : std::string_view{};
}

std::string ReplayMessage::context() const {
  return fmt::format("'{}' channel '{}' message at {} ns", path_ ? *path_ : std::string(),
                     channel(), view_.log_time);
}

Status ReplayMessage::checkDecodableAs(TypeId type) const {
  if (type == type_) return Status::ok();
  const TypeInfo& info = type.info();
  if (view_.schema && info.schema_name == view_.schema->name &&
      info.messageEncoding() == view_.channel->message_encoding)
    return Status::ok();  // the same schema (e.g. a RigidBodyState read as PoseWithCovariance)
  return invalidInput("{}: the channel holds {} ({}); cannot decode it as {}", context(),
                      type_ ? std::string(type_.name()) : std::string("a non-CDFF type"),
                      view_.schema ? view_.schema->name : view_.channel->message_encoding,
                      type.name());
}

Result<Value> ReplayMessage::decode() const {
  if (!type_)
    return notFound("{}: schema '{}' ({}) is not a CDFF type; only its raw bytes are available",
                    context(), schemaName(), messageEncoding());
  Result<Value> value = type_.info().decode(view_.data, view_.owner);
  if (!value) return value.status().withContext(context());
  return value;
}

struct Replay::Impl {
  std::vector<std::string> paths;
  std::vector<std::unique_ptr<McapReader>> readers;
  std::vector<MessageIterator> iterators;
  std::vector<std::size_t> iterator_files;  // the file each iterator reads
  std::vector<bool> has_current;
  std::vector<std::size_t> heap;  // iterator indices, min-heap on the current message
  std::vector<ReplayChannel> channels;
  std::vector<std::map<std::uint16_t, TypeId>> types;  // per file, by channel id
  ReplayMessage current;
  std::vector<std::string> open_damages;
  Timestamp start = 0, end = 0;
  bool started = false;

  bool later(std::size_t a, std::size_t b) const {
    const std::uint64_t ta = iterators[a].message().log_time;
    const std::uint64_t tb = iterators[b].message().log_time;
    if (ta != tb) return ta > tb;
    return a > b;
  }
  void push(std::size_t file) {
    heap.push_back(file);
    std::push_heap(heap.begin(), heap.end(),
                   [&](std::size_t a, std::size_t b) { return later(a, b); });
  }
};

namespace {

// The channels of all the files, matched by topic (a topic recorded in several files is one
// channel of the replay), and each file's channel ids with their CDFF types.
struct ChannelIndex {
  std::vector<ReplayChannel> channels;
  std::vector<std::map<std::uint16_t, TypeId>> types;  // per file, by channel id
};

// A topic must have the same schema and encoding in every file: the replay decodes all of its
// messages alike.
Result<ChannelIndex> indexChannels(const std::vector<std::unique_ptr<McapReader>>& readers,
                                   const std::vector<std::string>& paths) {
  ChannelIndex index;
  for (std::size_t f = 0; f < readers.size(); ++f) {
    const McapReader& r = *readers[f];
    auto& types = index.types.emplace_back();
    for (const auto& entry : r.channels()) {
      const std::uint16_t id = entry.first;
      const Channel& ch = entry.second;  // named: lambdas below capture it (clang 14)
      const Schema* schema = r.schemaOf(ch);
      const TypeId type = typeOfChannel(ch, schema);
      types[id] = type;
      const std::string schema_name = schema ? schema->name : std::string();
      auto it = std::find_if(index.channels.begin(), index.channels.end(),
                             [&](const ReplayChannel& c) { return c.topic == ch.topic; });
      if (it == index.channels.end()) {
        index.channels.push_back({ch.topic, type, schema_name, ch.message_encoding, 0, {}});
        it = index.channels.end() - 1;
      } else if (it->schema_name != schema_name || it->message_encoding != ch.message_encoding) {
        return invalidInput("channel '{}' is {} ({}) in '{}' but {} ({}) in '{}'", ch.topic,
                            it->schema_name, it->message_encoding, paths[it->files.front()],
                            schema_name, ch.message_encoding, paths[f]);
      }
      if (auto c = r.statistics().channel_message_counts.find(id);
          c != r.statistics().channel_message_counts.end())
        it->message_count += c->second;
      it->files.push_back(f);
    }
  }
  return index;
}

// A requested topic that no file has is an error, not an empty replay: it is most likely a typo,
// and the message lists the topics there are.
Status checkTopicsExist(const std::vector<std::string>& topics,
                        const std::vector<ReplayChannel>& channels,
                        const std::vector<std::string>& paths) {
  for (const std::string& topic : topics) {
    if (std::none_of(channels.begin(), channels.end(),
                     [&](const ReplayChannel& c) { return c.topic == topic; })) {
      std::string known;
      for (const ReplayChannel& c : channels) known += (known.empty() ? "" : ", ") + c.topic;
      std::string files;
      for (const std::string& p : paths) files += (files.empty() ? "'" : ", '") + p + "'";
      return notFound("no channel '{}' in {}; channels are: {}", topic, files,
                      known.empty() ? "(none)" : known);
    }
  }
  return Status::ok();
}

// The time range of the selection: the files' statistics (no message read), narrowed to the
// requested start and end.
std::pair<Timestamp, Timestamp> selectionRange(
    const std::vector<std::unique_ptr<McapReader>>& readers, const ReplayOptions& options) {
  bool any = false;
  std::uint64_t lo = std::numeric_limits<std::uint64_t>::max(), hi = 0;
  for (const auto& r : readers) {
    const Statistics& s = r->statistics();
    if (s.message_count == 0) continue;
    lo = std::min(lo, s.message_start_time);
    hi = std::max(hi, s.message_end_time);
    any = true;
  }
  Timestamp start = any ? fromMcapTime(lo) : 0;
  Timestamp end = any ? fromMcapTime(hi) : 0;
  if (options.start) start = std::max(start, *options.start);
  if (options.end) end = std::min(end, *options.end);
  return {start, end};
}

// What to read of one file: the requested time range in MCAP nanoseconds (the end's whole last
// microsecond) and the ids of the requested topics in this file; an empty range when the file
// has none of them or the range ends before time 0.
ReadOptions readOptionsFor(const McapReader& r, const ReplayOptions& options) {
  ReadOptions ro;
  if (options.start) ro.start_time = toMcapTime(std::max<Timestamp>(*options.start, 0));
  if (options.end) {
    if (*options.end < 0) {
      ro.end_time = 0;
      ro.start_time = 1;  // an empty range
    } else {
      ro.end_time = toMcapTime(*options.end) + 999;  // the whole last microsecond
    }
  }
  if (!options.channels.empty()) {
    for (const auto& [id, ch] : r.channels())
      if (std::find(options.channels.begin(), options.channels.end(), ch.topic) !=
          options.channels.end())
        ro.channels.push_back(id);
    if (ro.channels.empty()) {
      ro.start_time = 1;  // nothing wanted in this file
      ro.end_time = 0;
    }
  }
  return ro;
}

// The channels of one file that hold a single message in all the files (static), among the
// requested ones, read before the window's start.
ReadOptions staticChannelsBefore(const McapReader& r, const std::vector<ReplayChannel>& channels,
                                 const ReplayOptions& options) {
  ReadOptions ro;
  ro.start_time = 0;
  ro.end_time = toMcapTime(*options.start) - 1;
  for (const auto& [id, ch] : r.channels()) {
    const bool wanted = options.channels.empty() ||
                        std::find(options.channels.begin(), options.channels.end(), ch.topic) !=
                            options.channels.end();
    const bool single = std::any_of(channels.begin(), channels.end(), [&](const ReplayChannel& c) {
      return c.topic == ch.topic && c.message_count == 1;
    });
    if (wanted && single) ro.channels.push_back(id);
  }
  return ro;
}

}  // namespace

Replay::Replay() = default;
Replay::~Replay() = default;

Status Replay::open(const std::vector<std::string>& paths, const ReplayOptions& options) {
  auto impl = std::make_unique<Impl>();
  if (paths.empty()) return invalidInput("replay: no file given");
  if (options.start && options.end && *options.start > *options.end)
    return invalidInput("replay: start {} us is after end {} us", *options.start, *options.end);
  impl->paths = paths;
  for (const std::string& path : paths) {
    auto reader = std::make_unique<McapReader>();
    CDFF_RETURN_IF_ERROR(reader->open(path, options.reader));
    for (const Damage& d : reader->recovery().damages)
      impl->open_damages.push_back(fmt::format("'{}': {}", path, d.toString()));
    impl->readers.push_back(std::move(reader));
  }
  Result<ChannelIndex> index = indexChannels(impl->readers, paths);
  if (!index) return index.status();
  impl->channels = std::move(index->channels);
  impl->types = std::move(index->types);
  CDFF_RETURN_IF_ERROR(checkTopicsExist(options.channels, impl->channels, paths));
  std::tie(impl->start, impl->end) = selectionRange(impl->readers, options);
  for (std::size_t f = 0; f < impl->readers.size(); ++f) {
    impl->iterators.push_back(
        impl->readers[f]->messages(readOptionsFor(*impl->readers[f], options)));
    impl->iterator_files.push_back(f);
  }
  if (options.keep_static && options.start && *options.start > 0) {
    for (std::size_t f = 0; f < impl->readers.size(); ++f) {
      ReadOptions before = staticChannelsBefore(*impl->readers[f], impl->channels, options);
      if (before.channels.empty()) continue;
      impl->iterators.push_back(impl->readers[f]->messages(before));
      impl->iterator_files.push_back(f);
    }
  }
  impl_ = std::move(impl);
  return Status::ok();
}

const std::vector<ReplayChannel>& Replay::channels() const {
  static const std::vector<ReplayChannel> kNone;
  return impl_ ? impl_->channels : kNone;
}

const ReplayChannel* Replay::channel(std::string_view topic) const {
  for (const ReplayChannel& c : channels())
    if (c.topic == topic) return &c;
  return nullptr;
}

Timestamp Replay::startTime() const {
  return impl_ ? impl_->start : 0;
}
Timestamp Replay::endTime() const {
  return impl_ ? impl_->end : 0;
}

bool Replay::next() {
  if (!impl_) return false;
  Impl& m = *impl_;
  auto later = [&](std::size_t a, std::size_t b) { return m.later(a, b); };
  if (!m.started) {
    m.started = true;
    for (std::size_t f = 0; f < m.iterators.size(); ++f)
      if (m.iterators[f].next()) m.push(f);
  } else if (!m.heap.empty()) {
    // Advance the file whose message was delivered last.
    std::pop_heap(m.heap.begin(), m.heap.end(), later);
    const std::size_t f = m.heap.back();
    m.heap.pop_back();
    if (m.iterators[f].next()) m.push(f);
  }
  if (m.heap.empty()) return false;
  const std::size_t it = m.heap.front(), f = m.iterator_files[it];
  const MessageView& view = m.iterators[it].message();
  m.current.view_ = view;
  m.current.file_ = f;
  m.current.path_ = &m.paths[f];
  auto t = m.types[f].find(view.channel->id);
  m.current.type_ = t == m.types[f].end() ? TypeId() : t->second;
  return true;
}

const ReplayMessage& Replay::message() const {
  return impl_->current;
}

std::vector<std::string> Replay::damages() const {
  std::vector<std::string> all;
  if (!impl_) return all;
  all = impl_->open_damages;
  for (std::size_t it = 0; it < impl_->iterators.size(); ++it)
    for (const Damage& d : impl_->iterators[it].damages())
      all.push_back(fmt::format("'{}': {}", impl_->paths[impl_->iterator_files[it]], d.toString()));
  return all;
}

Status Replay::status() const {
  const auto all = damages();
  if (all.empty()) return Status::ok();
  return {StatusCode::kCorruptData, all.size() == 1 ? all.front()
                                                    : fmt::format("{} (and {} more damaged places)",
                                                                  all.front(), all.size() - 1)};
}

std::size_t Replay::fileCount() const {
  return impl_ ? impl_->readers.size() : 0;
}
const McapReader& Replay::reader(std::size_t file) const {
  return *impl_->readers.at(file);
}

}  // namespace cdff::io
