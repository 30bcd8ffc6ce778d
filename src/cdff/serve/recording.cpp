#include "cdff/serve/recording.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cdff/eval/recording_evaluation.hpp"
#include "cdff/io/inspect.hpp"
#include "cdff/io/recorder.hpp"
#include "cdff/serve/contour.hpp"
#include "cdff/serve/scene.hpp"
#include "cdff/types/codec/codec.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::serve {

using nlohmann::json;

double ChannelSummary::rateHz() const {
  if (times_ns.size() < 2 || times_ns.back() <= times_ns.front()) return 0.0;
  return static_cast<double>(times_ns.size() - 1) / ((times_ns.back() - times_ns.front()) * 1e-9);
}

bool isPoseType(const std::string& type) {
  return type == "PoseWithCovariance" || type == "RigidBodyState" || type == "Transform";
}

Result<EncodedImage> encodeJpeg(const Image& image, int max_width, int quality) {
  CDFF_RETURN_IF_ERROR(image.validate("the recorded image"));
  if (max_width < 16)
    return invalidInput("max_width = {}: too small; expected at least 16 pixels", max_width);
  cv::Mat mat = toMat(image);
  if (image.format == PixelFormat::kGray16 || image.format == PixelFormat::kFloat32) {
    cv::Mat stretched;
    cv::normalize(mat, stretched, 0, 255, cv::NORM_MINMAX, CV_8U);
    mat = stretched;
  }
  if (mat.cols > max_width) {
    const int height = std::max(
        1, static_cast<int>(std::lround(static_cast<double>(mat.rows) * max_width / mat.cols)));
    cv::Mat small;
    cv::resize(mat, small, cv::Size(max_width, height), 0, 0, cv::INTER_AREA);
    mat = small;
  }
  EncodedImage out;
  if (!cv::imencode(".jpg", mat, out.jpeg, {cv::IMWRITE_JPEG_QUALITY, quality}))
    return invalidInput("OpenCV could not encode a {}x{} {} image as JPEG", image.width,
                        image.height, toString(image.format));
  out.width = mat.cols;
  out.height = mat.rows;
  out.source_width = image.width;
  out.source_height = image.height;
  return out;
}

Result<std::unique_ptr<Recording>> Recording::open(const std::string& path) {
  std::unique_ptr<Recording> r(new Recording());
  r->path_ = path;
  CDFF_RETURN_IF_ERROR(r->reader_.open(path));
  for (const io::Damage& d : r->reader_.recovery().damages) r->damages_.push_back(d.toString());
  std::map<std::uint16_t, std::size_t> index;
  for (const auto& [id, ch] : r->reader_.channels()) {
    const io::Schema* schema = r->reader_.schemaOf(ch);
    const TypeId type = io::typeOfChannel(ch, schema);
    ChannelSummary c;
    c.id = id;
    c.topic = ch.topic;
    c.type = type ? std::string(type.name()) : "";
    c.schema = schema ? schema->name : "";
    c.message_encoding = ch.message_encoding;
    index[id] = r->channels_.size();
    r->channels_.push_back(std::move(c));
  }
  auto it = r->reader_.messages();
  bool any = false;
  while (it.next()) {
    const io::MessageView& m = it.message();
    r->channels_[index.at(m.channel->id)].times_ns.push_back(m.log_time);
    r->start_ns_ = any ? std::min(r->start_ns_, m.log_time) : m.log_time;
    r->end_ns_ = any ? std::max(r->end_ns_, m.log_time) : m.log_time;
    any = true;
    ++r->messages_;
  }
  for (const io::Damage& d : it.damages()) r->damages_.push_back(d.toString());
  for (ChannelSummary& c : r->channels_) std::sort(c.times_ns.begin(), c.times_ns.end());
  std::sort(r->channels_.begin(), r->channels_.end(),
            [](const ChannelSummary& a, const ChannelSummary& b) { return a.topic < b.topic; });
  return r;
}

std::string Recording::name() const {
  return std::filesystem::path(path_).filename().string();
}

const ChannelSummary* Recording::channel(std::string_view topic) const {
  for (const ChannelSummary& c : channels_)
    if (c.topic == topic) return &c;
  return nullptr;
}

Result<const ChannelSummary*> Recording::findChannel(const std::string& topic) const {
  if (const ChannelSummary* c = channel(topic); c && !c->times_ns.empty()) return c;
  std::vector<std::string> topics;
  for (const ChannelSummary& c : channels_)
    if (!c.times_ns.empty()) topics.push_back(c.topic);
  return notFound("channel '{}' has no messages in {}; expected one of {{{}}}", topic, name(),
                  fmt::join(topics, ", "));
}

json Recording::summary(bool with_channels) const {
  json j = {{"name", name()},
            {"messages", messages_},
            {"start_ns", start_ns_},
            {"duration_s", (end_ns_ - start_ns_) * 1e-9},
            {"damage", damages_}};
  if (!with_channels) return j;
  j["channels"] = json::array();
  for (const ChannelSummary& c : channels_) {
    json e = {{"topic", c.topic},
              {"type", c.type},
              {"schema", c.schema},
              {"message_encoding", c.message_encoding},
              {"messages", c.times_ns.size()},
              {"rate_hz", c.rateHz()}};
    if (!c.times_ns.empty()) {
      e["first_t"] = secondsOf(c.times_ns.front());
      e["last_t"] = secondsOf(c.times_ns.back());
    }
    j["channels"].push_back(std::move(e));
  }
  return j;
}

Result<std::uint64_t> Recording::timeAt(double t) const {
  const double duration = (end_ns_ - start_ns_) * 1e-9;
  if (!std::isfinite(t) || t < 0 || t > duration + 1e-9)
    return invalidInput("t = {} s is outside the recording; expected seconds in [0, {}]", t,
                        duration);
  return std::min(end_ns_, start_ns_ + static_cast<std::uint64_t>(std::llround(t * 1e9)));
}

double Recording::secondsOf(std::uint64_t log_time_ns) const {
  return log_time_ns >= start_ns_ ? (log_time_ns - start_ns_) * 1e-9
                                  : -((start_ns_ - log_time_ns) * 1e-9);
}

std::size_t Recording::indexAt(const ChannelSummary& channel, std::uint64_t log_time_ns) {
  const auto& t = channel.times_ns;
  const auto after = std::upper_bound(t.begin(), t.end(), log_time_ns);
  return after == t.begin() ? 0 : static_cast<std::size_t>(after - t.begin()) - 1;
}

Result<io::MessageView> readMessageAt(const io::McapReader& reader, const ChannelSummary& channel,
                                      std::uint64_t log_time_ns) {
  io::ReadOptions options;
  options.start_time = log_time_ns;
  options.end_time = log_time_ns;
  options.channels = {channel.id};
  auto it = reader.messages(options);
  if (it.next()) return it.message();
  if (!it.status().isOk()) return it.status();
  return notFound("no message of '{}' at log time {} ns", channel.topic, log_time_ns);
}

Result<EncodedImage> imageOf(const io::MessageView& message, int max_width, int quality) {
  Image image;
  CDFF_RETURN_IF_ERROR(codec::decode(message.data, message.owner, image)
                           .withContext(fmt::format("channel '{}'", message.channel->topic)));
  Result<EncodedImage> jpeg = encodeJpeg(image, max_width, quality);
  if (jpeg) jpeg->log_time_ns = message.log_time;
  return jpeg;
}

Result<json> Recording::messages(const std::string& topic, double t, std::size_t count) const {
  Result<const ChannelSummary*> channel = findChannel(topic);
  if (!channel) return channel.status();
  Result<std::uint64_t> at = timeAt(t);
  if (!at) return at.status();
  const ChannelSummary& c = **channel;
  const std::size_t first = indexAt(c, *at);
  const std::size_t last = std::min(c.times_ns.size(), first + count) - 1;
  io::ReadOptions options;
  options.start_time = c.times_ns[first];
  options.end_time = c.times_ns[last];
  options.channels = {c.id};
  json out = {{"channel", topic}, {"messages", json::array()}};
  std::lock_guard lock(mutex_);
  const io::Channel& mc = reader_.channels().at(c.id);
  Result<io::MessageInspector> inspector =
      io::MessageInspector::create(mc, reader_.schemaOf(mc), io::InspectOptions{});
  if (!inspector) return inspector.status();
  auto it = reader_.messages(options);
  while (out["messages"].size() < count && it.next()) {
    const io::MessageView& m = it.message();
    Result<json> data = inspector->toJson(m.data);
    if (!data) return data.status().withContext(fmt::format("channel '{}'", topic));
    out["messages"].push_back({{"t", secondsOf(m.log_time)},
                               {"log_time_ns", m.log_time},
                               {"sequence", m.sequence},
                               {"data", std::move(*data)}});
  }
  CDFF_RETURN_IF_ERROR(it.status());
  return out;
}

Result<io::MessageView> Recording::messageShownAt(const ChannelSummary& channel, double t) const {
  Result<std::uint64_t> at = timeAt(t);
  if (!at) return at.status();
  const std::uint64_t frame_ns = channel.times_ns[indexAt(channel, *at)];
  std::lock_guard lock(mutex_);
  return readMessageAt(reader_, channel, frame_ns);
}

Result<EncodedImage> Recording::imageAt(const std::string& topic, double t, int max_width,
                                        int quality) const {
  Result<const ChannelSummary*> channel = findChannel(topic);
  if (!channel) return channel.status();
  if ((*channel)->type != "Image")
    return invalidInput("channel '{}' holds {} messages; expected an Image channel", topic,
                        (*channel)->type.empty() ? (*channel)->schema : (*channel)->type);
  Result<io::MessageView> message = messageShownAt(**channel, t);
  if (!message) return message.status();
  // Encoded without the lock: the message holds its chunk, other queries go on meanwhile.
  return imageOf(*message, max_width, quality);
}

Result<std::vector<Transform>> Recording::transforms(const std::string& topic) const {
  Result<const ChannelSummary*> channel = findChannel(topic);
  if (!channel) return channel.status();
  const ChannelSummary& c = **channel;
  if (!isPoseType(c.type))
    return invalidInput(
        "channel '{}' holds {} messages; expected PoseWithCovariance, RigidBodyState or "
        "Transform",
        topic, c.type.empty() ? c.schema : c.type);
  std::vector<Transform> out;
  out.reserve(c.times_ns.size());
  io::ReadOptions options;
  options.channels = {c.id};
  std::lock_guard lock(mutex_);
  auto it = reader_.messages(options);
  while (it.next()) {
    const io::MessageView& m = it.message();
    if (c.type == "Transform") {
      CDFF_RETURN_IF_ERROR(codec::decode(m.data, m.owner, out.emplace_back())
                               .withContext(fmt::format("channel '{}'", topic)));
    } else {
      PoseWithCovariance p;
      CDFF_RETURN_IF_ERROR(
          codec::decode(m.data, m.owner, p).withContext(fmt::format("channel '{}'", topic)));
      out.push_back(std::move(p.pose));
    }
  }
  CDFF_RETURN_IF_ERROR(it.status());
  return out;
}

Result<json> Recording::poses(const std::string& topic, std::size_t max_points,
                              const std::string& via) const {
  Result<std::vector<Transform>> poses = transforms(topic);
  if (!poses) return poses.status();
  const ChannelSummary& c = *channel(topic);
  std::vector<std::uint64_t> times = c.times_ns;
  std::size_t unmatched = 0;
  if (!via.empty()) {
    Result<std::vector<Transform>> outer = transforms(via);
    if (!outer) return outer.status();
    if (!outer->empty() && !poses->empty() &&
        outer->front().child_frame != poses->front().parent_frame)
      return invalidInput(
          "via = '{}' holds {}_T_{}; expected a transform whose child frame is '{}', the parent "
          "frame of '{}'",
          via, outer->front().parent_frame, outer->front().child_frame, poses->front().parent_frame,
          topic);
    std::vector<Transform> composed;
    std::vector<std::uint64_t> composed_times;
    for (std::size_t i = 0; i < poses->size(); ++i) {
      const Transform& p = (*poses)[i];
      std::optional<Transform> o = eval::truthAt(*outer, p.stamp, {});
      if (!o) {
        ++unmatched;
        continue;
      }
      composed.push_back(Transform::fromIsometry(o->isometry() * p.isometry(), o->parent_frame,
                                                 p.child_frame, p.stamp));
      composed_times.push_back(times[i]);
    }
    *poses = std::move(composed);
    times = std::move(composed_times);
  }
  const std::size_t n = poses->size();
  const std::size_t stride = std::max<std::size_t>(1, (n + max_points - 1) / max_points);
  json cols = {{"channel", topic}, {"stride", stride}};
  std::vector<double> t, x, y, z, qw, qx, qy, qz;
  for (std::size_t i = 0; i < n; ++i) {
    // Every stride-th pose, and the last one while there is room for it.
    if (i % stride != 0 && (i + 1 != n || t.size() >= max_points)) continue;
    const Transform& pose = (*poses)[i];
    t.push_back(secondsOf(times[i]));
    x.push_back(pose.translation.x());
    y.push_back(pose.translation.y());
    z.push_back(pose.translation.z());
    qw.push_back(pose.rotation.w());
    qx.push_back(pose.rotation.x());
    qy.push_back(pose.rotation.y());
    qz.push_back(pose.rotation.z());
  }
  if (!via.empty()) cols.update({{"via", via}, {"unmatched", unmatched}});
  cols.update({{"frame", n ? poses->back().parent_frame : ""},
               {"child_frame", n ? poses->back().child_frame : ""},
               {"t", t},
               {"x", x},
               {"y", y},
               {"z", z},
               {"qw", qw},
               {"qx", qx},
               {"qy", qy},
               {"qz", qz}});
  return cols;
}

Result<TriangleMesh> Recording::mesh(const std::string& topic) const {
  Result<const ChannelSummary*> channel = findChannel(topic);
  if (!channel) return channel.status();
  const ChannelSummary& c = **channel;
  if (c.type != "TriangleMesh")
    return invalidInput("channel '{}' holds {} messages; expected a TriangleMesh channel", topic,
                        c.type.empty() ? c.schema : c.type);
  if (c.times_ns.empty()) return notFound("channel '{}' has no message", topic);
  Result<io::MessageView> message = [&] {
    std::lock_guard lock(mutex_);
    return readMessageAt(reader_, c, c.times_ns.front());
  }();
  if (!message) return message.status();
  TriangleMesh mesh;
  CDFF_RETURN_IF_ERROR(codec::decode(message->data, message->owner, mesh)
                           .withContext(fmt::format("channel '{}'", topic)));
  return mesh;
}

Result<std::string> Recording::meshBody(const std::string& topic) const {
  Result<TriangleMesh> m = mesh(topic);
  if (!m) return m.status();
  return serve::meshBody(*m, {{"channel", topic}, {"source", topic}});
}

Result<Transform> Recording::mounting(const std::string& parent, const std::string& child) const {
  std::vector<std::string> seen;
  for (const ChannelSummary& c : channels_) {
    if (c.type != "Transform" || c.times_ns.empty()) continue;
    Result<io::MessageView> message = [&] {
      std::lock_guard lock(mutex_);
      return readMessageAt(reader_, c, c.times_ns.front());
    }();
    if (!message) return message.status();
    Transform t;
    CDFF_RETURN_IF_ERROR(codec::decode(message->data, message->owner, t)
                             .withContext(fmt::format("channel '{}'", c.topic)));
    if (t.parent_frame == parent && t.child_frame == child) return t;
    seen.push_back(fmt::format("{} ({}_T_{})", c.topic, t.parent_frame, t.child_frame));
  }
  return notFound("no Transform channel holds {}_T_{}; expected one among {}", parent, child,
                  seen.empty() ? std::string("the recording's (it has none)")
                               : fmt::format("{}", fmt::join(seen, ", ")));
}

Result<json> Recording::contour(const std::string& image_topic, double t,
                                const std::string& pose_topic,
                                const std::string& mesh_topic) const {
  Result<const ChannelSummary*> channel = findChannel(image_topic);
  if (!channel) return channel.status();
  if ((*channel)->type != "Image")
    return invalidInput("image = '{}' holds {} messages; expected an Image channel", image_topic,
                        (*channel)->type.empty() ? (*channel)->schema : (*channel)->type);
  std::string model = mesh_topic;
  if (model.empty()) {
    for (const ChannelSummary& c : channels_)
      if (c.type == "TriangleMesh" && !c.times_ns.empty()) {
        model = c.topic;
        break;
      }
    if (model.empty())
      return notFound("the recording has no TriangleMesh channel; expected mesh=<channel>");
  }
  Result<TriangleMesh> mesh_value = mesh(model);
  if (!mesh_value) return mesh_value.status();
  Result<io::MessageView> message = messageShownAt(**channel, t);
  if (!message) return message.status();
  const std::uint64_t frame_ns = message->log_time;
  Image image;
  CDFF_RETURN_IF_ERROR(codec::decode(message->data, message->owner, image)
                           .withContext(fmt::format("channel '{}'", image_topic)));
  if (!image.camera)
    return invalidInput(
        "the image of '{}' at {:.3f} s has no camera model; expected a calibrated camera's "
        "images",
        image_topic, secondsOf(frame_ns));
  Result<std::vector<Transform>> poses = transforms(pose_topic);
  if (!poses) return poses.status();
  std::optional<Transform> pose = eval::truthAt(*poses, image.stamp, {});
  if (!pose)
    return notFound("'{}' has no pose within 0.5 s of the image at {:.3f} s", pose_topic,
                    secondsOf(frame_ns));
  Transform camera_T_parent = Transform::identity(image.frame_id, pose->parent_frame);
  if (pose->parent_frame != image.frame_id) {
    Result<Transform> mount = mounting(pose->parent_frame, image.frame_id);
    if (!mount) return mount.status();
    camera_T_parent = mount->inverse();
  }
  Result<MeshOutline> outline = MeshOutline::of(*mesh_value);
  if (!outline) return outline.status().withContext(fmt::format("channel '{}'", model));
  const Transform camera_T_model = Transform::fromIsometry(
      camera_T_parent.isometry() * pose->isometry(), image.frame_id, pose->child_frame);
  Result<std::vector<std::array<float, 4>>> segments =
      outline->project(camera_T_model, *image.camera);
  if (!segments) return segments.status();
  json out = contourJson(*segments);
  out.update({{"t", secondsOf(frame_ns)},
              {"frame", image.frame_id},
              {"source_width", image.width},
              {"source_height", image.height},
              {"pose", pose_topic},
              {"mesh", model}});
  return out;
}

Result<json> Recording::errors(const std::string& estimate, const std::string& truth,
                               std::size_t max_points) const {
  Result<const ChannelSummary*> product = findChannel(estimate);
  if (!product) return product.status();
  if (!truth.empty()) {
    Result<const ChannelSummary*> t = findChannel(truth);
    if (!t) return t.status();
  }
  eval::RecordingEvaluationOptions options;
  options.products = {estimate};
  if (!truth.empty()) options.pairs[estimate] = truth;
  Result<eval::EvaluationReport> report = eval::evaluateRecording({path_}, options);
  if (!report) return report.status();
  const auto it =
      std::find_if(report->products.begin(), report->products.end(),
                   [&](const eval::PoseEvaluation& p) { return p.channel == estimate; });
  if (it == report->products.end())
    return notFound(
        "'{}' has no truth of the same transform in this recording; expected a /truth/ pose "
        "channel of its frames (or truth=<channel>)",
        estimate);
  const std::size_t n = it->errors.size();
  const std::size_t stride = std::max<std::size_t>(1, (n + max_points - 1) / max_points);
  json cols = {{"estimate", estimate},
               {"truth", it->truth_channel},
               {"frame", it->parent_frame},
               {"child_frame", it->child_frame},
               {"stride", stride},
               {"frames", it->frames},
               {"valid_frames", it->valid_frames},
               {"matched_frames", it->matched_frames},
               {"requirements", poseThresholdsJson()}};
  std::vector<double> t, pos, ang, range;
  std::vector<json> pos_limit, ang_limit, requirement;
  for (std::size_t i = 0; i < n; i += stride) {
    const eval::MatchedError& m = it->errors[i];
    PoseError e;
    e.range_m = m.range_m;
    applyThresholds(e);
    t.push_back(secondsOf(static_cast<std::uint64_t>(m.stamp) * 1000));
    pos.push_back(m.position_error_m);
    ang.push_back(m.angle_error_deg);
    range.push_back(m.range_m);
    pos_limit.push_back(e.position_threshold_m ? json(*e.position_threshold_m) : json());
    ang_limit.push_back(e.angle_threshold_deg ? json(*e.angle_threshold_deg) : json());
    requirement.push_back(e.requirement);
  }
  cols.update({{"t", t},
               {"position_error_m", pos},
               {"angle_error_deg", ang},
               {"range_m", range},
               {"position_threshold_m", pos_limit},
               {"angle_threshold_deg", ang_limit},
               {"requirement", requirement}});
  return cols;
}

Result<std::unique_ptr<io::McapReader>> Recording::openReader() const {
  auto reader = std::make_unique<io::McapReader>();
  CDFF_RETURN_IF_ERROR(reader->open(path_));
  return reader;
}

}  // namespace cdff::serve
