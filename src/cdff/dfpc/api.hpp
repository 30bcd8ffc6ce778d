#pragma once
// The external interface of CDFF (seed §7.3): what the autonomy (OG2) calls, and how sensor data
// (OG4) comes in. Every function returns a Status or a Result and never throws: an invalid state
// or request is an error value that says what was asked, in which state, and what is accepted.
//
//   setCDFFState(kInitialize | kIdle | kReset | kStop)   getCDFFState()
//   getDFPCStatus(dfpc)                                   initDFPC(dfpc)   stopDFPC(dfpc)
//   getTargetRelativePose(frame)   getTargetRelativeVelocity(frame)   getModelOfTarget()
//   getDFPCPose(dfpc, hz, callback)   getDFPCStatus(dfpc, hz, callback)   (asynchronous)
//   push(message)   (sensor data, when the input is live)
//   designateTarget(x, y, width, height)   (the user's region of interest, seed §4.1.1)
//
// The state machine (docs/external-api.md):
//   uninitialised --initialize--> running   (DFPCs started; input consumed)
//   running --idle--> idle --initialize--> running   (input paused, states kept)
//   running | idle | stopped --reset--> same state   (DFPCs re-initialised, products cleared)
//   running | idle --stop--> stopped --initialize--> running   (fresh DFPCs, products cleared)
// Any other request is an error (kInvalidInput) naming the state and the accepted requests.
//
// Threads: the input is consumed on a thread of its own; subscriptions are called on another
// (one callback at a time, at the requested rate of the configured clock). Every function may
// be called from any thread, including from a callback.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "cdff/dfpc/clock.hpp"
#include "cdff/dfpc/data_product_manager.hpp"
#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/graph.hpp"
#include "cdff/dfpc/orchestrator.hpp"
#include "cdff/dfpc/stream.hpp"
#include "cdff/types/image_region.hpp"
#include "cdff/types/types.hpp"

namespace cdff::api {

enum class CdffState { kUninitialised, kRunning, kIdle, kStopped };
enum class StateRequest { kInitialize, kIdle, kReset, kStop };
const char* toString(CdffState state);
const char* toString(StateRequest request);

struct Config {
  std::vector<std::string> graph_files;  // DFPC graphs (YAML)
  std::vector<dfpc::GraphSpec> graphs;   // DFPC graphs built in C++
  /// A recording (or any stream) to consume; null: live input through push().
  std::shared_ptr<dfpc::InputStream> input;
  std::size_t live_capacity = 1024;  // live messages queued at most (oldest dropped beyond)
  bool realtime = false;             // pace a given input on the clock
  /// Subscriptions (and real-time pacing) run on this clock; the steady clock when null. A
  /// SimulatedClock in manual mode makes them exact in tests.
  std::shared_ptr<dfpc::Clock> clock;
  dfpc::Sink* sink = nullptr;  // products, events, timings (e.g. a recording); may be null
  bool record_timing = true;   // one timing record per DFN call to the sink
  /// DFPCs that run only while another's track state is in given states (detection while a
  /// tracker is UNINITIALISED or LOST; Orchestrator::runWhile).
  std::vector<dfpc::ActivationRule> run_while;
  /// Fixed transforms a_T_b (e.g. servicer_T_camera) with which poses and velocities are
  /// re-expressed in a requested frame.
  std::vector<Transform> static_transforms;
};

/// The velocity (twist) of the target relative to `frame`, expressed in `frame`, with its
/// covariance ([dv, domega], m^2/s^2 and rad^2/s^2).
struct VelocityWithCovariance {
  Timestamp stamp = 0;
  std::string frame;
  std::string target_frame;
  Twist twist;
  Matrix6d covariance = Matrix6d::Zero();
};

/// The latest model of the target: a mesh or a point cloud (one of them is set).
struct TargetModel {
  std::string product;
  Timestamp stamp = 0;
  std::shared_ptr<const TriangleMesh> mesh;
  std::shared_ptr<const PointCloud> cloud;
};

/// A designation as delivered by designateTarget(): the region, the DFPCs that read it and the
/// image it is a box of.
struct Designated {
  /// The box as an ImageRegion: stamp = the stream time it was delivered at, frame_id = the
  /// image's, source "user".
  ImageRegion region;
  std::vector<std::string> dfpcs;  // the running DFPCs whose designation input reads it
  std::string image_channel;       // their Image input
  int image_width = 0, image_height = 0;
  Timestamp image_stamp = 0;  // the latest image on image_channel when it was designated
};

using SubscriptionId = std::uint64_t;
/// `now` is the clock time of the call; the pose is an error until the DFPC has produced one.
using PoseCallback = std::function<void(Timestamp now, const Result<PoseWithCovariance>& pose)>;
using StatusCallback = std::function<void(Timestamp now, const Result<dfpc::DfpcStatus>& status)>;

class Cdff {
 public:
  /// Loads and checks every graph, creates the DFPCs (initialised, not started) and checks that
  /// a given input has their channels. The state is then uninitialised.
  static Result<std::unique_ptr<Cdff>> create(Config config) noexcept;
  ~Cdff();
  Cdff(const Cdff&) = delete;
  Cdff& operator=(const Cdff&) = delete;

  Status setCDFFState(StateRequest request) noexcept;
  CdffState getCDFFState() const noexcept;

  Result<dfpc::DfpcStatus> getDFPCStatus(const std::string& dfpc) const noexcept;
  /// (Re)initialises one DFPC and starts it (the CDFF must be running or idle).
  Status initDFPC(const std::string& dfpc) noexcept;
  Status stopDFPC(const std::string& dfpc) noexcept;

  /// The latest target pose (outputs with role target_state or target_pose, the most recent
  /// among the DFPCs) in `frame`: the product's own parent frame, or one reached through a
  /// static transform.
  Result<PoseWithCovariance> getTargetRelativePose(const std::string& frame) const noexcept;
  /// The latest target velocity (role target_state) in `frame`.
  Result<VelocityWithCovariance> getTargetRelativeVelocity(const std::string& frame) const noexcept;
  /// The latest target model (role target_model).
  Result<TargetModel> getModelOfTarget() const noexcept;

  /// Calls `callback` at `frequency_hz` (clock time) with the DFPC's latest pose (its output with
  /// a target role, else its first pose-typed output), in the product's frame.
  Result<SubscriptionId> getDFPCPose(const std::string& dfpc, double frequency_hz,
                                     PoseCallback callback) noexcept;
  /// Calls `callback` at `frequency_hz` with the DFPC's status.
  Result<SubscriptionId> getDFPCStatus(const std::string& dfpc, double frequency_hz,
                                       StatusCallback callback) noexcept;
  /// Ends a subscription; when it returns, its callback is not running and will not run again
  /// (except when called from that callback itself).
  Status cancelSubscription(SubscriptionId id) noexcept;

  /// Live input: queues a sensor message (an error when the input is a given stream).
  Status push(dfpc::Message message) noexcept;
  /// Waits (up to timeout_s of steady time) until every pushed message has been processed, or a
  /// given input has been consumed to its end.
  Status flush(double timeout_s) noexcept;

  /// The user designates the target (seed §4.1.1: "the user initialises the position of the
  /// target by selecting a ROI"): the box [x, x + width) x [y, y + height), in pixels of the
  /// latest image the designation's readers were given (full resolution, pixel centres at
  /// integer coordinates), goes as an ImageRegion on dfpc::kDesignationChannel to every running
  /// DFPC with an ImageRegion input on that channel, at the current stream time (the stamp of
  /// the latest message processed): what `cdff run --roi` does from the command line, here while
  /// the input runs (a given recording or live input). Far-range tracking takes its template
  /// from the next image. Errors: a coordinate that is not finite, a size below one pixel, a box
  /// that leaves the image (kInvalidInput, naming the value and the image's size); no running
  /// DFPC that reads designations, or no image on its Image input yet (kNotFound, naming them).
  Result<Designated> designateTarget(double x, double y, int width, int height) noexcept;

  /// The products (shared, thread-safe).
  std::shared_ptr<const dfpc::DataProductManager> products() const noexcept;

 private:
  struct Impl;
  explicit Cdff(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdff::api
