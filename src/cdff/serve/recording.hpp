#pragma once
// A recording served by `cdff serve` (docs/web-ui.md): its channels with their message counts,
// types and rates, and the queries of the web application's replay page: the messages of a
// channel near a time, a camera image at a time as a JPEG, a pose channel as arrays.
//
// Times in queries are seconds from the recording's first message (`t`); answers also give the
// MCAP log time in nanoseconds. A Recording is shared by the server's threads: its queries lock
// the reader, and a stream opens readers of its own (openReader()).

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/io/mcap.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/status.hpp"

namespace cdff::serve {

struct ChannelSummary {
  std::uint16_t id = 0;
  std::string topic;
  std::string type;  // the CDFF type name; "" when it is none of ours
  std::string schema;
  std::string message_encoding;
  std::vector<std::uint64_t> times_ns;  // log times of its messages, sorted
  /// Messages per second over the channel's own span; 0 with fewer than two messages.
  double rateHz() const;
};

/// A JPEG of a camera image and what it shows.
struct EncodedImage {
  std::vector<std::uint8_t> jpeg;
  std::uint64_t log_time_ns = 0;
  int width = 0, height = 0;                // of the JPEG
  int source_width = 0, source_height = 0;  // of the recorded image
};

/// The image as a JPEG no wider than `max_width` (downscaled with its aspect kept). 16-bit and
/// float images are stretched to 8 bits between their minimum and maximum.
Result<EncodedImage> encodeJpeg(const Image& image, int max_width, int quality);

/// Types whose channels plot as positions: PoseWithCovariance, RigidBodyState, Transform.
bool isPoseType(const std::string& type);

class Recording {
 public:
  /// Opens the file and reads every message once for the counts, rates and times. A file that
  /// cannot be read is an error; damage met on the way is kept in damages().
  static Result<std::unique_ptr<Recording>> open(const std::string& path);

  const std::string& path() const { return path_; }
  std::string name() const;
  std::uint64_t startNs() const { return start_ns_; }
  std::uint64_t endNs() const { return end_ns_; }
  const std::vector<ChannelSummary>& channels() const { return channels_; }
  const ChannelSummary* channel(std::string_view topic) const;
  const std::vector<std::string>& damages() const { return damages_; }

  /// {name, messages, start_ns, duration_s, channels: [...] (with `with_channels`)}.
  nlohmann::json summary(bool with_channels) const;

  /// The log time `t` seconds after the first message; an error naming the value when it is
  /// not finite or outside the recording.
  Result<std::uint64_t> timeAt(double t) const;
  /// Seconds from the first message.
  double secondsOf(std::uint64_t log_time_ns) const;
  /// Index in `channel.times_ns` of its last message at or before `log_time_ns` (its first
  /// message when the time is before it).
  static std::size_t indexAt(const ChannelSummary& channel, std::uint64_t log_time_ns);

  /// `count` messages of `topic` from its last message at or before `t`, decoded to JSON (long
  /// arrays summarised).
  Result<nlohmann::json> messages(const std::string& topic, double t, std::size_t count) const;
  /// The image of `topic` (an Image channel) at or before `t`, as a JPEG.
  Result<EncodedImage> imageAt(const std::string& topic, double t, int max_width,
                               int quality) const;
  /// The positions and attitudes of a pose channel against time, as columns
  /// {t, x, y, z, qw, qx, qy, qz}, decimated to at most `max_points`. With `via` (a pose channel
  /// whose child frame is the poses' parent, e.g. /truth/tf/servicer = lvlh_T_servicer for
  /// servicer_T_target), each pose is expressed in via's parent frame: via interpolated at the
  /// pose's stamp as `cdff eval` interpolates the truth, times the pose (lvlh_T_target); a pose
  /// without a via pose within 0.5 s is left out (counted in `unmatched`).
  Result<nlohmann::json> poses(const std::string& topic, std::size_t max_points,
                               const std::string& via = "") const;

  /// Every pose of a pose channel, in time order (a PoseWithCovariance's or RigidBodyState's
  /// pose alone).
  Result<std::vector<Transform>> transforms(const std::string& topic) const;
  /// The 3D view's model: the first mesh of a TriangleMesh channel (the simulator's
  /// /truth/target_mesh), as a mesh body (scene.hpp).
  Result<std::string> meshBody(const std::string& topic) const;
  /// The errors of a pose product against the truth as `cdff eval` measures them (its pairing,
  /// validity and interpolation: eval::evaluateRecording), with the thresholds of the
  /// requirement at each error's true range, as columns {t, position_error_m, angle_error_deg,
  /// range_m, position_threshold_m, angle_threshold_deg, requirement}, decimated to at most
  /// `max_points`. `truth` "" pairs by frames as `cdff eval` does.
  Result<nlohmann::json> errors(const std::string& estimate, const std::string& truth,
                                std::size_t max_points) const;

  /// The tracked model's contour over the image of `image` at or before `t` (contour.hpp): the
  /// model of `mesh` (a TriangleMesh channel; "" for the recording's first) at the pose of
  /// `pose` at the image's stamp (interpolated as `cdff eval` does), brought into the image's
  /// frame with the recording's Transform channel from the pose's parent frame to it, projected
  /// with the image's camera model. {t, image_t, frame, source_width, source_height, pose,
  /// mesh, count, segments}.
  Result<nlohmann::json> contour(const std::string& image, double t, const std::string& pose,
                                 const std::string& mesh) const;
  /// The first mesh of a TriangleMesh channel.
  Result<TriangleMesh> mesh(const std::string& topic) const;
  /// parent_T_child from the first message of the Transform channel that holds it.
  Result<Transform> mounting(const std::string& parent, const std::string& child) const;

  /// A reader of its own (for a stream that iterates while others query).
  Result<std::unique_ptr<io::McapReader>> openReader() const;

  /// A channel by topic, or an error listing the channels (404-worthy: kNotFound).
  Result<const ChannelSummary*> findChannel(const std::string& topic) const;

 private:
  Recording() = default;
  /// The message of `channel` shown at `t` seconds (its last at or before), read under the lock.
  Result<io::MessageView> messageShownAt(const ChannelSummary& channel, double t) const;

  std::string path_;
  std::uint64_t start_ns_ = 0, end_ns_ = 0, messages_ = 0;
  std::vector<ChannelSummary> channels_;
  std::vector<std::string> damages_;
  mutable std::mutex mutex_;  // guards reader_
  io::McapReader reader_;
};

/// The one message of `channel` at exactly `log_time_ns` (the first of several).
Result<io::MessageView> readMessageAt(const io::McapReader& reader, const ChannelSummary& channel,
                                      std::uint64_t log_time_ns);
/// Decodes an Image channel's message and encodes it as a JPEG.
Result<EncodedImage> imageOf(const io::MessageView& message, int max_width, int quality);

}  // namespace cdff::serve
