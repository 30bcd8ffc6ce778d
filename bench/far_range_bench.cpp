// Far-range tracking: TemplateMatching's two DFIs side by side on the same frames (ours, the
// inverse compositional ZNCC, and OpenCV's findTransformECC behind the same coarse search and
// template handling), per frame, for a target of 5, 40 and 250 pixels (2 km, 250 m and 40 m
// from a 35 mm camera); the error of the tracked point is reported beside the time. And the
// bearing filter's step. One core (CDFF_BENCHMARK_MAIN).
//   build/bench/far_range_bench
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "BearingFilter.gen.hpp"
#include "TemplateMatching.gen.hpp"
#include "bench_support.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/tracking/relative_motion.hpp"
#include "support/far_target.hpp"

namespace cdff {
namespace {

struct Sequence {
  std::vector<Image> images;
  std::vector<Eigen::Vector2d> truth;  // the tracked point in each image
  ImageRegion designation;
};

/// 21 frames of the target at `scale` px per unit, moving by up to 3 px per frame.
Sequence makeSequence(double scale) {
  Sequence s;
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> move(-3, 3);
  const int size = std::max(160, static_cast<int>(8 * scale) + 64);
  Eigen::Vector2d centre(0.5 * size + 0.3, 0.5 * size - 0.4);
  const Eigen::Vector2d offset(0.3 * scale, 0.2 * scale);  // the designated point
  for (int k = 0; k <= 20; ++k) {
    if (k > 0) centre += Eigen::Vector2d(move(rng), move(rng));
    s.images.push_back(testing::renderFarTarget(centre, scale, 0, rng, k * 1'000'000, size));
    s.truth.push_back(centre + offset);
  }
  const int half = static_cast<int>(std::ceil(3.5 * scale)) + 6;
  s.designation =
      ImageRegion::box(s.truth[0].x() - half, s.truth[0].y() - half, 2 * half + 1, 2 * half + 1);
  s.designation.source = "user";
  return s;
}

void BM_TemplateMatching(benchmark::State& state, const char* dfi) {
  const double scale = state.range(0) / 7.0;  // the target's span in pixels / its 7 units
  const Sequence s = makeSequence(scale);
  auto node = dfn::Registry::instance().createAs<dfn::TemplateMatching>("TemplateMatching", dfi);
  if (!node || !(*node)->configure(YAML::Load("{}"))) {
    state.SkipWithError("cannot create the DFI");
    return;
  }
  dfn::TemplateMatching& m = **node;
  double sum_sq = 0;
  std::size_t matched = 0, frames = 0, k = 0;
  for (auto _ : state) {
    state.PauseTiming();
    if (k % s.images.size() == 0) m.in.designation.set(s.designation);
    m.in.image.set(s.images[k % s.images.size()]);
    state.ResumeTiming();
    const Status status = m.process();
    state.PauseTiming();
    if (!status) state.SkipWithError(status.toString().c_str());
    if (k % s.images.size() != 0) {
      ++frames;
      if (*m.out.found) {
        ++matched;
        sum_sq += (m.out.match->centre() - s.truth[k % s.images.size()]).squaredNorm();
      }
    }
    ++k;
    state.ResumeTiming();
  }
  state.counters["error_rms_px"] = matched ? std::sqrt(sum_sq / matched) : NAN;
  state.counters["matched"] = frames ? static_cast<double>(matched) / frames : 0;
}
BENCHMARK_CAPTURE(BM_TemplateMatching, Zncc, "Zncc")
    ->Arg(5)
    ->Arg(40)
    ->Arg(250)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_TemplateMatching, Ecc, "Ecc")
    ->Arg(5)
    ->Arg(40)
    ->Arg(250)
    ->Unit(benchmark::kMillisecond);

void BM_BearingFilterStep(benchmark::State& state) {
  auto node =
      dfn::Registry::instance().createAs<dfn::BearingFilter>("BearingFilter", "ExtendedKalman");
  if (!node || !(*node)->configure(YAML::Load("{}"))) {
    state.SkipWithError("cannot create the DFI");
    return;
  }
  dfn::BearingFilter& f = **node;
  CameraModel camera;
  camera.width = camera.height = 1024;
  camera.fx = camera.fy = 6363.6;
  camera.cx = camera.cy = 511.5;
  f.in.calibration.set(camera);
  Transform mount = Transform::identity("servicer", "camera_far_optical");
  mount.rotation =
      Eigen::Quaterniond((Eigen::Matrix3d() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished());
  f.in.camera_mount.set(mount);
  Timestamp t = 0;
  for (auto _ : state) {
    PoseWithCovariance attitude;
    attitude.pose = Transform::identity("lvlh", "servicer", t);
    attitude.pose.rotation =
        Eigen::Quaterniond((Eigen::Matrix3d() << 0, 0, 1, 1, 0, 0, 0, 1, 0).finished());
    attitude.covariance.block<3, 3>(3, 3) = 1e-9 * Eigen::Matrix3d::Identity();
    f.in.attitude.set(attitude);
    ImageRegion m = ImageRegion::box(511.5, 511.5, 1, 1);
    m.stamp = t;
    m.frame_id = "camera_far_optical";
    m.covariance = 0.01 * Eigen::Matrix2d::Identity();
    m.source = t == 0 ? "user" : "match";
    f.in.measurement.set(m);
    if (const Status s = f.process(); !s) state.SkipWithError(s.toString().c_str());
    t += 1'000'000;
  }
}
BENCHMARK(BM_BearingFilterStep)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace cdff

CDFF_BENCHMARK_MAIN();
