#pragma once
// Where the simulator's outputs go. The simulator knows nothing about files: it hands each
// message (channel, log time, a typed payload) to a SimulationSink, in log-time order. The MCAP
// writer (`cdff sim`) is one sink; MemorySink keeps everything for tests; DigestSink hashes the
// payloads' bytes (determinism checks without storing the run).

#include <cstdint>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include "cdff/egse/range_sensors.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/lidar_info.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/sensors.hpp"
#include "cdff/types/status.hpp"

namespace cdff::egse {

/// A camera's calibration as published beside its images.
struct CameraInfo {
  Timestamp stamp = 0;
  std::string frame_id;
  CameraModel model;
};

/// A fault starting, ending or hitting one measurement (for the record: faults are not hidden).
struct FaultEvent {
  Timestamp stamp = 0;
  std::string sensor;
  std::string fault;   // e.g. "camera_failure", "dropped_frame"
  std::string detail;  // human-readable: what happened, with values
};

using SimPayload = std::variant<Image, DepthMap, PointCloud, ImuSample, RangeMeasurement,
                                CameraInfo, LidarInfo, Transform, PoseWithCovariance,
                                RigidBodyState, TriangleMesh, FaultEvent, JointState, Wrench>;

struct SimMessage {
  std::string channel;
  Timestamp log_time = 0;  // when the message is available (stamp + latency [+ fault delay])
  SimPayload payload;
};

/// What a run is: recorded once at the start.
struct SimulationMetadata {
  std::string scenario;       // name
  std::string scenario_file;  // where it came from
  std::string scenario_yaml;  // the effective scenario, overrides applied (reproducible)
  std::uint64_t seed = 0;
  double duration = 0;                        // s
  std::string renderer;                       // which backend ran, and on what
  std::map<std::string, std::string> values;  // frames, sensors, versions
};

class SimulationSink {
 public:
  virtual ~SimulationSink() = default;
  virtual Status begin(const SimulationMetadata& metadata) = 0;
  virtual Status write(const SimMessage& message) = 0;
  virtual Status end() { return Status::ok(); }
};

class MemorySink final : public SimulationSink {
 public:
  Status begin(const SimulationMetadata& metadata) override {
    metadata_ = metadata;
    return Status::ok();
  }
  Status write(const SimMessage& message) override {
    messages_.push_back(message);
    return Status::ok();
  }
  const SimulationMetadata& metadata() const { return metadata_; }
  const std::vector<SimMessage>& messages() const { return messages_; }
  /// The payloads of type T on `channel`, in order.
  template <typename T>
  std::vector<T> on(const std::string& channel) const {
    std::vector<T> out;
    for (const SimMessage& m : messages_)
      if (m.channel == channel)
        if (const T* v = std::get_if<T>(&m.payload)) out.push_back(*v);
    return out;
  }
  std::size_t count(const std::string& channel) const;

 private:
  SimulationMetadata metadata_;
  std::vector<SimMessage> messages_;
};

/// A 64-bit FNV-1a hash over every message's channel, log time and payload bytes, and the
/// metadata: two runs are identical when their digests are.
class DigestSink final : public SimulationSink {
 public:
  Status begin(const SimulationMetadata& metadata) override;
  Status write(const SimMessage& message) override;
  std::uint64_t digest() const { return hash_; }
  std::size_t messages() const { return count_; }

 private:
  void add(const void* data, std::size_t size);
  void add(const std::string& s);
  void add(const Transform& t);
  void add(const Image& image);
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
  std::size_t count_ = 0;
};

}  // namespace cdff::egse
