// PoseRefinement/DepthIcp on the procedural target seen by the stereo rig's left camera at half
// resolution (812x617, where StereoMatching gives the detection's depth):
// - speed: one depth map (evaluation draw 7, at 10.6 m), 1 and 10 candidates (4 starts each);
//   the search for the model's near-symmetries, once per model (box and hexagonal targets);
// - accuracy over the evaluation draws (data/evaluation/draws.yaml; CDFF_DRAW_SET, CDFF_DRAWS):
//   draw N places the target (attitude uniform on SO(3), range log-uniform over [3, 16] m,
//   centre in the middle half of the image, sun anywhere behind the camera's plane) from the
//   simulator seed N, and the detection to refine from the draw's initial-error stream: the
//   truth moved by the model's near-symmetry N mod 4 (0: not moved; the procedural target's are
//   its three half turns, registration::nearSymmetries), then turned by
//   up to 15 degrees and moved by up to 10 % of the range (a correct detection's bounds). Two
//   depths: `stereo` (the pair rendered by the simulator's renderer, StereoMatching/Sgbm) and
//   `ray_cast` (ray-cast truth plus independent noise at the DFI's depth-noise setting).
//   Counters: the fraction within the goal (1 % of the range, 2 degrees) overall and per range
//   band, the median errors, and the mean NEES of the pose covariance over the draws within the
//   goal (6 when the covariance is honest).
// Environment: CDFF_DRAW_SET / CDFF_DRAWS (bench_support.hpp); CDFF_REFINEMENT_YAML and
// CDFF_STEREO_YAML, settings of PoseRefinement/DepthIcp and StereoMatching/Sgbm to try;
// CDFF_FROM_TRUTH, refine from the truth itself (what the depth alone holds the pose to);
// CDFF_VERBOSE, one line per draw.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "PoseRefinement.gen.hpp"
#include "StereoMatching.gen.hpp"
#include "bench_support.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/range_sensors.hpp"
#include "cdff/egse/raycaster.hpp"
#include "cdff/egse/rng.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/eval/draws.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/registration/model_symmetry.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/opencv.hpp"
#include "depth_fit.hpp"
#include "linemod_training.hpp"

#ifndef CDFF_SOURCE_DIR
#define CDFF_SOURCE_DIR "."
#endif

namespace cdff {
namespace {

using bench::createConfigured;

constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr double kBaseline = 0.2;  // m, the simulated rig's (stereo_matching_bench)
constexpr const char* kFrame = "camera_left_optical";

CameraModel undistorted(CameraModel m) {
  m.distortion_model = DistortionModel::kNone;
  m.distortion.clear();
  return m;
}

struct Shared {
  egse::TargetModel target;
  std::unique_ptr<egse::RayCaster> caster;
  PointCloud model;
  std::vector<Eigen::Isometry3d> symmetries;  // of the model (PoseRefinement's starts)
  CameraModel full = undistorted(egse::prosilicaGc1600h());
  CameraModel camera = cameraAfterPyrDown(undistorted(egse::prosilicaGc1600h()), 1);
};

const Shared& shared() {
  static const Shared* s = [] {
    auto* out = new Shared;
    out->target = egse::makeTargetSatellite().value();
    out->caster = egse::RayCaster::create(out->target).value();
    const auto points = static_cast<std::size_t>(out->target.surfaceArea() / (0.02 * 0.02));
    out->model = sampleSurface(out->target.mesh, points, 7).value();
    out->model.frame_id = "target";
    registration::ModelIndex index;
    (void)index.update(out->model);
    out->symmetries = registration::motionsOf(registration::nearSymmetries(index));
    return out;
  }();
  return *s;
}

/// One draw: the truth, the sun, and the detection to refine.
struct Case {
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  Eigen::Vector3d sun = -Eigen::Vector3d::UnitZ();
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  double range = 0;
};

Case caseOf(const eval::Draw& draw) {
  const Shared& s = shared();
  std::mt19937_64 scene(draw.simulator_seed), error(draw.initial_error_seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0, 1);
  Case c;
  c.range = 3.0 * std::pow(16.0 / 3.0, u(scene));
  const Eigen::Vector3d centre((u(scene) - 0.5) * 0.5 * s.camera.width / s.camera.fx,
                               (u(scene) - 0.5) * 0.5 * s.camera.height / s.camera.fy, 1.0);
  c.truth.linear() =
      Eigen::Quaterniond(g(scene), g(scene), g(scene), g(scene)).normalized().toRotationMatrix();
  c.truth.translation() =
      centre.normalized() * c.range - c.truth.linear() * s.target.boundingCentre();
  c.sun = Eigen::Vector3d(g(scene), g(scene), -std::abs(g(scene)) - 0.3).normalized();
  const std::size_t turn = draw.number % 4;
  const Eigen::Isometry3d turned = pose_refinement::startsOf(c.truth, s.symmetries)[turn];
  const Eigen::Vector3d axis = Eigen::Vector3d(g(error), g(error), g(error)).normalized();
  const Eigen::Vector3d direction = Eigen::Vector3d(g(error), g(error), g(error)).normalized();
  const double angle = 15 * kDeg * u(error), shift = 0.10 * u(error) * c.range;
  const Eigen::Vector3d at = turned * s.target.boundingCentre();
  c.start.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * turned.linear();
  c.start.translation() = at + direction * shift - c.start.linear() * s.target.boundingCentre();
  return c;
}

/// Ray-cast depth with independent noise at the DFI's default setting.
Result<DepthMap> rayCastDepth(const Case& c, std::uint64_t seed) {
  const Shared& s = shared();
  egse::TofSpec spec;
  spec.model = s.camera;
  spec.max_range = 40;
  spec.min_amplitude = 0;
  spec.noise_constant = 0.005;
  spec.noise_quadratic = 0.0017;
  Result<egse::TofSensor> sensor = egse::TofSensor::create(spec, "depth");
  if (!sensor) return sensor.status();
  egse::Rng rng(seed);
  Result<DepthMap> d = sensor->capture(*s.caster, s.target, c.truth, 0.0, rng);
  if (d) d->image.frame_id = kFrame;
  return d;
}

/// The rendered stereo pair's depth (StereoMatching/Sgbm on the half-resolution pair).
Result<DepthMap> stereoDepth(const Case& c, dfn::StereoMatching& matcher) {
  const Shared& s = shared();
  Result<linemod_templates::ViewRenderer> renderer = linemod_templates::ViewRenderer::create(
      s.target, s.full, 1, egse::RendererBackend::kCpu, c.sun);
  if (!renderer) return renderer.status();
  Eigen::Isometry3d right_T_left = Eigen::Isometry3d::Identity();
  right_T_left.translation() = Eigen::Vector3d(-kBaseline, 0, 0);
  Result<linemod_templates::RenderedView> left = renderer->render(c.truth);
  if (!left) return left.status();
  Result<linemod_templates::RenderedView> right = renderer->render(right_T_left * c.truth);
  if (!right) return right.status();
  StereoImagePair pair;
  Result<Image> l = fromMat(left->image.clone(), 0, kFrame);
  Result<Image> r = fromMat(right->image.clone(), 0, "camera_right_optical");
  if (!l || !r) return invalidInput("cannot wrap the rendered pair");
  pair.left = *l;
  pair.right = *r;
  pair.left.camera = pair.right.camera = s.camera;
  pair.right_T_left = Transform::fromIsometry(right_T_left, "camera_right_optical", kFrame, 0);
  matcher.in.rectified.set(pair);
  CDFF_RETURN_IF_ERROR(matcher.process());
  return *matcher.out.depth;
}

double nees(const PoseWithCovariance& estimate, const Eigen::Isometry3d& truth) {
  return eval::poseNees(estimate.pose, Transform::fromIsometry(truth, "", "", 0),
                        estimate.covariance);
}

Detections detectionsOf(const std::vector<Eigen::Isometry3d>& poses) {
  Detections d;
  d.frame_id = kFrame;
  for (const Eigen::Isometry3d& p : poses) {
    Detection one;
    one.pose = Transform::fromIsometry(p, kFrame, "target", 0);
    one.similarity = 0.8;
    d.detections.push_back(one);
  }
  return d;
}

void BM_PoseRefinement_Speed(benchmark::State& state) {
  const int candidates = static_cast<int>(state.range(0));
  const eval::Draw draw = eval::drawOf(7);
  Case c = caseOf(draw);
  Result<DepthMap> depth = rayCastDepth(c, draw.simulator_seed);
  if (!depth) return state.SkipWithError(depth.status().toString().c_str());
  // The first candidate is the draw's start, the others the truth turned 60 degrees or more.
  std::vector<Eigen::Isometry3d> poses = {c.start};
  for (int i = 1; i < candidates; ++i) {
    Eigen::Isometry3d p = c.truth;
    p.linear() = Eigen::AngleAxisd((40.0 + 20.0 * i) * kDeg, Eigen::Vector3d(1, 1, 0).normalized())
                     .toRotationMatrix() *
                 p.linear();
    poses.push_back(p);
  }
  auto dfn = createConfigured<dfn::PoseRefinement>("PoseRefinement", "DepthIcp");
  if (!dfn) return state.SkipWithError("cannot create or configure the DFI");
  dfn->in.detections.set(detectionsOf(poses));
  dfn->in.depth.set(*depth);
  dfn->in.model.set(shared().model);
  if (!dfn->process()) return state.SkipWithError("process failed");  // builds the structures
  for (auto _ : state) {
    const Status s = dfn->process();
    if (!s) return state.SkipWithError(s.toString().c_str());
  }
  state.counters["range_m"] = c.range;
}

const eval::DrawSets& drawSets() {
  static const eval::DrawSets sets = [] {
    Result<eval::DrawSets> s =
        eval::loadDrawSets(std::string(CDFF_SOURCE_DIR) + "/data/evaluation/draws.yaml");
    return s ? std::move(s).value() : eval::DrawSets{};
  }();
  return sets;
}

struct Band {
  double low, high;
  int draws = 0, within = 0;
};

void BM_PoseRefinement_Accuracy(benchmark::State& state, bool stereo) {
  Result<std::vector<eval::Draw>> draws = bench::drawsFromEnvironment(drawSets(), 40);
  if (!draws) return state.SkipWithError(draws.status().toString().c_str());
  const bool from_truth = std::getenv("CDFF_FROM_TRUTH") != nullptr;
  const bool verbose = std::getenv("CDFF_VERBOSE") != nullptr;
  // Settings to try (on the tuning draws) as inline YAML from the environment.
  const char* refinement = std::getenv("CDFF_REFINEMENT_YAML");
  const char* stereo_settings = std::getenv("CDFF_STEREO_YAML");
  auto dfn = createConfigured<dfn::PoseRefinement>(
      "PoseRefinement", "DepthIcp",
      refinement ? refinement : (stereo ? "{}" : "{missing_depth_cost: 9}"));
  auto matcher = createConfigured<dfn::StereoMatching>(
      "StereoMatching", "Sgbm",
      stereo_settings ? stereo_settings : "{pyramid_level: 0, min_depth: 2.0}");
  if (!dfn || !matcher) return state.SkipWithError("cannot create or configure the DFIs");
  std::vector<Band> bands = {{3, 6}, {6, 10}, {10, 16.01}};
  std::vector<double> angles, positions, nees_within, millis;
  int within = 0, refined = 0;
  for (auto _ : state) {
    for (const eval::Draw& draw : *draws) {
      const Case c = caseOf(draw);
      Result<DepthMap> depth =
          stereo ? stereoDepth(c, *matcher) : rayCastDepth(c, draw.simulator_seed);
      if (!depth) return state.SkipWithError(depth.status().toString().c_str());
      dfn->in.detections.set(detectionsOf({from_truth ? c.truth : c.start}));
      dfn->in.depth.set(*depth);
      dfn->in.model.set(shared().model);
      const auto t0 = std::chrono::steady_clock::now();
      const Status s = dfn->process();
      millis.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      if (!s) return state.SkipWithError(s.toString().c_str());
      const Eigen::Isometry3d pose = dfn->out.pose->pose.isometry();
      const Eigen::Vector3d centre = shared().target.boundingCentre();
      const double angle = Eigen::AngleAxisd(pose.linear().transpose() * c.truth.linear()).angle();
      const double position = ((pose * centre) - (c.truth * centre)).norm() / c.range;
      angles.push_back(angle / kDeg);
      positions.push_back(100 * position);
      const bool ok = angle < 2 * kDeg && position < 0.01;
      within += ok;
      refined += *dfn->out.refined;
      if (ok) nees_within.push_back(nees(*dfn->out.pose, c.truth));
      for (Band& b : bands)
        if (c.range >= b.low && c.range < b.high) {
          ++b.draws;
          b.within += ok;
        }
      if (verbose)
        fmt::print("draw {} range {:.1f} m turn {}: {:.2f} deg {:.2f} % refined {} misfit {:.2f}\n",
                   draw.number, c.range, draw.number % 4, angle / kDeg, 100 * position,
                   *dfn->out.refined, *dfn->out.misfit);
    }
  }
  auto median = [](std::vector<double> v) {
    if (v.empty()) return std::nan("");
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  double mean_nees = 0;
  for (double n : nees_within) mean_nees += n / static_cast<double>(nees_within.size());
  const double n = static_cast<double>(draws->size());
  state.counters["draws"] = n;
  state.counters["within_goal"] = within / n;
  state.counters["refined"] = refined / n;
  for (const Band& b : bands)
    state.counters[fmt::format("within_{:.0f}_{:.0f}m", b.low, b.high)] =
        b.draws > 0 ? static_cast<double>(b.within) / b.draws : std::nan("");
  state.counters["angle_median_deg"] = median(angles);
  state.counters["position_median_pct"] = median(positions);
  state.counters["nees_mean"] = nees_within.empty() ? std::nan("") : mean_nees;
  state.counters["ms_median"] = median(millis);
}

/// registration::nearSymmetries of a procedural target (0: the box satellite, 1: the hexagonal
/// one) sampled 2 cm apart: what PoseRefinement and EdgeRefinement pay once per model.
void BM_NearSymmetries(benchmark::State& state) {
  const Result<egse::TargetModel> target =
      state.range(0) == 0 ? egse::makeTargetSatellite() : egse::makeHexagonalSatellite();
  if (!target) return state.SkipWithError(target.status().toString().c_str());
  const auto points = static_cast<std::size_t>(target->surfaceArea() / (0.02 * 0.02));
  Result<PointCloud> model = sampleSurface(target->mesh, points, 7);
  if (!model) return state.SkipWithError(model.status().toString().c_str());
  registration::ModelIndex index;
  if (!index.update(*model)) return state.SkipWithError("cannot index the model");
  std::size_t found = 0;
  for (auto _ : state) found = registration::nearSymmetries(index).size();
  state.counters["symmetries"] = static_cast<double>(found);
  state.counters["model_points"] = static_cast<double>(points);
}

BENCHMARK(BM_PoseRefinement_Speed)->Arg(1)->Arg(10)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_NearSymmetries)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PoseRefinement_Accuracy, stereo, true)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PoseRefinement_Accuracy, ray_cast, false)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace cdff
CDFF_BENCHMARK_MAIN();
