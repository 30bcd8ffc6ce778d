#pragma once
// Publishes CDFF messages on DDS, one topic per channel (rt/<channel>, wire.hpp says which type).
//
//   std::unique_ptr<Participant> participant = Participant::create(domain).value();
//   Publisher publisher(*participant);
//   CDFF_RETURN_IF_ERROR(publisher.publish(message));   // creates the channel's writer once
//
// An image with a camera model also publishes the model on <dir>/camera_info (ROS 2's
// convention, same stamp and frame), written before the image. A pose's child frame travels in
// its writer's user data ("cdff.child_frame=<frame>;"), set from the channel's first pose: a
// later pose with another child frame is an error. With Encoding::kAsn1Uper the types that have
// an ASN.1 type travel as uPER Records (wire.hpp): an image carries its camera model, a pose its
// child frame.

#include <map>
#include <string>
#include <vector>

#include "cdff/dds/participant.hpp"
#include "cdff/dds/wire.hpp"
#include "cdff/dfpc/stream.hpp"

namespace cdff::dds {

/// The user-data key of a pose writer's child frame.
inline constexpr std::string_view kChildFrameKey = "cdff.child_frame";

class Publisher {
 public:
  explicit Publisher(Participant& participant, WriterQos qos = {},
                     Encoding encoding = Encoding::kRos2);
  ~Publisher();
  Publisher(const Publisher&) = delete;
  Publisher& operator=(const Publisher&) = delete;

  /// Writes `message` on its channel's topic (and an image's camera info). Errors: a value that
  /// does not convert (it names why), a channel that carried another type, a write that failed
  /// or timed out behind a reader that does not keep up.
  Status publish(const dfpc::Message& message);
  /// Creates the writers of a channel before its first message (so that readers can match
  /// first); `child_frame` is a pose channel's.
  Status prepare(const std::string& channel, TypeId type, const std::string& child_frame = "");
  /// The number of readers matched on a channel's topic (0 when it has no writer yet).
  int matchedReaders(const std::string& channel) const;
  /// Waits until every sample written was acknowledged by every matched reader.
  Status waitForAcknowledgements(double timeout_s);

  std::uint64_t published() const { return published_; }

 private:
  struct Writer {
    TypeId type;
    dds_entity_t writer = 0;
    dds_entity_t camera_info = 0;  // images: the CameraInfo writer
    std::string child_frame;       // poses
  };
  Result<Writer*> writerFor(const dfpc::Message& message);
  Status write(dds_entity_t writer, const void* sample, const std::string& channel);

  Participant& participant_;
  WriterQos qos_;
  Encoding encoding_;
  std::map<std::string, Writer> writers_;
  OutgoingSample sample_;
  OutgoingSample camera_sample_;
  dds_time_t last_source_time_ = 0;
  std::uint64_t published_ = 0;
};

}  // namespace cdff::dds
