#pragma once
// The live run of `cdff serve` (docs/web-ui.md): one DFPC graph run on a served recording at a
// chosen speed, driven only through the seed §7.3 external API (cdff::api::Cdff: setCDFFState,
// getCDFFState, getDFPCStatus and its subscriptions), and watched by any number of browsers.
//
// Threads: the API consumes the recording on its input thread; a tee on that input keeps the
// latest camera image and LIDAR scan (shared pointers, no copy) for an encoder thread of the
// run's own, which compresses the image to JPEG and thins the scan when a browser watches; the
// API's subscription thread calls back with each DFPC's pose and status; the run's sink receives
// events and timings on the input thread. All of them hand frames to the browsers' listeners (each
// a bounded FrameQueue that drops its oldest frame), so a slow or absent browser never slows the
// DFPCs: only its copy is decimated.

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/dfpc/api.hpp"
#include "cdff/serve/frame_queue.hpp"
#include "cdff/serve/recording.hpp"

namespace cdff::serve {

/// What a live run is started with (POST /api/live).
struct LiveSpec {
  std::string graph;          // as listed by LiveHub::graphs() (e.g. "dfpcs/pose_filtering.yaml")
  std::size_t recording = 0;  // index of a served recording
  double speed = 1.0;         // stream seconds per wall second, in [1/16, 16]
  std::string camera;         // the Image channel shown; "" for the recording's first one
  /// The PointCloud channel of the 3D view; "" for the recording's first one (none when it has
  /// none).
  std::string points;
};

/// "idle" | "initialize" | "reset" | "stop", or an error naming the value and the accepted ones.
Result<api::StateRequest> parseStateRequest(const std::string& text);

/// The server's one live run and the browsers that watch it. Thread-safe.
class LiveHub {
 public:
  using Listener = std::function<void(Frame)>;
  /// How many frames a browser's queue has dropped so far.
  using DroppedCount = std::function<std::uint64_t()>;

  /// `graphs`: the graph files a run may use, as given (the only values "graph" may take).
  LiveHub(const std::vector<std::unique_ptr<Recording>>& recordings,
          std::vector<std::string> graphs);
  ~LiveHub();  // stops the run

  const std::vector<std::string>& graphs() const { return graphs_; }

  /// Starts a run and puts the CDFF in RUNNING (setCDFFState(initialize)). `conflict` is set
  /// (and an error returned) when a run already exists.
  Status start(const LiveSpec& spec, bool& conflict);
  /// {"active": false, "last": the removed run's last state} when no run exists, else the run's
  /// state: {"active", "run" (its number), "graph",
  /// "recording", "speed", "camera", "state" (getCDFFState), "input_ended", "t",
  /// "dfpcs": [getDFPCStatus of each, with the latest DFN timings], "events": [the last ones]};
  /// both with "browsers": [{"dropped"}], one per watching browser.
  nlohmann::json state() const;
  /// setCDFFState(request); the API's own error when it refuses. kNotFound when no run exists.
  Status request(api::StateRequest request);
  /// initDFPC(dfpc) (`init`) or stopDFPC(dfpc); the API's own error when it refuses (an unknown
  /// DFPC, a CDFF that is not running or idle). kNotFound when no run exists.
  Status dfpcRequest(const std::string& dfpc, bool init);
  /// designateTarget(x, y, width, height) (the box in full-resolution pixels of the run's
  /// camera image): the designation as JSON {"x", "y", "width", "height", "t", "stamp_us",
  /// "frame_id", "dfpcs", "image": {"channel", "width", "height", "t"}}, also sent to every
  /// browser as a "designation" frame; the API's own error when it refuses (a box that leaves the
  /// image, no running DFPC that reads designations, no image yet). `no_run` is set (and an error
  /// returned) when no run exists.
  Result<nlohmann::json> designate(double x, double y, int width, int height, bool& no_run);
  /// Stops the run (setCDFFState(stop) when the state allows it) and removes it.
  Status remove();
  /// A served graph's model for the 3D view: the first `mesh_file` parameter of its nodes
  /// (relative to the working directory, as the run reads it), loaded with egse's loaders, as a
  /// mesh body (scene.hpp). The graph is refused as start() refuses it; kNotFound when it names
  /// no mesh file.
  Result<std::string> modelBody(const std::string& graph) const;

  /// A browser: every frame of the run goes to `listener` from now on (first the current
  /// state); `dropped` tells what its queue dropped (in the state's "browsers"). Returns its id
  /// for removeListener().
  std::uint64_t addListener(Listener listener, DroppedCount dropped);
  void removeListener(std::uint64_t id);
  std::size_t listeners() const;

  class Run;  // live_run.cpp

 private:
  friend class Run;
  void publish(const Frame& frame) const;
  /// Ok when `graph` is one of graphs(); else kNotFound, or kInvalidInput for a path.
  Status checkGraph(const std::string& graph) const;

  const std::vector<std::unique_ptr<Recording>>& recordings_;
  std::vector<std::string> graphs_;
  mutable std::mutex run_mutex_;  // guards run_ (a run is started and removed under it)
  std::unique_ptr<Run> run_;
  nlohmann::json last_;
  std::uint64_t runs_ =
      0;  // runs started so far  // the removed run's last state (null before the first)
  mutable std::mutex listeners_mutex_;
  std::map<std::uint64_t, std::pair<Listener, DroppedCount>> listeners_;
  std::uint64_t next_listener_ = 1;
};

}  // namespace cdff::serve
