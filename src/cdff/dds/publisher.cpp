#include "cdff/dds/publisher.hpp"

#include <fmt/format.h>

namespace cdff::dds {

Publisher::Publisher(Participant& participant, WriterQos qos, Encoding encoding)
    : participant_(participant), qos_(std::move(qos)), encoding_(encoding) {}

Publisher::~Publisher() {
  for (auto& [channel, w] : writers_) {
    dds_delete(w.writer);
    if (w.camera_info != 0) dds_delete(w.camera_info);
  }
}

Status Publisher::prepare(const std::string& channel, TypeId type, const std::string& child_frame) {
  if (auto found = writers_.find(channel); found != writers_.end()) {
    if (found->second.type != type)
      return invalidInput("channel '{}' carries {}; expected {} as before", channel, type.name(),
                          found->second.type.name());
    return Status::ok();
  }
  const WireType wire = wireTypeOf(type, encoding_);
  Writer w;
  w.type = type;
  w.child_frame = child_frame;
  WriterQos qos = qos_;
  if (wire == WireType::kPoseWithCovarianceStamped)
    qos.user_data = fmt::format("{}={};", kChildFrameKey, child_frame);
  Result<dds_entity_t> topic =
      participant_.topic(topicOfChannel(channel), wireInfo(wire).descriptor);
  if (!topic) return topic.status().withContext(fmt::format("channel '{}'", channel));
  Result<dds_entity_t> writer = participant_.createWriter(*topic, qos);
  if (!writer) return writer.status().withContext(fmt::format("channel '{}'", channel));
  w.writer = *writer;
  if (wire == WireType::kImage) {
    const std::string info_channel = cameraInfoChannel(channel);
    Result<dds_entity_t> info_topic = participant_.topic(
        topicOfChannel(info_channel), wireInfo(WireType::kCameraInfo).descriptor);
    if (!info_topic) return info_topic.status().withContext(fmt::format("channel '{}'", channel));
    Result<dds_entity_t> info = participant_.createWriter(*info_topic, qos_);
    if (!info) return info.status().withContext(fmt::format("channel '{}'", info_channel));
    w.camera_info = *info;
  }
  writers_.emplace(channel, w);
  return Status::ok();
}

Result<Publisher::Writer*> Publisher::writerFor(const dfpc::Message& message) {
  const PoseWithCovariance* pose = message.as<PoseWithCovariance>();
  const std::string child_frame = pose ? pose->pose.child_frame : "";
  CDFF_RETURN_IF_ERROR(prepare(message.channel, message.type(), child_frame));
  Writer& w = writers_.at(message.channel);
  if (pose && wireTypeOf(w.type, encoding_) == WireType::kPoseWithCovarianceStamped &&
      w.child_frame != child_frame)
    return invalidInput(
        "channel '{}': a pose of child frame '{}' after poses of '{}'; expected one child frame "
        "per channel (a PoseWithCovarianceStamped carries it in its writer's user data)",
        message.channel, child_frame, w.child_frame);
  return &w;
}

Status Publisher::write(dds_entity_t writer, const void* sample, const std::string& channel) {
  // Source times strictly increase, so that readers can restore the order of publication.
  last_source_time_ = std::max(dds_time(), last_source_time_ + 1);
  if (dds_return_t rc = dds_write_ts(writer, sample, last_source_time_); rc < 0)
    return ddsError(rc, fmt::format("writing on '{}'", topicOfChannel(channel)));
  ++published_;
  return Status::ok();
}

Status Publisher::publish(const dfpc::Message& message) {
  Result<Writer*> w = writerFor(message);
  if (!w) return w.status();
  Status encoded = encodeSample(message.value, message.stamp, sample_, encoding_);
  if (!encoded) return encoded.withContext(fmt::format("channel '{}'", message.channel));
  if (const Image* image = message.as<Image>(); image && image->camera && (*w)->camera_info) {
    const std::string info_channel = cameraInfoChannel(message.channel);
    Status info = encodeCameraInfo(*image->camera, image->stamp, image->frame_id, camera_sample_);
    if (!info) return info.withContext(fmt::format("channel '{}'", info_channel));
    CDFF_RETURN_IF_ERROR(write((*w)->camera_info, camera_sample_.data(), info_channel));
  }
  return write((*w)->writer, sample_.data(), message.channel);
}

int Publisher::matchedReaders(const std::string& channel) const {
  auto found = writers_.find(channel);
  if (found == writers_.end()) return 0;
  dds_publication_matched_status_t status{};
  if (dds_get_publication_matched_status(found->second.writer, &status) < 0) return 0;
  return static_cast<int>(status.current_count);
}

Status Publisher::waitForAcknowledgements(double timeout_s) {
  const dds_duration_t timeout = static_cast<dds_duration_t>(timeout_s * 1e9);
  for (const auto& [channel, w] : writers_) {
    for (dds_entity_t writer : {w.writer, w.camera_info}) {
      if (writer == 0) continue;
      if (dds_return_t rc = dds_wait_for_acks(writer, timeout); rc < 0)
        return ddsError(rc, fmt::format("waiting for the readers of '{}' to acknowledge",
                                        topicOfChannel(channel)));
    }
  }
  return Status::ok();
}

}  // namespace cdff::dds
