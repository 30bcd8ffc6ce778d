// The LIDAR tracking DFPC (dfpcs/lidar_tracking.yaml) step by step on the simulated mid-range
// approach: one iteration is one full VLP-16 scan (about 29 000 points, most of them in every
// direction but the target's) through the Orchestrator: the EKF's prediction ticks since the
// previous scan, crop and voxel grid, FastIcp, the frame change and the EKF correction. The
// scans are fed in order, as in a run; the DFPC is started again (untimed) when they run out.
//
// BM_ModelTracking3dStep: dfpcs/model_tracking_3d.yaml on the same scans, started with no
// initial state: each scan searched with no prior (GlobalRegistration3D/PointPairVoting), the
// clusters verified (PoseHypothesisSelection/IcpMisfit) and the decided pose fused by the EKF.
//
// BM_ModelTracking3dTofStep: dfpcs/model_tracking_3d_tof.yaml on the ToF camera's depth maps of
// the close-range approach's first 10 s (the LIDAR off), with no initial state: each depth map
// turned into its points, then as BM_ModelTracking3dStep.
#include <benchmark/benchmark.h>

#include <optional>

#include "bench_support.hpp"
#include "cdff/dfpc/orchestrator.hpp"
#include "lidar_tracking_support.hpp"

namespace cdff {
namespace {

using lidar_tracking::SimulatedRun;

const SimulatedRun& simulated() {
  static const SimulatedRun run = [] {
    Result<SimulatedRun> r = lidar_tracking::simulate("mid_range_approach", 0);
    return r ? std::move(r).value() : SimulatedRun{};
  }();
  return run;
}

const SimulatedRun& simulatedTof() {
  static const SimulatedRun run = [] {
    Result<SimulatedRun> r =
        lidar_tracking::simulate("close_range_approach", 10.0, "", 1,
                                 {"sensors.tof.enabled=true", "sensors.lidar.enabled=false"});
    return r ? std::move(r).value() : SimulatedRun{};
  }();
  return run;
}

/// The stamp of the run's first sensor frame (a LIDAR scan, else a depth map).
Timestamp firstFrame(const SimulatedRun& run) {
  return run.scans.empty() ? run.depth_stamps.front() : run.scans.front().stamp;
}

struct Tracker {
  std::unique_ptr<dfpc::Orchestrator> orchestrator;
  std::size_t next = 0;  // next message of the run
};

// A started DFPC (dfpcs/<graph>.yaml) that has processed the calibration, the initial state
// (lidar_tracking only) and the first second.
std::optional<Tracker> startTracker(const SimulatedRun& run,
                                    const std::string& graph_name = "lidar_tracking") {
  Result<std::unique_ptr<dfpc::Dfpc>> graph =
      lidar_tracking::loadGraph(run.mesh_file, {}, graph_name);
  if (!graph) return std::nullopt;
  Tracker t;
  t.orchestrator = std::make_unique<dfpc::Orchestrator>(dfpc::OrchestratorOptions{});
  if (!t.orchestrator->add(std::move(graph).value()) || !t.orchestrator->startAll())
    return std::nullopt;
  const Timestamp first = firstFrame(run);
  const RigidBodyState initial =
      lidar_tracking::perturbedInitialState(run.truth, first, 0.10, 10.0 * M_PI / 180.0, 7);
  bool initialised = graph_name != "lidar_tracking";  // the others start with no prior
  for (; t.next < run.messages.size(); ++t.next) {
    const dfpc::Message& m = run.messages[t.next];
    if (m.stamp > first + fromSeconds(1.0)) break;
    if (!initialised && m.channel == "/chaser/lidar/points") {
      if (!t.orchestrator->process(
              dfpc::Message::of("/cdff/lidar_tracking/initial_state", initial.pose.stamp, initial)))
        return std::nullopt;
      initialised = true;
    }
    if (!t.orchestrator->process(m)) return std::nullopt;
  }
  return t;
}

void trackingSteps(benchmark::State& state, const std::string& graph,
                   const SimulatedRun& run = simulated()) {
  if (run.scans.empty() && run.depth_stamps.empty())
    return state.SkipWithError("simulation failed");
  std::optional<Tracker> tracker = startTracker(run, graph);
  if (!tracker) return state.SkipWithError("the DFPC did not start");
  std::size_t points = 0, scans = 0;
  for (auto _ : state) {
    // Everything up to and including the next scan: one DFPC step per scan.
    bool scanned = false;
    while (!scanned) {
      if (tracker->next >= run.messages.size()) {
        state.PauseTiming();
        tracker = startTracker(run, graph);
        state.ResumeTiming();
        if (!tracker) return state.SkipWithError("the DFPC did not restart");
      }
      const dfpc::Message& m = run.messages[tracker->next++];
      if (const PointCloud* scan = m.as<PointCloud>()) {
        points += scan->size();
        ++scans;
        scanned = true;
      }
      scanned = scanned || m.as<DepthMap>() != nullptr;
      if (!tracker->orchestrator->process(m)) return state.SkipWithError("process failed");
    }
  }
  if (scans > 0)
    state.counters["scan_points"] = benchmark::Counter(static_cast<double>(points) / scans);
}

void BM_LidarTrackingStep(benchmark::State& state) {
  trackingSteps(state, "lidar_tracking");
}
BENCHMARK(BM_LidarTrackingStep)->Unit(benchmark::kMillisecond)->Iterations(800);

void BM_ModelTracking3dStep(benchmark::State& state) {
  trackingSteps(state, "model_tracking_3d");
}
BENCHMARK(BM_ModelTracking3dStep)->Unit(benchmark::kMillisecond)->Iterations(200);

void BM_ModelTracking3dTofStep(benchmark::State& state) {
  trackingSteps(state, "model_tracking_3d_tof", simulatedTof());
}
BENCHMARK(BM_ModelTracking3dTofStep)->Unit(benchmark::kMillisecond)->Iterations(100);

}  // namespace
}  // namespace cdff

CDFF_BENCHMARK_MAIN();
