// The visual tracking DFPC (dfpcs/visual_tracking.yaml: undistortion, edge tracker, EKF) through
// the Orchestrator, one simulated 1624x1234 camera frame per iteration: frames of the simulator's
// close-range approach (2 m -> 0.5 m, one every 2 s) and of the mid-range approach (17 m -> 2 m,
// one every 3 s) are rendered once, then tracked in a loop that starts from the true pose at
// each pass. Each chain (CDFF's EdgeTracker, ViSP's vpMbGenericTracker) runs in the same program;
// counters give the worst errors over the frames and the frames not tracking. CPU time of the
// whole process on one thread (OMP_NUM_THREADS=1 for ViSP).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <map>

#include "bench_support.hpp"
#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/orchestrator.hpp"
#include "simulated_approach.hpp"

namespace {

using namespace cdff;

const visual_demo::SimulatedFrames& frames(const std::string& scenario) {
  static std::map<std::string, Result<visual_demo::SimulatedFrames>> cache;
  auto it = cache.find(scenario);
  if (it == cache.end()) {
    visual_demo::ApproachOptions o;
    o.scenario = scenario;
    o.camera_rate = scenario == "close_range_approach" ? 0.5 : 1.0 / 3.0;
    it = cache.emplace(scenario, visual_demo::simulateFrames(o)).first;
  }
  static const visual_demo::SimulatedFrames empty;
  return it->second ? *it->second : empty;
}

void trackApproach(benchmark::State& state, const std::string& scenario, const std::string& dfi) {
  const visual_demo::SimulatedFrames& seq = frames(scenario);
  if (seq.images.empty()) {
    state.SkipWithError("the simulation failed");
    return;
  }
  visual_demo::ApproachOptions o;
  o.dfi = dfi;
  Result<std::unique_ptr<dfpc::Dfpc>> graph = visual_demo::makeDfpc(o);
  if (!graph) {
    state.SkipWithError(graph.status().toString().c_str());
    return;
  }
  dfpc::MemorySink sink;
  dfpc::OrchestratorOptions options;
  options.sink = &sink;
  options.record_timing = false;
  dfpc::Orchestrator orchestrator(options);
  if (!orchestrator.add(std::move(graph).value()) || !orchestrator.startAll()) {
    state.SkipWithError("cannot start the DFPC");
    return;
  }
  std::vector<dfpc::Message> images;
  for (const Image& image : seq.images)
    images.push_back(dfpc::Message::of("/chaser/camera/left/image", image.stamp, image));
  const Timestamp period = seq.images.back().stamp - seq.images.front().stamp +
                           (seq.images[1].stamp - seq.images[0].stamp);
  double max_mm = 0, max_deg = 0, max_pct = 0;
  int not_tracking = 0;
  std::size_t k = 0, pass = 0;
  for (auto _ : state) {
    // Stream time keeps increasing from pass to pass: each pass is the sequence shifted.
    const Timestamp shift = static_cast<Timestamp>(pass) * period;
    if (k == 0) {
      state.PauseTiming();
      if (pass == 0) {
        (void)orchestrator.process(
            dfpc::Message::of("/chaser/tf/camera_left_optical", 0, seq.camera_mounting));
        (void)orchestrator.process(
            dfpc::Message::of("/cdff/visual_tracking/model", images[0].stamp, seq.model));
      }
      RigidBodyState initial;
      initial.pose = seq.truth[0];
      initial.pose.stamp += shift;
      initial.covariance.diagonal().setConstant(1e-8);
      (void)orchestrator.process(
          dfpc::Message::of("/cdff/visual_tracking/initial_pose", initial.pose.stamp, initial));
      state.ResumeTiming();
    }
    Image image = *images[k].as<Image>();
    image.stamp += shift;
    if (!orchestrator.process(dfpc::Message::of("/chaser/camera/left/image", image.stamp, image))) {
      state.SkipWithError("the DFPC failed");
      return;
    }
    state.PauseTiming();
    const auto poses = sink.messages("/cdff/visual_tracking/camera_pose");
    const auto statuses = sink.messages("/cdff/visual_tracking/status");
    if (!poses.empty() && !statuses.empty()) {
      const Transform& est = poses.back().as<RigidBodyState>()->pose;
      const Transform& truth = seq.truth[k];
      const double e = (est.translation - truth.translation).norm();
      max_mm = std::max(max_mm, e * 1e3);
      max_pct = std::max(max_pct, 100 * e / truth.translation.norm());
      max_deg = std::max(max_deg, angularDistance(est.rotation, truth.rotation) * 180 / M_PI);
      not_tracking += *statuses.back().as<int>() != 0;
    }
    if (++k == images.size()) {
      k = 0;
      ++pass;
    }
    state.ResumeTiming();
  }
  state.counters["frames"] = static_cast<double>(images.size());
  state.counters["max_mm"] = max_mm;
  state.counters["max_pct_range"] = max_pct;
  state.counters["max_deg"] = max_deg;
  state.counters["not_tracking"] = not_tracking;
}

void BM_Dfpc_CloseRange_EdgeTracker(benchmark::State& s) {
  trackApproach(s, "close_range_approach", "EdgeTracker");
}
void BM_Dfpc_CloseRange_VispMbt(benchmark::State& s) {
  trackApproach(s, "close_range_approach", "VispMbt");
}
void BM_Dfpc_MidRange_EdgeTracker(benchmark::State& s) {
  trackApproach(s, "mid_range_approach", "EdgeTracker");
}
void BM_Dfpc_MidRange_VispMbt(benchmark::State& s) {
  trackApproach(s, "mid_range_approach", "VispMbt");
}
BENCHMARK(BM_Dfpc_CloseRange_EdgeTracker)
    ->Iterations(60)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Dfpc_CloseRange_VispMbt)
    ->Iterations(60)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Dfpc_MidRange_EdgeTracker)
    ->Iterations(60)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Dfpc_MidRange_VispMbt)
    ->Iterations(60)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
