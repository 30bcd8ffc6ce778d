// The visual tracking DFPC (dfpcs/visual_tracking.yaml: undistortion, edge tracker, EKF) through
// the Orchestrator, one simulated 1624x1234 camera frame per iteration: frames of the simulator's
// close-range approach (2 m -> 0.5 m, one every 2 s) and of the mid-range approach (17 m -> 2 m,
// one every 3 s) are rendered once, then tracked in a loop that starts from the true pose at
// each pass. Each chain (CDFF's EdgeTracker, ViSP's vpMbGenericTracker) runs in the same program;
// counters give the worst errors over the frames and the frames not tracking. ViSP runs with its
// moving-edge settings for 640x480 scaled to the 1624x1234 images (kVispScaled), its covariance
// on (EdgeTracker computes one too) and off. Then the
// acquisition frame alone: the first frame after an initial pose 5 % of the range and 5 degrees
// off. CPU time of the whole process on one thread (OMP_NUM_THREADS=1 for ViSP).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <map>
#include <random>

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

// ViSP's moving-edge settings are given for 640x480 images (its Castle-simu configuration, the
// DFI's defaults: 5 px masks, +-8 px search, 5 px sample step, likelihood threshold 10 000); the
// DFI scales them to the 1624x1234 images by the width ratio 2.54 (13 px masks, +-20 px,
// 12.7 px, threshold 67 600; see its pixel_settings_width).
const std::string kVispScaled = "pixel_settings_width: 640";

void trackApproach(benchmark::State& state, const std::string& scenario, const std::string& dfi,
                   const std::string& dfi_parameters = "") {
  const visual_demo::SimulatedFrames& seq = frames(scenario);
  if (seq.images.empty()) {
    state.SkipWithError("the simulation failed");
    return;
  }
  visual_demo::ApproachOptions o;
  o.dfi = dfi;
  o.dfi_parameters = dfi_parameters;
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
  trackApproach(s, "close_range_approach", "VispMbt", "{" + kVispScaled + ", covariance: on}");
}
void BM_Dfpc_CloseRange_VispMbt_no_covariance(benchmark::State& s) {
  trackApproach(s, "close_range_approach", "VispMbt", "{" + kVispScaled + ", covariance: off}");
}
void BM_Dfpc_MidRange_EdgeTracker(benchmark::State& s) {
  trackApproach(s, "mid_range_approach", "EdgeTracker");
}
void BM_Dfpc_MidRange_VispMbt(benchmark::State& s) {
  trackApproach(s, "mid_range_approach", "VispMbt", "{" + kVispScaled + ", covariance: on}");
}
void BM_Dfpc_MidRange_VispMbt_no_covariance(benchmark::State& s) {
  trackApproach(s, "mid_range_approach", "VispMbt", "{" + kVispScaled + ", covariance: off}");
}
BENCHMARK(BM_Dfpc_CloseRange_EdgeTracker)
    ->Iterations(60)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Dfpc_CloseRange_VispMbt)
    ->Iterations(60)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Dfpc_CloseRange_VispMbt_no_covariance)
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
BENCHMARK(BM_Dfpc_MidRange_VispMbt_no_covariance)
    ->Iterations(60)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);

// The first frame (t = 0) of the scenario, rendered once.
const visual_demo::SimulatedFrames& firstFrame(const std::string& scenario) {
  static std::map<std::string, Result<visual_demo::SimulatedFrames>> cache;
  auto it = cache.find(scenario);
  if (it == cache.end()) {
    visual_demo::ApproachOptions o;
    o.scenario = scenario;
    o.duration = 0.1;
    it = cache.emplace(scenario, visual_demo::simulateFrames(o)).first;
  }
  static const visual_demo::SimulatedFrames empty;
  return it->second ? *it->second : empty;
}

// The initial pose of the simulated-approach tests (examples/visual_tracking): the true pose
// moved by 5 % of the range in a random direction and turned by 5 degrees about a random axis
// (their first draw), with the covariance that says so and a still target's twist sigmas.
RigidBodyState perturbedInitialPose(const Transform& truth) {
  std::mt19937 rng(1);
  const auto direction = [&rng] {
    std::normal_distribution<double> n(0.0, 1.0);
    Eigen::Vector3d d;
    do d = Eigen::Vector3d(n(rng), n(rng), n(rng));
    while (d.norm() < 1e-6);
    return d.normalized();
  };
  const double angle = 5.0 * M_PI / 180;
  const double offset = 0.05 * truth.translation.norm();
  Eigen::Isometry3d p = truth.isometry();
  p.translation() += offset * direction();
  p.linear() = expSO3(angle * direction()).toRotationMatrix() * truth.isometry().linear();
  RigidBodyState s;
  s.pose = Transform::fromIsometry(p, truth.parent_frame, truth.child_frame, truth.stamp);
  s.covariance.diagonal() << Eigen::Vector3d::Constant(offset * offset),
      Eigen::Vector3d::Constant(angle * angle), Eigen::Vector3d::Constant(0.05 * 0.05),
      Eigen::Vector3d::Constant(angle * angle);
  return s;
}

// The acquisition frame through dfpcs/visual_tracking.yaml (coarse alignment on): each iteration
// re-initialises the filter with the perturbed pose and tracks the scenario's first frame, 10 s of
// stream time after the previous one. Counters: the tracker's status (1 = DEGRADED, ACQUIRING)
// and the error of its measurement.
void acquireFirstFrame(benchmark::State& state, const std::string& scenario) {
  const visual_demo::SimulatedFrames& seq = firstFrame(scenario);
  if (seq.images.empty()) {
    state.SkipWithError("the simulation failed");
    return;
  }
  Result<std::unique_ptr<dfpc::Dfpc>> graph = visual_demo::makeDfpc(visual_demo::ApproachOptions{});
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
  const Image& first = seq.images.front();
  (void)orchestrator.process(
      dfpc::Message::of("/chaser/tf/camera_left_optical", 0, seq.camera_mounting));
  (void)orchestrator.process(
      dfpc::Message::of("/cdff/visual_tracking/model", first.stamp, seq.model));
  const RigidBodyState initial = perturbedInitialPose(seq.truth.front());
  std::size_t pass = 0;
  // One acquisition, 10 s of stream time after the previous one; the first (the remap table's
  // and OpenCV's initialisation) is not timed.
  const auto acquire = [&](benchmark::State* timed) {
    const Timestamp shift = static_cast<Timestamp>(pass++) * 10'000'000;
    RigidBodyState init = initial;
    init.pose.stamp = first.stamp + shift;
    (void)orchestrator.process(
        dfpc::Message::of("/cdff/visual_tracking/initial_pose", init.pose.stamp, init));
    Image image = first;
    image.stamp += shift;
    if (timed) timed->ResumeTiming();
    const bool ok =
        orchestrator.process(dfpc::Message::of("/chaser/camera/left/image", image.stamp, image))
            .isOk();
    if (timed) timed->PauseTiming();
    return ok;
  };
  if (!acquire(nullptr)) {
    state.SkipWithError("the DFPC failed");
    return;
  }
  for (auto _ : state) {
    state.PauseTiming();
    if (!acquire(&state)) {
      state.SkipWithError("the DFPC failed");
      return;
    }
    state.ResumeTiming();
  }
  double error_mm = 0, error_deg = 0;
  int status = -1;
  const auto measurements = sink.messages("/cdff/visual_tracking/measurement");
  const auto statuses = sink.messages("/cdff/visual_tracking/status");
  if (!measurements.empty() && !statuses.empty()) {
    const Transform& est = measurements.back().as<PoseWithCovariance>()->pose;
    const Transform& truth = seq.truth.front();
    error_mm = (est.translation - truth.translation).norm() * 1e3;
    error_deg = angularDistance(est.rotation, truth.rotation) * 180 / M_PI;
    status = *statuses.back().as<int>();
  }
  state.counters["status"] = status;
  state.counters["error_mm"] = error_mm;
  state.counters["error_deg"] = error_deg;
}

void BM_Dfpc_MidRange_Acquisition(benchmark::State& s) {
  acquireFirstFrame(s, "mid_range_approach");
}
void BM_Dfpc_CloseRange_Acquisition(benchmark::State& s) {
  acquireFirstFrame(s, "close_range_approach");
}
BENCHMARK(BM_Dfpc_MidRange_Acquisition)
    ->Iterations(20)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Dfpc_CloseRange_Acquisition)
    ->Iterations(20)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
