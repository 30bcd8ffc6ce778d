#include "cdff/dds/subscriber.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "cdff/dds/publisher.hpp"
#include "cdff/dfpc/orchestrator.hpp"

namespace cdff::dds {

namespace {

constexpr std::size_t kCamerasKept = 32;  // camera models kept per camera info channel
constexpr std::uint32_t kBatch = 64;      // samples taken per call

}  // namespace

/// One received sample, converted, with the time it was published.
struct Subscriber::Taken {
  dds_time_t source_time = 0;
  std::size_t order = 0;  // arrival order, for equal source times
  Reader* reader = nullptr;
  Result<std::vector<Decoded>> decoded = std::vector<Decoded>{};
  Timestamp header_stamp = 0;
};

Subscriber::Subscriber(Participant& participant, Encoding encoding)
    : participant_(participant), encoding_(encoding) {
  waitset_ = dds_create_waitset(participant_.handle());
}

Subscriber::~Subscriber() {
  for (const auto& r : readers_) dds_delete(r->reader);
  if (discovery_ != 0) dds_delete(discovery_);
  if (waitset_ > 0) dds_delete(waitset_);
}

Status Subscriber::addReader(const std::string& channel, WireType wire, TypeId expected, bool emit,
                             Durability durability) {
  if (waitset_ < 0) return ddsError(waitset_, "creating a DDS waitset");
  Result<dds_entity_t> topic =
      participant_.topic(topicOfChannel(channel), wireInfo(wire).descriptor);
  if (!topic) return topic.status().withContext(fmt::format("channel '{}'", channel));
  Result<dds_entity_t> reader = participant_.createReader(*topic, ReaderQos{durability});
  if (!reader) return reader.status().withContext(fmt::format("channel '{}'", channel));
  if (dds_return_t rc = dds_waitset_attach(waitset_, *reader, *reader); rc < 0)
    return ddsError(rc, fmt::format("waiting on channel '{}'", channel));
  auto r = std::make_unique<Reader>();
  r->channel = channel;
  r->wire = wire;
  r->expected = expected;
  r->emit = emit;
  r->reader = *reader;
  readers_.push_back(std::move(r));
  if (emit) {
    const TypeId type = wire == WireType::kRecord ? expected : cdffTypeOf(wire);
    channel_types_[channel] = type;
    new_channels_.push_back(channel);
  }
  return Status::ok();
}

Status Subscriber::subscribe(const std::string& channel, TypeId type) {
  if (!type) return invalidParameter("channel '{}': no type; expected a CDFF type", channel);
  if (channel_types_.count(channel))
    return invalidParameter("channel '{}' is subscribed already", channel);
  const WireType wire = wireTypeOf(type, encoding_);
  CDFF_RETURN_IF_ERROR(addReader(channel, wire, wire == WireType::kRecord ? type : TypeId(), true,
                                 Durability::kVolatile));
  if (wire == WireType::kImage)
    CDFF_RETURN_IF_ERROR(addReader(cameraInfoChannel(channel), WireType::kCameraInfo, TypeId(),
                                   false, Durability::kVolatile));
  return Status::ok();
}

Status Subscriber::subscribeDiscovered(std::vector<std::string> patterns) {
  if (discovery_ != 0) return invalidParameter("subscribeDiscovered() was called already");
  patterns_ = std::move(patterns);
  discovery_ =
      dds_create_reader(participant_.handle(), DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  if (discovery_ < 0) return ddsError(discovery_, "reading the DDS publications");
  if (dds_return_t rc = dds_set_status_mask(discovery_, DDS_DATA_AVAILABLE_STATUS); rc < 0)
    return ddsError(rc, "reading the DDS publications");
  if (dds_return_t rc = dds_waitset_attach(waitset_, discovery_, discovery_); rc < 0)
    return ddsError(rc, "waiting on the DDS publications");
  return discover();
}

Status Subscriber::discover() {
  void* samples[kBatch] = {};
  dds_sample_info_t infos[kBatch];
  for (;;) {
    const dds_return_t n = dds_take(discovery_, samples, infos, kBatch, kBatch);
    if (n < 0) return ddsError(n, "reading the DDS publications");
    if (n == 0) return Status::ok();
    Status status;
    for (dds_return_t i = 0; i < n && status.isOk(); ++i) {
      if (!infos[i].valid_data) continue;
      const auto* ep = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
      const std::optional<std::string> channel = channelOfTopic(ep->topic_name);
      const std::optional<WireType> wire = wireTypeNamed(ep->type_name);
      if (!channel || !wire || channel_types_.count(*channel)) continue;
      const bool wanted =
          patterns_.empty() || std::any_of(patterns_.begin(), patterns_.end(), [&](const auto& p) {
            return dfpc::matchesChannelPattern(*channel, p);
          });
      if (!wanted) continue;
      dds_durability_kind_t durability = DDS_DURABILITY_VOLATILE;
      dds_qget_durability(ep->qos, &durability);
      status = addReader(*channel, *wire, TypeId(), true,
                         durability == DDS_DURABILITY_TRANSIENT_LOCAL ? Durability::kTransientLocal
                                                                      : Durability::kVolatile);
    }
    dds_return_loan(discovery_, samples, n);
    CDFF_RETURN_IF_ERROR(status);
  }
}

const std::string& Subscriber::childFrame(Reader& reader, dds_instance_handle_t publication) {
  auto found = reader.child_frames.find(publication);
  if (found != reader.child_frames.end()) return found->second;
  std::string frame;
  if (dds_builtintopic_endpoint_t* ep =
          dds_get_matched_publication_data(reader.reader, publication)) {
    void* data = nullptr;
    std::size_t size = 0;
    if (dds_qget_userdata(ep->qos, &data, &size) && data != nullptr) {
      frame = userDataValue(std::string_view(static_cast<const char*>(data), size), kChildFrameKey);
      dds_free(data);
    }
    dds_builtintopic_free_endpoint(ep);
  }
  return reader.child_frames.emplace(publication, frame).first->second;
}

Status Subscriber::take(Reader& reader, std::vector<Taken>& taken) {
  void* samples[kBatch] = {};
  dds_sample_info_t infos[kBatch];
  for (;;) {
    const dds_return_t n = dds_take(reader.reader, samples, infos, kBatch, kBatch);
    if (n < 0) return ddsError(n, fmt::format("taking samples of '{}'", reader.channel));
    if (n == 0) return Status::ok();
    for (dds_return_t i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      IncomingContext context{reader.channel, "", reader.expected};
      if (reader.wire == WireType::kPoseWithCovarianceStamped)
        context.child_frame = childFrame(reader, infos[i].publication_handle);
      Taken t;
      t.source_time = infos[i].source_timestamp;
      t.order = taken.size();
      t.reader = &reader;
      t.decoded = decodeSample(reader.wire, samples[i], context);
      // Every wire type begins with its header but TFMessage (whose transforms have their own).
      if (reader.wire != WireType::kTfMessage)
        t.header_stamp =
            fromRosTime(static_cast<const std_msgs_msg_dds__Header_*>(samples[i])->stamp);
      taken.push_back(std::move(t));
    }
    dds_return_loan(reader.reader, samples, n);
  }
}

void Subscriber::deliver(Taken& t, std::vector<dfpc::Message>& messages,
                         std::vector<Rejection>& rejections) {
  Reader& r = *t.reader;
  if (!t.decoded) {
    rejections.push_back({r.channel, t.header_stamp,
                          t.decoded.status().withContext(fmt::format("channel '{}' ({})", r.channel,
                                                                     wireInfo(r.wire).type_name))});
    return;
  }
  for (Decoded& d : *t.decoded) {
    if (const CameraModel* camera = d.value.get<CameraModel>()) {
      std::map<Timestamp, CameraModel>& kept = cameras_[r.channel];
      kept[d.stamp] = *camera;
      while (kept.size() > kCamerasKept) kept.erase(kept.begin());
    }
    if (!r.emit) continue;
    if (const Image* image = d.value.get<Image>()) {
      auto kept = cameras_.find(cameraInfoChannel(r.channel));
      if (kept != cameras_.end())
        if (auto camera = kept->second.find(d.stamp); camera != kept->second.end()) {
          Image with_camera = *image;
          with_camera.camera = camera->second;
          d.value = Value::of(std::move(with_camera));
        }
    }
    if (r.wire == WireType::kRecord && !r.expected) {
      // A recorded channel holds one type: the first sample's.
      r.expected = d.value.type();
      channel_types_[r.channel] = r.expected;
    }
    messages.push_back({r.channel, d.stamp, std::move(d.value)});
  }
}

Status Subscriber::poll(double timeout_s, std::vector<dfpc::Message>& messages,
                        std::vector<Rejection>& rejections) {
  if (waitset_ < 0) return ddsError(waitset_, "creating a DDS waitset");
  const dds_return_t woken =
      dds_waitset_wait(waitset_, nullptr, 0, static_cast<dds_duration_t>(timeout_s * 1e9));
  if (woken < 0) return ddsError(woken, "waiting for DDS samples");
  if (discovery_ != 0) CDFF_RETURN_IF_ERROR(discover());
  std::vector<Taken> taken;
  for (const auto& r : readers_) CDFF_RETURN_IF_ERROR(take(*r, taken));
  std::stable_sort(taken.begin(), taken.end(),
                   [](const Taken& a, const Taken& b) { return a.source_time < b.source_time; });
  for (Taken& t : taken) deliver(t, messages, rejections);
  return Status::ok();
}

std::vector<dfpc::ChannelInfo> Subscriber::channels() const {
  std::vector<dfpc::ChannelInfo> channels;
  for (const auto& [channel, type] : channel_types_)
    if (type) channels.push_back({channel, type, 0});
  return channels;
}

std::vector<LostPublisher> Subscriber::takeLostPublishers() {
  std::vector<LostPublisher> lost;
  for (const auto& r : readers_) {
    if (!r->emit) continue;
    dds_subscription_matched_status_t status{};
    // Reading the status resets its change count: each departure is reported once.
    if (dds_get_subscription_matched_status(r->reader, &status) < 0) continue;
    if (status.current_count_change < 0)
      lost.push_back(
          {r->channel, -status.current_count_change, static_cast<int>(status.current_count)});
  }
  return lost;
}

std::vector<std::string> Subscriber::takeNewChannels() {
  return std::exchange(new_channels_, {});
}

}  // namespace cdff::dds
