#pragma once
// Replaying recordings: one or several MCAP files merged in log-time order, with each message's
// channel, time, schema and a decode to the CDFF type that the DFN layer's ports carry.
//
//   cdff::io::Replay replay;
//   CDFF_RETURN_IF_ERROR(replay.open({"sensors.mcap", "truth.mcap"}, {.channels = {...}}));
//   while (replay.next()) {
//     const auto& m = replay.message();
//     Result<Value> value = m.decode();       // any registered type, known at run time
//     if (value) port.setAny(*value);
//   }
//   CDFF_RETURN_IF_ERROR(replay.status());     // damage met on the way (file, byte offset)

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cdff/io/mcap.hpp"
#include "cdff/io/recorder.hpp"

namespace cdff::io {

struct ReplayOptions {
  std::optional<Timestamp> start;     // us, inclusive; none: from the beginning
  std::optional<Timestamp> end;       // us, inclusive; none: to the end
  std::vector<std::string> channels;  // topics; empty: every channel
  /// With `start`: also the messages before it on the channels that hold a single message in
  /// the files (static ones: a sensor's mounting, the target's mesh), first, at their own
  /// times, so that a window of a recording still has what was recorded once at its beginning.
  bool keep_static = false;
  McapReaderOptions reader;
};

/// A channel as seen across the replayed files (matched by topic).
struct ReplayChannel {
  std::string topic;
  TypeId type;  // not valid when not a CDFF type (e.g. a ROS 2 message)
  std::string schema_name;
  std::string message_encoding;
  std::uint64_t message_count = 0;
  std::vector<std::size_t> files;  // indices of the files that have it
};

class ReplayMessage {
 public:
  const std::string& channel() const { return view_.channel->topic; }
  Timestamp logTime() const { return fromMcapTime(view_.log_time); }
  std::uint64_t logTimeNs() const { return view_.log_time; }
  std::uint64_t publishTimeNs() const { return view_.publish_time; }
  std::uint32_t sequence() const { return view_.sequence; }
  std::string_view schemaName() const;
  /// The channel's CDFF type; not valid when it is none of ours.
  TypeId type() const { return type_; }
  const std::string& messageEncoding() const { return view_.channel->message_encoding; }
  Bytes data() const { return view_.data; }
  std::size_t fileIndex() const { return file_; }
  const MessageView& view() const { return view_; }

  /// The value as its CDFF type (type()); large arrays share the chunk's memory.
  Result<Value> decode() const;
  /// The value as T; fails when the channel's schema does not hold T (a RigidBodyState channel
  /// reads as a PoseWithCovariance: they share their schema).
  template <RegisteredType T>
  Result<std::shared_ptr<const T>> decode() const {
    CDFF_RETURN_IF_ERROR(checkDecodableAs(TypeId::of<T>()));
    auto value = std::make_shared<T>();
    CDFF_RETURN_IF_ERROR(codec::decode(view_.data, view_.owner, *value).withContext(context()));
    return std::shared_ptr<const T>(std::move(value));
  }

 private:
  friend class Replay;
  Status checkDecodableAs(TypeId type) const;
  std::string context() const;

  MessageView view_;
  TypeId type_;
  std::size_t file_ = 0;
  const std::string* path_ = nullptr;
};

class Replay {
 public:
  Replay();
  ~Replay();
  Replay(const Replay&) = delete;
  Replay& operator=(const Replay&) = delete;

  /// Opens the files and prepares a merged iteration. Fails when a file cannot be read at all,
  /// when a requested channel is in none of them (the message lists the channels), or when two
  /// files disagree on a channel's schema.
  Status open(const std::vector<std::string>& paths, const ReplayOptions& options = {});

  const std::vector<ReplayChannel>& channels() const;
  const ReplayChannel* channel(std::string_view topic) const;
  /// Time range of the selected messages (us), from the files' statistics.
  Timestamp startTime() const;
  Timestamp endTime() const;

  /// Advances to the next message in log-time order (ties: file order, then file position).
  bool next();
  const ReplayMessage& message() const;

  /// Ok, or the first damage met: in a file's recovery report at open, or during iteration.
  Status status() const;
  /// Every damage so far, as "path: byte offset N: what".
  std::vector<std::string> damages() const;

  std::size_t fileCount() const;
  const McapReader& reader(std::size_t file) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdff::io
