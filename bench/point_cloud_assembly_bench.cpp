// PointCloudAssembly, VoxelFusion against Pcl (PCL's VoxelGrid + StatisticalOutlierRemoval) on
// the same frames: a fly-around of a sphere of radius 0.5 m (16 views on a ring 2 m from its
// centre, 20 deg above its equator), each view 50 000 points of the surface it sees with the
// servicer's stereo depth noise (sigma = 0.00092 r^2: 2.3 mm at 1.6 m) and 0.5 % spurious
// returns. One iteration fuses the 16 frames from an empty map, with an output after every frame
// (as the reconstruction DFPC calls it); the time per frame is the iteration's over 16. Each DFI
// with its statistical outlier removal (k = 8, 2 sigma) and without. Counters: the final
// output's points, its distance to the true sphere (p95, mm) and its completeness (the fraction
// of the samples of the sphere that at least 2 views saw, min_observations, within 1 cm of an
// output point; 4000 samples of the whole sphere).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "PointCloudAssembly.gen.hpp"
#include "bench_support.hpp"
#include "cdff/types/kd_tree.hpp"

namespace {

using namespace cdff;

constexpr double kRadius = 0.5;
constexpr int kViews = 16;
constexpr int kPointsPerView = 50'000;
constexpr double kQuadratic = 0.00092;  // 1/m, the DFN's default (the servicer's stereo pair)
constexpr double kDeg = M_PI / 180;

Eigen::Isometry3d modelTSensor(int k) {
  const Eigen::Vector3d eye =
      2.0 * (Eigen::AngleAxisd(2 * M_PI * k / kViews, Eigen::Vector3d::UnitZ()) *
             Eigen::AngleAxisd(70 * kDeg, Eigen::Vector3d::UnitX()) * Eigen::Vector3d::UnitZ());
  const Eigen::Vector3d z = -eye.normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() << x, z.cross(x), z;
  pose.translation() = eye;
  return pose;
}

Eigen::Vector3d sphereDirection(std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
}

struct Frames {
  std::vector<PointCloud> clouds;
  std::vector<PoseWithCovariance> poses;
};

const Frames& frames() {
  static const Frames f = [] {
    Frames out;
    std::mt19937 rng(5);
    std::normal_distribution<double> unit(0, 1);
    std::uniform_real_distribution<double> off(0.05, 0.3);
    for (int k = 0; k < kViews; ++k) {
      const Eigen::Isometry3d model_T_s = modelTSensor(k);
      const Eigen::Isometry3d s_T_model = model_T_s.inverse();
      const Eigen::Vector3d eye = model_T_s.translation();
      std::vector<Eigen::Vector3f> points;
      while (static_cast<int>(points.size()) < kPointsPerView) {
        const Eigen::Vector3d n = sphereDirection(rng);
        if (points.size() % 200 == 0) {  // a spurious return
          points.push_back((s_T_model * ((kRadius + off(rng)) * n)).cast<float>());
          continue;
        }
        const Eigen::Vector3d p = kRadius * n;
        if (n.dot(eye - p) <= 0) continue;
        const double r = (p - eye).norm();
        points.push_back(
            (s_T_model * (p + kQuadratic * r * r * unit(rng) * (p - eye) / r)).cast<float>());
      }
      out.clouds.push_back(PointCloud::fromXyz(points, "camera", fromSeconds(0.5 * k)));
      PoseWithCovariance pose;
      pose.pose = Transform::fromIsometry(model_T_s, "target", "camera", fromSeconds(0.5 * k));
      out.poses.push_back(pose);
    }
    return out;
  }();
  return f;
}

void reportAccuracy(benchmark::State& state, const PointCloud& model) {
  std::vector<double> d;
  for (const Point4f& p : model.points)
    d.push_back(std::abs(p.vec().cast<double>().norm() - kRadius));
  std::sort(d.begin(), d.end());
  KdTree3f tree(model.points.span());
  std::mt19937 rng(11);
  std::vector<KdTree3f::Neighbour> nearest;
  int near = 0;
  constexpr int kSamples = 4000;
  int seen = 0;
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector3d n = sphereDirection(rng);
    int views = 0;
    for (int k = 0; k < kViews; ++k)
      views += n.dot(modelTSensor(k).translation() - kRadius * n) > 0;
    if (views < 2) continue;
    ++seen;
    tree.kNearest((kRadius * n).cast<float>(), 1, nearest);
    near += !nearest.empty() && nearest[0].squared_distance <= 1e-4f;
  }
  state.counters["points"] = static_cast<double>(model.size());
  state.counters["p95_mm"] = d.empty() ? 0 : 1000 * d[d.size() * 95 / 100];
  state.counters["completeness"] = static_cast<double>(near) / std::max(1, seen);
}

/// The DFN's defaults (the servicer's stereo noise model) spelled out, with and without the
/// statistical outlier removal.
constexpr const char* kYaml =
    "{voxel_size: 0.01, range_sigma_constant: 0, range_sigma_quadratic: 0.00092, "
    "min_observations: 2, outlier_neighbours: 8, outlier_std_ratio: 2.0}";
constexpr const char* kYamlNoOutlierRemoval =
    "{voxel_size: 0.01, range_sigma_constant: 0, range_sigma_quadratic: 0.00092, "
    "min_observations: 2, outlier_neighbours: 0}";

void BM_Assembly(benchmark::State& state, const char* dfi, const char* yaml) {
  const Frames& f = frames();
  auto dfn = bench::createConfigured<dfn::PointCloudAssembly>("PointCloudAssembly", dfi, yaml);
  if (!dfn) return state.SkipWithError("configure failed");
  for (auto _ : state) {
    for (int k = 0; k < kViews; ++k) {
      dfn->in.cloud.set(f.clouds[k]);
      dfn->in.pose.set(f.poses[k]);
      dfn->in.reset.set(k == 0);
      if (!dfn->process()) return state.SkipWithError(dfn->diagnostics().last_error.c_str());
    }
  }
  state.SetItemsProcessed(state.iterations() * kViews);
  state.counters["ms_per_frame"] =
      benchmark::Counter(static_cast<double>(state.iterations() * kViews) * 1e-3,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  reportAccuracy(state, *dfn->out.assembled);
}
BENCHMARK_CAPTURE(BM_Assembly, VoxelFusion, "VoxelFusion", kYaml)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Assembly, Pcl, "Pcl", kYaml)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Assembly, VoxelFusion_NoOutlierRemoval, "VoxelFusion", kYamlNoOutlierRemoval)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Assembly, Pcl_NoOutlierRemoval, "Pcl", kYamlNoOutlierRemoval)
    ->Unit(benchmark::kMillisecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
