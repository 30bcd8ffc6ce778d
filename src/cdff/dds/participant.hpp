#pragma once
// A DDS domain participant (Eclipse Cyclone DDS, C API) and the QoS the CDFF's endpoints use.
//
// QoS, compatible with ROS 2's defaults (reliable, volatile) so that a ROS 2 system on
// rmw_cyclonedds matches the CDFF's readers and writers:
//  - every endpoint is reliable and uses XCDR1 (ROS 2's data representation);
//  - writers keep all samples until acknowledged and block a writer that runs ahead of its
//    slowest reader (up to `max_blocking_s`, then the write fails with a timeout): a bridge
//    plays as fast as its readers keep up, and nothing acknowledged is lost;
//  - a writer of products keeps its last `depth` samples for late-joining readers
//    (transient-local durability, `cdff node`): a recorder started after the node still gets
//    them; volatile readers (ROS 2's default) match it too;
//  - readers keep every sample until it is taken.
// The domain gets kDefaultConfiguration, or $CYCLONEDDS_URI when set.

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include <dds/dds.h>

#include "cdff/types/status.hpp"

namespace cdff::dds {

/// The Status of a failed DDS call: "<what>: <Cyclone's message> (DDS return code N)".
Status ddsError(dds_return_t code, std::string_view what);

enum class Durability { kVolatile, kTransientLocal };

struct WriterQos {
  Durability durability = Durability::kVolatile;
  int depth = 0;  // transient-local history kept for late joiners; 0: keep all
  double max_blocking_s = 10.0;
  std::string user_data;  // "key=value;" pairs, as ROS 2 writes them
};

struct ReaderQos {
  Durability durability = Durability::kVolatile;
};

/// The Cyclone configuration of a domain when $CYCLONEDDS_URI is not set. Large samples (a 2 MB
/// image) need large UDP datagrams and socket buffers: with Cyclone's defaults (1344-byte
/// fragments in 14 kB messages, a 1 MB receive buffer) a burst of fragments overflows the buffer
/// and each loss costs a retransmission round (~100 ms per 2 MB image on loopback, ddsperf
/// included); with 64 kB messages and up to 16 MB of buffer (as much as net.core.rmem_max
/// allows) a 2 MB image takes ~0.5 ms. Data go by unicast (multicast for discovery only), so
/// that one publisher's samples reach a reader through one socket, in order.
inline constexpr const char* kDefaultConfiguration =
    "<CycloneDDS><Domain><General><AllowMulticast>spdp</AllowMulticast>"
    "<MaxMessageSize>65500B</MaxMessageSize></General><Internal>"
    "<SocketReceiveBufferSize min=\"default\" max=\"16MB\"/></Internal></Domain></CycloneDDS>";

/// The largest DDS domain id (Cyclone's default port mapping).
inline constexpr int kMaxDomainId = 232;

/// Owns a participant (and so every topic, reader and writer created on it).
class Participant {
 public:
  /// An error for a domain id outside [0, 232] or when Cyclone cannot start (its message).
  static Result<std::unique_ptr<Participant>> create(int domain);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  dds_entity_t handle() const { return participant_; }
  int domain() const { return domain_; }

  /// The topic of that name and type, created once.
  Result<dds_entity_t> topic(const std::string& name, const dds_topic_descriptor_t* descriptor);
  Result<dds_entity_t> createWriter(dds_entity_t topic, const WriterQos& qos);
  /// A reader whose data-available status is enabled (a waitset can wait on it).
  Result<dds_entity_t> createReader(dds_entity_t topic, const ReaderQos& qos);

 private:
  Participant(dds_entity_t participant, int domain) : participant_(participant), domain_(domain) {}
  dds_entity_t participant_;
  int domain_;
  std::map<std::string, dds_entity_t> topics_;
};

/// A value of a "key=value;" user-data string; "" when absent.
std::string userDataValue(std::string_view user_data, std::string_view key);

}  // namespace cdff::dds
