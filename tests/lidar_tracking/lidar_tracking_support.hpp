#pragma once
// Runs dfpcs/lidar_tracking.yaml on a simulated scenario (the EGSE simulator in-process, LIDAR
// only) and evaluates its products against the simulator's ground truth with cdff::eval. Shared
// by the end-to-end tests and the DFPC benchmark.
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/graph.hpp"
#include "cdff/dfpc/stream.hpp"
#include "cdff/eval/draws.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/point_cloud.hpp"

namespace cdff::lidar_tracking {

struct SimulatedRun {
  std::vector<dfpc::Message> messages;  // in stamp order: /chaser/tf/*, scans (each after its
                                        // /chaser/lidar/info), AHRS attitudes, /truth/target_pose
  std::vector<Transform> truth;         // servicer_T_target, /truth/target_pose
  std::vector<PointCloud> scans;
  std::vector<Timestamp> depth_stamps;  // /chaser/tof/depth, when the ToF camera is on
  std::filesystem::path mesh_file;      // the target's mesh as the simulator used it (PLY)
};

/// Simulates `scenario` (a library name) with only the LIDAR on, for `duration` s (0: the
/// scenario's), with `extra_yaml` appended to the scenario file (e.g. a faults: list) and the
/// `overrides` (`cdff sim --set` syntax, e.g. sensors.ahrs.enabled=true; with
/// sensors.tof.enabled=true the ToF camera's depth maps are kept too) applied.
Result<SimulatedRun> simulate(const std::string& scenario, double duration,
                              const std::string& extra_yaml = "", std::uint64_t seed = 1,
                              const std::vector<std::string>& overrides = {});

/// An initial state for the DFPC: the truth at `stamp` with a Gaussian error of RMS
/// `position_fraction` of the range and `angle_rad`, and that Gaussian's covariance
/// (eval::perturbedInitialState; an empty state when there is no truth at `stamp`).
RigidBodyState perturbedInitialState(const std::vector<Transform>& truth, Timestamp stamp,
                                     double position_fraction, double angle_rad,
                                     std::uint64_t seed);

/// The draw sets of data/evaluation/draws.yaml (an empty set when the file does not load: the
/// loader's error is printed).
const eval::DrawSets& drawSets();

/// One draw of a scenario: simulated with the draw's seed, and the initial state at the first
/// scan with a Gaussian error of RMS `position_fraction` of the range and `angle_rad`, drawn
/// from the draw's own stream (eval::perturbedInitialState).
struct DrawnRun {
  eval::Draw draw;
  SimulatedRun run;
  RigidBodyState initial;
};
Result<DrawnRun> simulateDraw(const eval::Draw& draw, const std::string& scenario, double duration,
                              double position_fraction, double angle_rad,
                              const std::string& extra_yaml = "",
                              const std::vector<std::string>& overrides = {});

/// A change to the graph's specification before it is created (e.g. a parameter of an instance).
using GraphEdit = std::function<void(dfpc::GraphSpec&)>;

/// The `;`-separated settings in the environment variable `name` (empty when unset), e.g.
/// CDFF_GRAPH_SET="NODE.PARAM=VALUE;..." or CDFF_SCENARIO_SET="KEY=VALUE;...".
std::vector<std::string> settingsFromEnvironment(const char* name);

/// The graph, loaded from dfpcs/<graph>.yaml (lidar_tracking.yaml unless told), with its model
/// read from `mesh_file`.
Result<std::unique_ptr<dfpc::Dfpc>> loadGraph(const std::filesystem::path& mesh_file,
                                              const GraphEdit& edit = {},
                                              const std::string& graph = "lidar_tracking");

struct TrackingResult {
  eval::PoseEvaluation evaluation;  // the pose products after `settle_s`
  std::size_t scans = 0;            // scans after settle_s
  std::size_t accepted = 0;         // of those, fused by the EKF
  double tracked_fraction = 0;      // accepted / scans
  std::vector<dfpc::Event> events;
  std::vector<dfpc::Message> products;   // every product of the run
  std::string graph = "lidar_tracking";  // the DFPC: its products are on /cdff/<graph>/...
};

/// Runs the DFPC over `messages` (plus the initial state), evaluating from `settle_s` after the
/// first scan on.
Result<TrackingResult> track(const SimulatedRun& run, std::vector<dfpc::Message> messages,
                             const RigidBodyState& initial, double settle_s,
                             const GraphEdit& edit = {});

/// Runs the DFPC dfpcs/<graph>.yaml over `messages` with no initial state at all (it must find
/// the target itself), evaluating the pose products from `settle_s` after the first scan on.
Result<TrackingResult> trackWithoutPrior(const SimulatedRun& run,
                                         std::vector<dfpc::Message> messages, double settle_s,
                                         const GraphEdit& edit = {},
                                         const std::string& graph = "lidar_tracking");

/// The track state reported with each pose product: the EKF's step publishes both, the pose
/// first, so the n-th pose product goes with the n-th track_state product.
std::vector<std::pair<Transform, std::string>> posesWithTrackState(const TrackingResult& r);

/// A pose reported TRACKING is a wrong lock when it is more than 10 degrees or 5 % of the range
/// off: far outside the tracking goals, the mark of a registration caught in another minimum.
constexpr double kWrongLockDeg = 10.0;
constexpr double kWrongLockPct = 5.0;

/// The pose products reported TRACKING, from the initial state on, against the truth.
struct ReportedTracking {
  std::vector<eval::MatchedError> errors;  // every TRACKING pose's error
  std::size_t wrong_locks = 0;             // of those, wrong locks
  double worst_deg = 0;                    // the worst TRACKING pose's angle error
  double worst_pct = 0;                    // and position error, % of the range
};
Result<ReportedTracking> reportedTracking(const TrackingResult& r,
                                          const std::vector<Transform>& truth);

}  // namespace cdff::lidar_tracking
