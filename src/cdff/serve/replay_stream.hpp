#pragma once
// A replay streamed to one browser over a WebSocket (docs/web-ui.md): a thread reads the
// recording at the playback speed and hands frames to a sink (the browser's FrameQueue), never
// waiting on the browser. Images go out as binary frames (a header and a JPEG), poses and state
// as JSON text frames. Commands (play, pause, seek, speed) come from the browser.
//
// Binary frame: 4 bytes, the header's length N (little endian), N bytes of JSON header
// {"type":"image","channel","t","log_time_ns","width","height","source_width","source_height"},
// then the JPEG. Point clouds: the points frame of scene.hpp (header {"type": "points",
// "channel", "t", "log_time_ns", "frame", "count", "source_count", ...}, then Float32 x, y, z).

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/serve/frame_queue.hpp"
#include "cdff/serve/recording.hpp"

namespace cdff::serve {

struct StreamSpec {
  std::string image;               // an Image channel; "" for none
  std::vector<std::string> poses;  // pose channels (PoseWithCovariance, RigidBodyState, Transform)
  std::string points;              // a PointCloud channel for the 3D view; "" for none
  std::size_t max_points = 20000;  // points per cloud at most (scene.hpp), 1..kMaxCloudPoints
  int max_width = 640;             // images are downscaled to this width at most
  int quality = 80;                // JPEG quality
};

/// Ok when every channel of `spec` is in `recording` with the right type, else an error naming
/// the channel (kNotFound) or its type (kInvalidInput).
Status validate(const Recording& recording, const StreamSpec& spec);

/// A binary frame: the header's length, the JSON header and the payload.
std::string binaryFrame(const nlohmann::json& header, const std::vector<std::uint8_t>& payload);

class ReplayStream {
 public:
  using Sink = std::function<void(Frame)>;
  /// `dropped` tells how many frames the sink dropped (reported in state messages).
  using DroppedCount = std::function<std::uint64_t()>;

  /// Opens a reader of its own and starts paused at the recording's start, sending the frames
  /// of that time. `spec` must validate.
  static Result<std::unique_ptr<ReplayStream>> start(const Recording& recording, StreamSpec spec,
                                                     Sink sink, DroppedCount dropped);
  ~ReplayStream();  // stops the thread and waits for it

  /// {"cmd": "play"} | {"cmd": "pause"} | {"cmd": "seek", "t": seconds} |
  /// {"cmd": "speed", "value": factor in [1/64, 64]}; an error naming what is wrong.
  Status command(const nlohmann::json& command);

 private:
  using Clock = std::chrono::steady_clock;
  ReplayStream(const Recording& recording, StreamSpec spec, Sink sink, DroppedCount dropped);
  void run();
  void seekTo(std::uint64_t log_time_ns);  // sends the frames at that time (no lock held)
  void emit(const io::MessageView& message, bool late);
  void sendState(bool ended);
  std::uint64_t now() const;  // the replay's current log time (lock held)

  const Recording& recording_;
  StreamSpec spec_;
  Sink sink_;
  DroppedCount dropped_;
  std::unique_ptr<io::McapReader> reader_;
  std::optional<io::MessageIterator> iterator_;
  std::vector<std::uint16_t> channel_ids_;

  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false, playing_ = false, seek_ = true;
  double speed_ = 1.0;
  std::uint64_t seek_to_ = 0, position_ = 0, anchor_ns_ = 0;
  Clock::time_point anchor_wall_;
  std::optional<io::MessageView> pending_;
  std::thread thread_;
};

}  // namespace cdff::serve
