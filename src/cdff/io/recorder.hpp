#pragma once
// Recording CDFF values: one MCAP file, one channel per stream, schemas registered on first use.
//
//   cdff::io::Recorder rec;
//   CDFF_RETURN_IF_ERROR(rec.open("run.mcap"));        // lz4 chunks by default
//   CDFF_RETURN_IF_ERROR(rec.write("/chaser/camera/left/image", image));
//   CDFF_RETURN_IF_ERROR(rec.write("/truth/target_pose", pose));
//   CDFF_RETURN_IF_ERROR(rec.close());
//
// The log time of a message is its value's stamp (microseconds, stored as MCAP nanoseconds).
// Types without a stamp (camera models, matches, correspondences) take one as an argument.
// A channel holds one type; writing another type to it is refused. Thread-safe.

#include <map>
#include <mutex>
#include <string>

#include "cdff/io/codec.hpp"
#include "cdff/io/mcap.hpp"

namespace cdff::io {

/// cdff::Timestamp (us) <-> MCAP time (ns).
constexpr std::uint64_t toMcapTime(Timestamp us) {
  return static_cast<std::uint64_t>(us) * 1000;
}
constexpr Timestamp fromMcapTime(std::uint64_t ns) {
  return static_cast<Timestamp>(ns / 1000);
}

class Recorder {
 public:
  Recorder();
  ~Recorder();  // closes the file if still open
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  Status open(const std::string& path, const McapWriterOptions& options = {});
  bool isOpen() const;

  Status write(const std::string& channel, const Image& value);
  Status write(const std::string& channel, const DepthMap& value);
  Status write(const std::string& channel, const StereoImagePair& value);  // stamp: left image
  Status write(const std::string& channel, const CompressedImage& value);
  Status write(const std::string& channel, const PointCloud& value);
  Status write(const std::string& channel, const Transform& value);
  Status write(const std::string& channel, const PoseWithCovariance& value);
  Status write(const std::string& channel, const RigidBodyState& value);
  Status write(const std::string& channel, const PoseArray& value);
  Status write(const std::string& channel, const TriangleMesh& value);
  Status write(const std::string& channel, const Features2D& value);
  Status write(const std::string& channel, const Features3D& value);
  Status write(const std::string& channel, const ImuSample& value);
  Status write(const std::string& channel, const Wrench& value);
  Status write(const std::string& channel, const JointState& value);
  Status write(const std::string& channel, const CameraModel& value, Timestamp stamp,
               const std::string& frame_id = {});
  Status write(const std::string& channel, const Matches& value, Timestamp stamp);
  Status write(const std::string& channel, const Correspondences2D& value, Timestamp stamp);
  Status write(const std::string& channel, const Correspondences3D& value, Timestamp stamp);
  Status write(const std::string& channel, const Correspondences2D3D& value, Timestamp stamp);

  /// A scalar (double, bool, int, Timestamp or std::string) as {"timestamp", "value"}.
  template <typename T>
  Status writeScalar(const std::string& channel, const T& value, Timestamp stamp);

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
  Status writeEncoded(const std::string& channel, std::string_view cdff_type, Timestamp stamp);
  template <typename T, typename Encode>
  Status record(const std::string& channel, Timestamp stamp, Encode&& encode_value);

  struct ChannelEntry {
    std::uint16_t id;
    std::string_view cdff_type;
  };
  mutable std::mutex mutex_;
  McapWriter writer_;
  Encoded scratch_;
  std::map<std::string, ChannelEntry, std::less<>> channels_;
  std::map<std::string_view, std::uint16_t> schemas_;  // by CDFF type
};

}  // namespace cdff::io
