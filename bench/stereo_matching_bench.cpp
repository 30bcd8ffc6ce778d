// StereoMatching (Sgbm, Bm) on the simulator's stereo pair (two Prosilica GC1600H, 1624x1234,
// 6 mm lenses, 0.2 m baseline), rectified by StereoRectification, at pyramid levels 0-2:
// - speed: one pair at close range (target at about 2.9 m), per DFI and level;
// - accuracy: the first pair of close_range_approach (about 2.9 m) and mid_range_approach
//   (about 17 m) against the simulator's truth depth of the left camera (`truth.camera_depth`):
//   the fraction of the target's pixels with a depth, the fraction of the other pixels given a
//   depth under 100 m (where nothing is), and the depth error's median and p95 as a
//   percentage of the range, for both DFIs in the same run.
// The simulated cameras are parallel with the same intrinsics, so the rectification does not
// rotate them (checked: a rotated rectification is refused) and a rectified pixel's 3D point is
// projected back through the original left camera (its lens distortion) onto the truth depth.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "StereoMatching.gen.hpp"
#include "StereoRectification.gen.hpp"
#include "bench_support.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/egse/simulator.hpp"
#include "cdff/egse/sink.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff {
namespace {

using bench::createConfigured;

struct SimulatedPair {
  StereoImagePair raw;        // as the cameras publish it
  StereoImagePair rectified;  // StereoRectification's output
  DepthMap truth;             // of the left camera, in its (distorted) pixels
};

Result<SimulatedPair> simulatePair(const std::string& scenario_name) {
  Result<std::filesystem::path> file = egse::resolveScenario(scenario_name);
  if (!file) return file.status();
  std::ifstream in(*file);
  std::stringstream text;
  text << in.rdbuf();
  Result<egse::Scenario> scenario = egse::parseScenario(
      text.str(), file->string(),
      {"sensors.lidar.enabled=false", "sensors.tof.enabled=false", "sensors.imu.enabled=false",
       "sensors.ahrs.enabled=false", "truth.camera_depth=true"},
      file->parent_path());
  if (!scenario) return scenario.status();
  Result<std::unique_ptr<egse::Simulator>> sim = egse::Simulator::create(*scenario, 1, 0.05);
  if (!sim) return sim.status();
  egse::MemorySink sink;
  CDFF_RETURN_IF_ERROR((*sim)->run(sink));
  const std::vector<Image> left = sink.on<Image>("/chaser/camera/left/image");
  const std::vector<Image> right = sink.on<Image>("/chaser/camera/right/image");
  const std::vector<DepthMap> truth = sink.on<DepthMap>("/truth/camera_left/depth");
  std::map<std::string, Transform> mounts;
  for (const Transform& t : sink.on<Transform>("/chaser/tf/camera_left_optical"))
    mounts["left"] = t;
  for (const Transform& t : sink.on<Transform>("/chaser/tf/camera_right_optical"))
    mounts["right"] = t;
  if (left.empty() || right.empty() || truth.empty() || mounts.size() != 2)
    return notFound("{}: no stereo pair with truth depth in the first 0.05 s", scenario_name);
  SimulatedPair p;
  p.raw.left = left.front();
  p.raw.right = right.front();
  Result<Transform> right_T_left = mounts["right"].inverse().compose(mounts["left"]);
  if (!right_T_left) return right_T_left.status();
  p.raw.right_T_left = *right_T_left;
  p.truth = truth.front();
  auto rectify = createConfigured<dfn::StereoRectification>("StereoRectification", "OpenCV", "{}");
  if (!rectify) return notFound("cannot create StereoRectification/OpenCV");
  rectify->in.stereo.set(p.raw);
  CDFF_RETURN_IF_ERROR(rectify->process());
  p.rectified = *rectify->out.rectified;
  return p;
}

const SimulatedPair* pairOf(const std::string& scenario, benchmark::State& state) {
  static std::map<std::string, SimulatedPair> cache;
  if (auto it = cache.find(scenario); it != cache.end()) return &it->second;
  Result<SimulatedPair> p = simulatePair(scenario);
  if (!p) {
    state.SkipWithError(p.status().toString().c_str());
    return nullptr;
  }
  return &cache.emplace(scenario, std::move(p).value()).first->second;
}

std::string settings(const char* dfi, int level) {
  // CDFF_SGBM_MIN_TEXTURE: Sgbm's min_texture to try (default: the DFI's).
  const char* texture = std::getenv("CDFF_SGBM_MIN_TEXTURE");
  if (texture && std::string(dfi) == "Sgbm")
    return fmt::format("{{pyramid_level: {}, min_texture: {}}}", level, texture);
  return fmt::format("{{pyramid_level: {}}}", level);
}

void BM_StereoMatching_Speed(benchmark::State& state, const char* dfi, int level) {
  const SimulatedPair* p = pairOf("close_range_approach", state);
  if (!p) return;
  auto dfn = createConfigured<dfn::StereoMatching>("StereoMatching", dfi, settings(dfi, level));
  if (!dfn) return state.SkipWithError("cannot create or configure the DFI");
  dfn->in.rectified.set(p->rectified);
  for (auto _ : state) {
    const Status s = dfn->process();
    if (!s) return state.SkipWithError(s.toString().c_str());
    benchmark::DoNotOptimize(dfn->out.depth.get());
  }
  state.counters["valid_fraction"] = *dfn->out.valid_fraction;
  state.counters["width_px"] = dfn->out.depth->image.width;
}

// The raw OpenCV matchers on the same half-resolution pair with the DFIs' level-1 settings (the
// search for 1.5 m, OpenCV's recommended SGBM penalties): the difference is the DFN's own cost
// (the pyramid, the checks and the depth conversion).
void BM_OpenCV_Level1(benchmark::State& state, bool sgbm) {
  const SimulatedPair* p = pairOf("close_range_approach", state);
  if (!p) return;
  cv::Mat left, right, disparity;
  cv::pyrDown(toMat(p->rectified.left), left);
  cv::pyrDown(toMat(p->rectified.right), right);
  const double f_b = p->rectified.left.camera->fx / 2 * -p->rectified.right_T_left.translation.x();
  const int num = (static_cast<int>(std::ceil(f_b / 1.5)) + 1) / 16 * 16 + 16;
  cv::Ptr<cv::StereoMatcher> matcher;
  if (sgbm)
    matcher = cv::StereoSGBM::create(0, num, 5, 8 * 25, 32 * 25, 1, 63, 10, 100, 2);
  else {
    cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(num, 15);
    bm->setUniquenessRatio(10);
    bm->setSpeckleWindowSize(100);
    bm->setSpeckleRange(2);
    bm->setDisp12MaxDiff(1);
    bm->setPreFilterCap(31);
    matcher = bm;
  }
  for (auto _ : state) {
    matcher->compute(left, right, disparity);
    benchmark::DoNotOptimize(disparity.data);
  }
}
BENCHMARK_CAPTURE(BM_OpenCV_Level1, StereoSGBM, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_OpenCV_Level1, StereoBM, false)->Unit(benchmark::kMillisecond);

// The depth of each target pixel of the rectified left image against the truth.
void BM_StereoMatching_Accuracy(benchmark::State& state, const char* scenario, const char* dfi,
                                int level) {
  const SimulatedPair* p = pairOf(scenario, state);
  if (!p) return;
  auto dfn = createConfigured<dfn::StereoMatching>("StereoMatching", dfi, settings(dfi, level));
  if (!dfn) return state.SkipWithError("cannot create or configure the DFI");
  dfn->in.rectified.set(p->rectified);
  for (auto _ : state) {
    const Status s = dfn->process();
    if (!s) return state.SkipWithError(s.toString().c_str());
  }
  const Image& depth = dfn->out.depth->image;
  const CameraModel& rect = *depth.camera;
  const CameraModel& original = *p->raw.left.camera;
  const Image& truth = p->truth.image;
  // Each rectified pixel's ray (the rectification does not rotate these cameras) projected
  // through the original left camera, lens included, onto the truth depth (> 0 on the target).
  std::vector<cv::Point3d> rays;
  rays.reserve(static_cast<std::size_t>(depth.width) * depth.height);
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x)
      rays.emplace_back((x - rect.cx) / rect.fx, (y - rect.cy) / rect.fy, 1.0);
  std::vector<cv::Point2d> pixels;
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  cv::projectPoints(rays, zero, zero, cameraMatrix(original), distortionCoefficients(original),
                    pixels);
  std::vector<double> errors_pct;
  std::size_t target = 0, background = 0, background_with_depth = 0;
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x) {
      const cv::Point2d& q = pixels[static_cast<std::size_t>(y) * depth.width + x];
      const int u = static_cast<int>(std::lround(q.x)), v = static_cast<int>(std::lround(q.y));
      if (u < 0 || v < 0 || u >= truth.width || v >= truth.height) continue;
      const double z_true = truth.at<float>(u, v);
      if (!(z_true > 0) || !std::isfinite(z_true)) {
        ++background;
        background_with_depth += depth.at<float>(x, y) < 100.0f;  // nothing is there
        continue;
      }
      ++target;
      const float z = depth.at<float>(x, y);
      if (!std::isnan(z)) errors_pct.push_back(100.0 * std::abs(z - z_true) / z_true);
    }
  if (target == 0) return state.SkipWithError("no target pixel in the truth depth");
  std::sort(errors_pct.begin(), errors_pct.end());
  auto quantile = [&](double q) {
    return errors_pct.empty()
               ? NAN
               : errors_pct[std::min(errors_pct.size() - 1,
                                     static_cast<std::size_t>(q * errors_pct.size()))];
  };
  state.counters["target_px"] = static_cast<double>(target);
  state.counters["target_with_depth"] = static_cast<double>(errors_pct.size()) / target;
  state.counters["background_depth_under_100m"] =
      static_cast<double>(background_with_depth) / std::max<std::size_t>(background, 1);
  state.counters["depth_error_median_pct"] = quantile(0.5);
  state.counters["depth_error_p95_pct"] = quantile(0.95);
  state.counters["within_1pct"] =
      static_cast<double>(std::upper_bound(errors_pct.begin(), errors_pct.end(), 1.0) -
                          errors_pct.begin()) /
      target;
}

void registerAll() {
  for (const char* dfi : {"Sgbm", "Bm"})
    for (int level : {0, 1, 2}) {
      benchmark::RegisterBenchmark(
          fmt::format("BM_StereoMatching_Speed/{}/level{}", dfi, level).c_str(),
          BM_StereoMatching_Speed, dfi, level)
          ->Unit(benchmark::kMillisecond);
      for (const char* scenario : {"close_range_approach", "mid_range_approach"})
        benchmark::RegisterBenchmark(
            fmt::format("BM_StereoMatching_Accuracy/{}/{}/level{}", scenario, dfi, level).c_str(),
            BM_StereoMatching_Accuracy, scenario, dfi, level)
            ->Unit(benchmark::kMillisecond)
            ->Iterations(1);
    }
}

const bool registered = (registerAll(), true);

}  // namespace
}  // namespace cdff
CDFF_BENCHMARK_MAIN();
