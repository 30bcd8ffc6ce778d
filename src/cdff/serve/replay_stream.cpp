#include "cdff/serve/replay_stream.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "cdff/serve/scene.hpp"
#include "cdff/types/codec/codec.hpp"

namespace cdff::serve {

using nlohmann::json;

namespace {

// An image more than this behind its time is skipped: the replay keeps its pace when encoding
// cannot keep up (the browser's copy is decimated, never slowed).
constexpr auto kLateImage = std::chrono::milliseconds(200);

}  // namespace

Status validate(const Recording& recording, const StreamSpec& spec) {
  if (spec.image.empty() && spec.poses.empty() && spec.points.empty())
    return invalidInput(
        "no channel to stream; expected image=<Image channel>, pose=<pose channel> and/or "
        "points=<PointCloud channel> in the query");
  if (!spec.points.empty()) {
    Result<const ChannelSummary*> c = recording.findChannel(spec.points);
    if (!c) return c.status();
    if ((*c)->type != "PointCloud")
      return invalidInput("points = '{}' holds {} messages; expected a PointCloud channel",
                          spec.points, (*c)->type.empty() ? (*c)->schema : (*c)->type);
  }
  if (spec.max_points < 1 || spec.max_points > kMaxCloudPoints)
    return invalidInput("max_points = {}: expected a number of points in [1, {}]", spec.max_points,
                        kMaxCloudPoints);
  if (!spec.image.empty()) {
    Result<const ChannelSummary*> c = recording.findChannel(spec.image);
    if (!c) return c.status();
    if ((*c)->type != "Image")
      return invalidInput("image = '{}' holds {} messages; expected an Image channel", spec.image,
                          (*c)->type.empty() ? (*c)->schema : (*c)->type);
  }
  for (const std::string& topic : spec.poses) {
    Result<const ChannelSummary*> c = recording.findChannel(topic);
    if (!c) return c.status();
    if (!isPoseType((*c)->type))
      return invalidInput(
          "pose = '{}' holds {} messages; expected PoseWithCovariance, RigidBodyState or "
          "Transform",
          topic, (*c)->type.empty() ? (*c)->schema : (*c)->type);
  }
  if (spec.max_width < 16 || spec.max_width > 4096)
    return invalidInput("max_width = {}: expected pixels in [16, 4096]", spec.max_width);
  return Status::ok();
}

std::string binaryFrame(const json& header, const std::vector<std::uint8_t>& payload) {
  const std::string head = header.dump();
  const auto n = static_cast<std::uint32_t>(head.size());
  std::string out;
  out.reserve(4 + head.size() + payload.size());
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((n >> (8 * i)) & 0xff));
  out += head;
  out.append(reinterpret_cast<const char*>(payload.data()), payload.size());
  return out;
}

ReplayStream::ReplayStream(const Recording& recording, StreamSpec spec, Sink sink,
                           DroppedCount dropped)
    : recording_(recording),
      spec_(std::move(spec)),
      sink_(std::move(sink)),
      dropped_(std::move(dropped)) {}

Result<std::unique_ptr<ReplayStream>> ReplayStream::start(const Recording& recording,
                                                          StreamSpec spec, Sink sink,
                                                          DroppedCount dropped) {
  CDFF_RETURN_IF_ERROR(validate(recording, spec));
  std::unique_ptr<ReplayStream> s(
      new ReplayStream(recording, std::move(spec), std::move(sink), std::move(dropped)));
  Result<std::unique_ptr<io::McapReader>> reader = recording.openReader();
  if (!reader) return reader.status();
  s->reader_ = std::move(*reader);
  if (!s->spec_.image.empty()) s->channel_ids_.push_back(recording.channel(s->spec_.image)->id);
  for (const std::string& topic : s->spec_.poses)
    s->channel_ids_.push_back(recording.channel(topic)->id);
  if (!s->spec_.points.empty()) s->channel_ids_.push_back(recording.channel(s->spec_.points)->id);
  s->seek_to_ = recording.startNs();
  s->thread_ = std::thread([p = s.get()] { p->run(); });
  return s;
}

ReplayStream::~ReplayStream() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::uint64_t ReplayStream::now() const {
  if (!playing_) return position_;
  const double elapsed = std::chrono::duration<double>(Clock::now() - anchor_wall_).count();
  const auto t = anchor_ns_ + static_cast<std::uint64_t>(std::max(0.0, elapsed * speed_ * 1e9));
  const std::uint64_t limit = pending_ ? pending_->log_time : recording_.endNs();
  return std::min(t, std::max(limit, position_));
}

Status ReplayStream::command(const json& command) {
  if (!command.is_object() || !command.contains("cmd") || !command["cmd"].is_string())
    return invalidInput(
        "command {}: expected an object with \"cmd\": one of play, pause, seek, "
        "speed",
        command.dump());
  const std::string cmd = command["cmd"];
  std::unique_lock lock(mutex_);
  if (cmd == "play") {
    if (!playing_) {
      anchor_ns_ = position_;
      anchor_wall_ = Clock::now();
      playing_ = true;
    }
  } else if (cmd == "pause") {
    position_ = now();
    playing_ = false;
  } else if (cmd == "seek") {
    if (!command.contains("t") || !command["t"].is_number())
      return invalidInput("seek: \"t\" = {}: expected seconds from the recording's start",
                          command.value("t", json()).dump());
    Result<std::uint64_t> t = recording_.timeAt(command["t"].get<double>());
    if (!t) return t.status().withContext("seek");
    seek_to_ = *t;
    seek_ = true;
  } else if (cmd == "speed") {
    const json v = command.value("value", json());
    if (!v.is_number() || !(v.get<double>() >= 1.0 / 64 && v.get<double>() <= 64))
      return invalidInput("speed: \"value\" = {}: expected a factor in [0.015625, 64]", v.dump());
    anchor_ns_ = now();
    anchor_wall_ = Clock::now();
    speed_ = v.get<double>();
  } else {
    return invalidInput("command '{}' is unknown; expected one of play, pause, seek, speed", cmd);
  }
  lock.unlock();
  wake_.notify_all();
  if (cmd != "seek") {
    std::lock_guard again(mutex_);
    sendState(false);
  }
  return Status::ok();
}

void ReplayStream::sendState(bool ended) {
  json state = {{"type", "state"}, {"playing", playing_},
                {"speed", speed_}, {"t", recording_.secondsOf(now())},
                {"ended", ended},  {"dropped", dropped_ ? dropped_() : 0}};
  sink_({false, state.dump()});
}

void ReplayStream::emit(const io::MessageView& message, bool late) {
  const std::string& topic = message.channel->topic;
  if (topic == spec_.image) {
    if (late) return;
    Result<EncodedImage> jpeg = imageOf(message, spec_.max_width, spec_.quality);
    if (!jpeg) {
      sink_({false, json{{"type", "error"}, {"error", jpeg.status().message()}}.dump()});
      return;
    }
    const json header = {{"type", "image"},
                         {"channel", topic},
                         {"t", recording_.secondsOf(message.log_time)},
                         {"log_time_ns", message.log_time},
                         {"width", jpeg->width},
                         {"height", jpeg->height},
                         {"source_width", jpeg->source_width},
                         {"source_height", jpeg->source_height}};
    sink_({true, binaryFrame(header, jpeg->jpeg)});
    return;
  }
  if (topic == spec_.points) {
    if (late) return;
    PointCloud cloud;
    if (Status s = codec::decode(message.data, message.owner, cloud); !s.isOk()) {
      sink_({false, json{{"type", "error"}, {"error", s.withContext(topic).message()}}.dump()});
      return;
    }
    const json header = {{"channel", topic},
                         {"t", recording_.secondsOf(message.log_time)},
                         {"log_time_ns", message.log_time}};
    sink_({true, pointsFrame(header, cloud, decimateCloud(cloud, spec_.max_points))});
    return;
  }
  PoseWithCovariance pose;
  Status s = recording_.channel(topic)->type == "Transform"
                 ? codec::decode(message.data, message.owner, pose.pose)
                 : codec::decode(message.data, message.owner, pose);
  if (!s.isOk()) {
    sink_({false, json{{"type", "error"}, {"error", s.withContext(topic).message()}}.dump()});
    return;
  }
  const Transform& p = pose.pose;
  const json frame = {{"type", "pose"},
                      {"channel", topic},
                      {"t", recording_.secondsOf(message.log_time)},
                      {"log_time_ns", message.log_time},
                      {"p", {p.translation.x(), p.translation.y(), p.translation.z()}},
                      {"q", {p.rotation.w(), p.rotation.x(), p.rotation.y(), p.rotation.z()}}};
  sink_({false, frame.dump()});
}

void ReplayStream::seekTo(std::uint64_t log_time_ns) {
  std::vector<std::string> topics = spec_.poses;
  if (!spec_.image.empty()) topics.insert(topics.begin(), spec_.image);
  if (!spec_.points.empty()) topics.push_back(spec_.points);
  for (const std::string& topic : topics) {
    const ChannelSummary& c = *recording_.channel(topic);
    const std::uint64_t at = c.times_ns[Recording::indexAt(c, log_time_ns)];
    Result<io::MessageView> m = readMessageAt(*reader_, c, at);
    if (m)
      emit(*m, false);
    else
      sink_({false, json{{"type", "error"}, {"error", m.status().message()}}.dump()});
  }
  io::ReadOptions options;
  options.start_time = log_time_ns + 1;
  options.channels = channel_ids_;
  iterator_.emplace(reader_->messages(options));
}

void ReplayStream::run() {
  std::unique_lock lock(mutex_);
  while (!stop_) {
    if (seek_) {
      seek_ = false;
      pending_.reset();
      position_ = anchor_ns_ = seek_to_;
      anchor_wall_ = Clock::now();
      const std::uint64_t to = seek_to_;
      lock.unlock();
      seekTo(to);
      lock.lock();
      sendState(false);
      continue;
    }
    if (!playing_) {
      wake_.wait(lock);
      continue;
    }
    if (!pending_) {
      lock.unlock();
      const bool more = iterator_->next();
      lock.lock();
      if (seek_) continue;  // the iterator was replaced
      if (!more) {
        position_ = recording_.endNs();
        playing_ = false;
        sendState(true);
        continue;
      }
      pending_ = iterator_->message();
      continue;
    }
    const auto due =
        anchor_wall_ +
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
            (pending_->log_time - std::min(pending_->log_time, anchor_ns_)) * 1e-9 / speed_));
    if (Clock::now() < due) {
      wake_.wait_until(lock, due);
      continue;
    }
    const io::MessageView message = *pending_;
    pending_.reset();
    position_ = message.log_time;
    const bool late = Clock::now() - due > kLateImage;
    lock.unlock();
    emit(message, late);
    lock.lock();
  }
}

}  // namespace cdff::serve
