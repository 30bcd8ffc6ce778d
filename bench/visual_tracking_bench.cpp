// Model-based visual tracking on ViSP's Castle-simu sequence (visp-images-data; 40 frames,
// 640x480, CAD model, true poses): CDFF's EdgeTracker and ViSP's vpMbGenericTracker (the VispMbt
// DFI) side by side in one run, each frame one benchmark iteration through the same DFN interface.
// Each pass over the sequence starts from the true pose of frame 1 and predicts every frame with
// the previous estimate, as ViSP's own regression test does; the counters give the worst errors
// against the true poses (geodesic angle, and ViSP's theta-u metric), the frames not tracked and
// the mean number of features (edge samples, depth points) per frame.
// Then the atomic steps EdgeTracker is made of, each on one frame.
//
// CPU time is the whole process's (MeasureProcessCPUTime), so that threads a library starts are
// counted; run with OMP_NUM_THREADS=1 for one-core figures (ViSP is built with OpenMP).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <memory>
#include <vector>

#include "../tests/support/castle_simu.hpp"
#include "ContourSampling.gen.hpp"
#include "EdgeMatching.gen.hpp"
#include "EdgePoseEstimation.gen.hpp"
#include "ModelBasedTracking.gen.hpp"
#include "VisibilityDetermination.gen.hpp"
#include "bench_support.hpp"

namespace {

namespace castle = cdff::testing::castle;
using cdff::dfn::ModelBasedTracking;

struct Sequence {
  cdff::PolygonModel model;
  std::vector<castle::Frame> frames;
  cdff::Status status;
};

const Sequence& sequence() {
  static const Sequence s = [] {
    Sequence out;
    auto model = castle::model();
    if (!model) {
      out.status = model.status();
      return out;
    }
    out.model = std::move(model).value();
    for (int k = 1; k <= castle::kFrames; ++k) {
      auto frame = castle::frame(k, true);
      if (!frame) {
        out.status = frame.status();
        return out;
      }
      out.frames.push_back(std::move(frame).value());
    }
    return out;
  }();
  return s;
}

constexpr double kDeg = 180.0 / M_PI;
const char* kVispSettings =
    "{me_mask_size: 5, me_mask_number: 180, me_range: 8, me_threshold: 10000, me_mu1: 0.5, "
    "me_mu2: 0.5, me_sample_step: 5, angle_appear: 85, angle_disappear: 89, "
    "near_clipping: 0.01, far_clipping: 2, fov_clipping: true, depth_dense_step: 4, "
    "depth_extrinsics: [-0.05, 0, 0, 0, 0, 0], mode: ";

void trackCastle(benchmark::State& state, const std::string& dfi, const std::string& yaml,
                 bool depth) {
  const Sequence& seq = sequence();
  if (!seq.status) {
    state.SkipWithError(seq.status.toString().c_str());
    return;
  }
  auto node = cdff::bench::createConfigured<ModelBasedTracking>("ModelBasedTracking", dfi, yaml);
  if (!node) {
    state.SkipWithError("cannot configure the tracker");
    return;
  }
  auto model = std::make_shared<const cdff::PolygonModel>(seq.model);
  node->in.model.set(model);
  std::vector<std::shared_ptr<const cdff::Image>> images;
  std::vector<std::shared_ptr<const cdff::DepthMap>> depths;
  for (const castle::Frame& f : seq.frames) {
    images.push_back(std::make_shared<const cdff::Image>(f.image));
    depths.push_back(std::make_shared<const cdff::DepthMap>(f.depth));
  }
  cdff::PoseWithCovariance predicted;
  double max_t = 0, max_a = 0, max_tu = 0, features = 0;
  int not_tracking = 0, calls = 0;
  std::size_t k = 0;
  for (auto _ : state) {
    if (k == 0)
      predicted.pose =
          cdff::Transform::fromIsometry(seq.frames[0].camera_T_model, "camera", "castle");
    node->in.image.set(images[k]);
    if (depth) node->in.depth.set(depths[k]);
    node->in.predicted_pose.set(predicted);
    if (!node->process()) {
      state.SkipWithError(node->diagnostics().last_error.c_str());
      return;
    }
    predicted = *node->out.pose;
    state.PauseTiming();
    const castle::PoseError e =
        castle::poseError(predicted.pose.isometry(), seq.frames[k].camera_T_model);
    max_t = std::max(max_t, e.translation);
    max_a = std::max(max_a, e.angle);
    max_tu = std::max(max_tu, e.theta_u);
    not_tracking += *node->out.status != static_cast<int>(cdff::TrackingStatus::kTracking);
    features += *node->out.feature_count;
    ++calls;
    k = (k + 1) % seq.frames.size();
    state.ResumeTiming();
  }
  state.counters["max_mm"] = max_t * 1e3;
  state.counters["max_deg"] = max_a * kDeg;
  state.counters["max_thetau_deg"] = max_tu * kDeg;
  state.counters["not_tracking"] = not_tracking;
  state.counters["features"] = features / std::max(calls, 1);
}

void BM_Castle_EdgeTracker_edges(benchmark::State& state) {
  trackCastle(state, "EdgeTracker", "{}", false);
}
void BM_Castle_EdgeTracker_edges_depth(benchmark::State& state) {
  trackCastle(state, "EdgeTracker", "{depth_extrinsics: [-0.05, 0, 0, 0, 0, 0]}", true);
}
void BM_Castle_VispMbt_edges(benchmark::State& state) {
  trackCastle(state, "VispMbt", std::string(kVispSettings) + "edges}", false);
}
// ViSP's tracker alone: without the covariance, which ViSP gets from an N x N matrix.
void BM_Castle_VispMbt_edges_no_covariance(benchmark::State& state) {
  trackCastle(state, "VispMbt", std::string(kVispSettings) + "edges, covariance: off}", false);
}
void BM_Castle_VispMbt_edges_klt(benchmark::State& state) {
  trackCastle(state, "VispMbt", std::string(kVispSettings) + "edges_klt}", false);
}
void BM_Castle_VispMbt_edges_depth(benchmark::State& state) {
  trackCastle(state, "VispMbt", std::string(kVispSettings) + "edges_depth}", true);
}
// Whole passes over the sequence, so that the error counters cover all 40 frames.
BENCHMARK(BM_Castle_EdgeTracker_edges)
    ->Iterations(400)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Castle_EdgeTracker_edges_depth)
    ->Iterations(400)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Castle_VispMbt_edges)
    ->Iterations(200)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Castle_VispMbt_edges_no_covariance)
    ->Iterations(200)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Castle_VispMbt_edges_klt)
    ->Iterations(200)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Castle_VispMbt_edges_depth)
    ->Iterations(200)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);

// The atomic steps on frame 20 at its true pose.
struct Steps {
  std::unique_ptr<cdff::dfn::VisibilityDetermination> visibility =
      cdff::bench::createConfigured<cdff::dfn::VisibilityDetermination>("VisibilityDetermination",
                                                                        "HiddenLineRemoval");
  std::unique_ptr<cdff::dfn::ContourSampling> sampling =
      cdff::bench::createConfigured<cdff::dfn::ContourSampling>("ContourSampling", "Uniform");
  std::unique_ptr<cdff::dfn::EdgeMatching> matching =
      cdff::bench::createConfigured<cdff::dfn::EdgeMatching>("EdgeMatching", "NormalSearch");
  std::unique_ptr<cdff::dfn::EdgePoseEstimation> pose =
      cdff::bench::createConfigured<cdff::dfn::EdgePoseEstimation>("EdgePoseEstimation",
                                                                   "RobustGaussNewton");
  bool ok = false;

  Steps() {
    const Sequence& seq = sequence();
    if (!seq.status || !visibility || !sampling || !matching || !pose) return;
    const castle::Frame& f = seq.frames[19];
    visibility->in.model.set(seq.model);
    visibility->in.image.set(f.image);
    visibility->in.pose.set(cdff::Transform::fromIsometry(f.camera_T_model, "camera", "castle"));
    ok = visibility->process().isOk();
    sampling->in.contours.set(visibility->out.contours.shared());
    ok = ok && sampling->process().isOk();
    matching->in.image.set(f.image);
    matching->in.samples.set(sampling->out.samples.shared());
    ok = ok && matching->process().isOk();
    pose->in.matches.set(matching->out.matches.shared());
    ok = ok && pose->process().isOk();
  }
};

template <typename Dfn>
void runStep(benchmark::State& state, Dfn* (*pick)(Steps&), void (*refresh)(Steps&)) {
  Steps steps;
  if (!steps.ok) {
    state.SkipWithError("the Castle-simu data or a DFN is missing");
    return;
  }
  Dfn* node = pick(steps);
  for (auto _ : state) {
    refresh(steps);
    if (!node->process()) state.SkipWithError("process failed");
  }
}

void BM_Step_VisibilityDetermination(benchmark::State& state) {
  runStep<cdff::dfn::VisibilityDetermination>(
      state, [](Steps& s) { return s.visibility.get(); },
      [](Steps& s) { s.visibility->in.pose.set(s.visibility->in.pose.shared()); });
}
void BM_Step_ContourSampling(benchmark::State& state) {
  runStep<cdff::dfn::ContourSampling>(
      state, [](Steps& s) { return s.sampling.get(); }, [](Steps&) {});
}
void BM_Step_EdgeMatching(benchmark::State& state) {
  runStep<cdff::dfn::EdgeMatching>(
      state, [](Steps& s) { return s.matching.get(); }, [](Steps&) {});
}
void BM_Step_EdgePoseEstimation(benchmark::State& state) {
  runStep<cdff::dfn::EdgePoseEstimation>(
      state, [](Steps& s) { return s.pose.get(); }, [](Steps&) {});
}
BENCHMARK(BM_Step_VisibilityDetermination)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Step_ContourSampling)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Step_EdgeMatching)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Step_EdgePoseEstimation)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
