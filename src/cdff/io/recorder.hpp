#pragma once
// Recording CDFF values: one MCAP file, one channel per stream, schemas registered on first use.
//
//   cdff::io::Recorder rec;
//   CDFF_RETURN_IF_ERROR(rec.open("run.mcap"));        // lz4 chunks by default
//   CDFF_RETURN_IF_ERROR(rec.write("/chaser/camera/left/image", image));
//   CDFF_RETURN_IF_ERROR(rec.write("/truth/target_pose", pose));
//   CDFF_RETURN_IF_ERROR(rec.close());
//
// Any type of the registry (type_registry.hpp) can be written: its schema and encoding come from
// there. The log time of a message is its value's stamp (microseconds, stored as MCAP
// nanoseconds); types without a stamp (camera models, matches, correspondences, scalars) take one
// as an argument. A channel holds one type; writing another type to it is refused. Thread-safe.

#include <map>
#include <mutex>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "cdff/io/mcap.hpp"
#include "cdff/types/codec/codec.hpp"
#include "cdff/types/type_registry.hpp"

namespace cdff::io {

/// cdff::Timestamp (us) <-> MCAP time (ns).
constexpr std::uint64_t toMcapTime(Timestamp us) {
  return static_cast<std::uint64_t>(us) * 1000;
}
constexpr Timestamp fromMcapTime(std::uint64_t ns) {
  return static_cast<Timestamp>(ns / 1000);
}

/// The channel metadata key that names a channel's CDFF type.
inline constexpr std::string_view kTypeMetadataKey = "cdff.type";

/// The CDFF type of a channel: its "cdff.type" metadata, else what its schema implies
/// (foxglove.RawImage -> Image, ...), else Json for a JSON channel without a known schema; not
/// valid when it is none of ours (e.g. a ROS 2 message).
TypeId typeOfChannel(const Channel& channel, const Schema* schema);

class Recorder {
 public:
  Recorder();
  ~Recorder();  // closes the file if still open
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  Status open(const std::string& path, const McapWriterOptions& options = {});
  bool isOpen() const;

  /// A value of any registered type. Its log time is its own stamp (an image's, a pose's...), or
  /// `stamp` for the types without one (matches, correspondences, camera models, scalars).
  Status write(const std::string& channel, const Value& value, Timestamp stamp);
  /// A value with a stamp of its own; an error for a type without one.
  template <RegisteredType T>
  Status write(const std::string& channel, const T& value) {
    return writeTyped(channel, TypeId::of<T>(), &value, std::nullopt);
  }
  template <RegisteredType T>
  Status write(const std::string& channel, const T& value, Timestamp stamp) {
    return writeTyped(channel, TypeId::of<T>(), &value, stamp);
  }
  /// A camera model with the frame its calibration belongs to.
  Status writeCalibration(const std::string& channel, const CameraModel& value, Timestamp stamp,
                          const std::string& frame_id);

  /// A JSON object (schema cdff.Record), e.g. a DFN timing record or a report.
  Status writeJson(const std::string& channel, Timestamp stamp, const nlohmann::json& record);
  /// An event on /cdff/events (docs/recording.md): level "info" | "warning" | "error".
  Status writeEvent(Timestamp stamp, const std::string& level, const std::string& source,
                    const std::string& message, const std::string& channel = "/cdff/events");

  Status writeAttachment(const std::string& name, const std::string& media_type, Timestamp stamp,
                         Bytes data);
  Status writeMetadata(const std::string& name, const std::map<std::string, std::string>& values);

  /// Hands the current chunk to the operating system (a crash then keeps it).
  Status flush();
  Status close();

  /// The file's statistics so far.
  Statistics statistics() const;

 private:
  Status writeTyped(const std::string& channel, TypeId type, const void* value,
                    std::optional<Timestamp> stamp);
  Status writeEncoded(const std::string& channel, TypeId type, Timestamp stamp);

  struct ChannelEntry {
    std::uint16_t id;
    TypeId type;
  };
  mutable std::mutex mutex_;
  McapWriter writer_;
  codec::Encoded scratch_;
  std::map<std::string, ChannelEntry, std::less<>> channels_;
  std::map<std::string_view, std::uint16_t> schemas_;  // by type name
};

}  // namespace cdff::io
