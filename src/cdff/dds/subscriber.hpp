#pragma once
// Receives CDFF messages from DDS: from the channels asked for (`cdff node`: the graphs' inputs),
// or from every rt/ topic of a type the CDFF reads as its publications are discovered
// (`cdff record`).
//
//   Subscriber subscriber(*participant);
//   CDFF_RETURN_IF_ERROR(subscriber.subscribe("/chaser/camera/far/image", TypeId::of<Image>()));
//   std::vector<dfpc::Message> messages;
//   std::vector<Rejection> rejected;
//   CDFF_RETURN_IF_ERROR(subscriber.poll(0.1, messages, rejected));
//
// poll() returns the samples of every topic in the order they were published (their source
// times: one publisher's samples come in its order of writing; samples of several publishers
// are interleaved by their clocks). An image gets the camera model published on its
// <dir>/camera_info topic with the same stamp, when there is one. A sample that does not convert
// is a Rejection that says which channel, which stamp and why; it never stops the others.

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cdff/dds/participant.hpp"
#include "cdff/dds/wire.hpp"
#include "cdff/dfpc/stream.hpp"

namespace cdff::dds {

/// A subscribed channel whose publishers left (stopped, or killed: their lease expired).
struct LostPublisher {
  std::string channel;
  int left = 0;       // publishers that left since the last look
  int remaining = 0;  // publishers still matched
};

struct Rejection {
  std::string channel;
  Timestamp stamp = 0;  // the sample's header stamp, when it has one
  Status status;
};

class Subscriber {
 public:
  /// `encoding`: how the channels subscribed with subscribe() travel (wire.hpp); a Record is
  /// decoded by its own encoding field.
  explicit Subscriber(Participant& participant, Encoding encoding = Encoding::kRos2);
  ~Subscriber();
  Subscriber(const Subscriber&) = delete;
  Subscriber& operator=(const Subscriber&) = delete;

  /// Reads `channel`, whose values are of `type` (an image channel also reads its camera info).
  Status subscribe(const std::string& channel, TypeId type);
  /// Reads every channel published as rt/<channel> with a type the CDFF reads, as its first
  /// publication is discovered, when it matches one of `patterns` (a prefix, or a shell pattern
  /// with * ? [ ]; none: every channel). A transient-local publication is read from its history.
  Status subscribeDiscovered(std::vector<std::string> patterns);

  /// Waits up to `timeout_s` for data, then takes every sample available, in publication order.
  Status poll(double timeout_s, std::vector<dfpc::Message>& messages,
              std::vector<Rejection>& rejections);

  /// The channels read so far, with their types (Record channels: the first sample's type).
  std::vector<dfpc::ChannelInfo> channels() const;
  /// The subscribed channels whose publishers left since the last call (camera infos aside).
  std::vector<LostPublisher> takeLostPublishers();
  /// The channels subscribed since the last call (for a recorder's log).
  std::vector<std::string> takeNewChannels();

 private:
  struct Reader {
    std::string channel;
    WireType wire;
    TypeId expected;   // Record channels: the type every sample must have (not valid: any)
    bool emit = true;  // false: a camera info read only for its images
    dds_entity_t reader = 0;
    std::map<dds_instance_handle_t, std::string> child_frames;  // per publication
  };
  struct Taken;
  Status addReader(const std::string& channel, WireType wire, TypeId expected, bool emit,
                   Durability durability);
  Status discover();
  Status take(Reader& reader, std::vector<Taken>& taken);
  const std::string& childFrame(Reader& reader, dds_instance_handle_t publication);
  void deliver(Taken& taken, std::vector<dfpc::Message>& messages,
               std::vector<Rejection>& rejections);

  Participant& participant_;
  Encoding encoding_;
  dds_entity_t waitset_ = 0;
  dds_entity_t discovery_ = 0;  // the DCPSPublication reader (subscribeDiscovered)
  std::vector<std::string> patterns_;
  std::vector<std::unique_ptr<Reader>> readers_;
  std::map<std::string, TypeId> channel_types_;
  std::vector<std::string> new_channels_;
  // camera info channel -> the latest camera models by stamp
  std::map<std::string, std::map<Timestamp, CameraModel>> cameras_;
};

}  // namespace cdff::dds
