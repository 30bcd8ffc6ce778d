// The 3D reconstruction's geometry DFNs (issue 20) on the same synthetic pairs, each DFI side by
// side: FundamentalMatrixEstimation, EssentialMatrixEstimation, Triangulation and
// PerspectiveNPoint (tests/support/two_view: random points 4-7 m in front of a 1024 x 768
// camera, f = 800 px, seen from 0.5 m aside, 0.5 px noise, 20 % outliers), and BundleAdjustment
// on the key frames of a fly-around (tests/support/ring_views). The counters give the result's
// error against the truth.
#include <benchmark/benchmark.h>

#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "BundleAdjustment.gen.hpp"
#include "EssentialMatrixEstimation.gen.hpp"
#include "FundamentalMatrixEstimation.gen.hpp"
#include "PerspectiveNPoint.gen.hpp"
#include "Triangulation.gen.hpp"
#include "bench_support.hpp"
#include "support/ring_views.hpp"
#include "support/two_view.hpp"

namespace {

using cdff::bench::createConfigured;

cdff::testing::TwoViewScene scene(int points) {
  cdff::testing::TwoViewOptions options;
  options.points = points;
  options.sigma_px = 0.5;
  options.outlier_fraction = 0.2;
  options.seed = 3;
  return cdff::testing::twoViewScene(options);
}

constexpr const char* kConfig = "{threshold: 3.0, confidence: 0.999}";

void BM_FundamentalMatrixEstimation(benchmark::State& state, const char* dfi) {
  const cdff::testing::TwoViewScene s = scene(static_cast<int>(state.range(0)));
  auto dfn = createConfigured<cdff::dfn::FundamentalMatrixEstimation>("FundamentalMatrixEstimation",
                                                                      dfi, kConfig);
  if (!dfn) return state.SkipWithError("configuration failed");
  dfn->in.correspondences.set(s.observed);
  for (auto _ : state)
    if (!dfn->process()) return state.SkipWithError("FundamentalMatrixEstimation failed");
  Eigen::Matrix3d f;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) f(r, c) = (*dfn->out.fundamental)[r][c].get<double>();
  double sum2 = 0;
  int n = 0;
  for (std::size_t i = 0; i < s.inlier.size(); ++i)
    if (s.inlier[i]) {
      const double d = cdff::testing::sampsonDistance(f, s.truth.first[i], s.truth.second[i]);
      sum2 += d * d;
      ++n;
    }
  state.counters["sampson_rms_px"] = std::sqrt(sum2 / n);
  state.counters["inliers"] = *dfn->out.inlier_count;
}
BENCHMARK_CAPTURE(BM_FundamentalMatrixEstimation, Ransac, "Ransac")
    ->Arg(200)
    ->Arg(2000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_FundamentalMatrixEstimation, Magsac, "Magsac")
    ->Arg(200)
    ->Arg(2000)
    ->Unit(benchmark::kMillisecond);

void BM_EssentialMatrixEstimation(benchmark::State& state, const char* dfi) {
  const cdff::testing::TwoViewScene s = scene(static_cast<int>(state.range(0)));
  auto dfn = createConfigured<cdff::dfn::EssentialMatrixEstimation>("EssentialMatrixEstimation",
                                                                    dfi, kConfig);
  if (!dfn) return state.SkipWithError("configuration failed");
  dfn->in.correspondences.set(s.observed);
  dfn->in.camera.set(s.camera);
  for (auto _ : state)
    if (!dfn->process()) return state.SkipWithError("EssentialMatrixEstimation failed");
  const cdff::Transform& pose = *dfn->out.pose;
  const Eigen::Vector3d t = s.first_T_second.translation.normalized();
  state.counters["rotation_error_deg"] =
      cdff::angularDistance(pose.rotation, s.first_T_second.rotation) * 180 / M_PI;
  state.counters["direction_error_deg"] =
      std::atan2(pose.translation.cross(t).norm(), pose.translation.dot(t)) * 180 / M_PI;
  state.counters["inliers"] = *dfn->out.inlier_count;
}
BENCHMARK_CAPTURE(BM_EssentialMatrixEstimation, Ransac, "Ransac")
    ->Arg(200)
    ->Arg(2000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_EssentialMatrixEstimation, Magsac, "Magsac")
    ->Arg(200)
    ->Arg(2000)
    ->Unit(benchmark::kMillisecond);

void BM_Triangulation(benchmark::State& state, const char* dfi) {
  const cdff::testing::TwoViewScene s = scene(static_cast<int>(state.range(0)));
  auto dfn = createConfigured<cdff::dfn::Triangulation>("Triangulation", dfi, "{}");
  if (!dfn) return state.SkipWithError("configuration failed");
  dfn->in.correspondences.set(s.observed);
  dfn->in.camera.set(s.camera);
  dfn->in.pose.set(s.first_T_second);
  for (auto _ : state)
    if (!dfn->process()) return state.SkipWithError("Triangulation failed");
  double sum2 = 0;
  int n = 0;
  std::size_t k = 0;
  for (std::size_t i = 0; i < s.inlier.size(); ++i) {
    if ((*dfn->out.status)[i] != "ok") continue;
    const Eigen::Vector3d p = dfn->out.points->points[k++].vec().cast<double>();
    if (s.inlier[i]) sum2 += (p - s.points[i]).squaredNorm(), ++n;
  }
  state.counters["rms_error_mm"] = 1000 * std::sqrt(sum2 / n);
  state.counters["accepted"] = *dfn->out.accepted;
}
BENCHMARK_CAPTURE(BM_Triangulation, Dlt, "Dlt")->Arg(200)->Arg(2000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Triangulation, Midpoint, "Midpoint")
    ->Arg(200)
    ->Arg(2000)
    ->Unit(benchmark::kMicrosecond);

void BM_PerspectiveNPoint(benchmark::State& state, const char* dfi) {
  const cdff::testing::TwoViewScene s = scene(static_cast<int>(state.range(0)));
  cdff::Correspondences2D3D pairs;
  pairs.points = s.points;
  pairs.pixels = s.observed.second;
  auto dfn = createConfigured<cdff::dfn::PerspectiveNPoint>("PerspectiveNPoint", dfi, "{}");
  if (!dfn) return state.SkipWithError("configuration failed");
  dfn->in.correspondences.set(pairs);
  dfn->in.camera.set(s.camera);
  for (auto _ : state)
    if (!dfn->process()) return state.SkipWithError("PerspectiveNPoint failed");
  const cdff::Transform truth = s.first_T_second.inverse();
  const cdff::Transform& pose = dfn->out.pose->pose;
  state.counters["translation_error_mm"] = 1000 * (pose.translation - truth.translation).norm();
  state.counters["rotation_error_deg"] =
      cdff::angularDistance(pose.rotation, truth.rotation) * 180 / M_PI;
  state.counters["inliers"] = *dfn->out.inlier_count;
}
BENCHMARK_CAPTURE(BM_PerspectiveNPoint, EpnpRansac, "EpnpRansac")
    ->Arg(200)
    ->Arg(2000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PerspectiveNPoint, SqpnpRansac, "SqpnpRansac")
    ->Arg(200)
    ->Arg(2000)
    ->Unit(benchmark::kMillisecond);

// BundleAdjustment/Ceres, one thread: key frames 3 m from the centre of a 2 m object (about 2 m
// from its surface), 1024 x 768, f = 800 px, 0.5 px noise, 2 % outliers, the initial guess 2 cm
// and 0.3 deg off. Arguments: key frames, points, arc (deg of azimuth: 45 for a sliding window,
// 360 for the whole fly-around), held poses, max_dense_poses, compute_covariance.
void BM_BundleAdjustment(benchmark::State& state) {
  cdff::testing::RingOptions o;
  o.cameras = static_cast<int>(state.range(0));
  o.points = static_cast<int>(state.range(1));
  o.arc = state.range(2) * M_PI / 180;
  o.exact_poses = static_cast<int>(state.range(3));
  o.outlier_fraction = 0.02;
  o.seed = 11;
  const cdff::testing::RingScene s = cdff::testing::ringScene(o);
  auto dfn = createConfigured<cdff::dfn::BundleAdjustment>(
      "BundleAdjustment", "Ceres",
      fmt::format("{{fixed_poses: {}, max_dense_poses: {}, compute_covariance: {}, threads: 1}}",
                  state.range(3), state.range(4), state.range(5) ? "true" : "false"));
  if (!dfn) return state.SkipWithError("configuration failed");
  dfn->in.poses.set(cdff::testing::ringPoses(s.initial_poses));
  dfn->in.points.set(cdff::testing::ringPoints(s.initial_points));
  dfn->in.observations.set(cdff::testing::ringObservations(s));
  dfn->in.camera.set(s.camera);
  for (auto _ : state)
    if (!dfn->process()) return state.SkipWithError("BundleAdjustment failed");
  double sum2 = 0;
  for (int i = o.exact_poses; i < o.cameras; ++i)
    sum2 +=
        (dfn->out.poses->poses[i].translation() - s.world_T_camera[i].translation()).squaredNorm();
  state.counters["observations"] = static_cast<double>(s.observations.size());
  state.counters["inliers"] = *dfn->out.inlier_count;
  state.counters["rms_error_px"] = *dfn->out.rms_error;
  state.counters["position_rms_mm"] = 1000 * std::sqrt(sum2 / (o.cameras - o.exact_poses));
}
BENCHMARK(BM_BundleAdjustment)
    ->ArgNames({"frames", "points", "arc", "held", "max_dense", "cov"})
    ->Args({10, 500, 45, 3, 100, 0})
    ->Args({10, 500, 45, 3, 0, 0})
    ->Args({10, 500, 45, 3, 100, 1})
    ->Args({50, 2000, 360, 1, 100, 0})
    ->Args({50, 2000, 360, 1, 0, 0})
    ->Args({50, 2000, 360, 1, 100, 1})
    ->Unit(benchmark::kMillisecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
