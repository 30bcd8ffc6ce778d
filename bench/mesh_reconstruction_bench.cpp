// MeshReconstruction's two DFIs side by side on the same fused-model-sized clouds: the
// simulator's procedural target satellite (bus, two solar wings, adapter ring, antenna, thrusters)
// sampled uniformly over its surface (20 000 and 50 000 points, the true normals or none) with
// Gaussian noise of 2 mm on each axis, as PointCloudAssembly's fused cloud of a fly-around would
// be. The counters give what each mesh is worth: its triangles, the p95 distance of points
// sampled on it to the true surface (accuracy), the fraction of the true surface within 1 cm of it
// (completeness) and fit_fraction (the input points within one point spacing of the mesh). The
// raw PCL calls with the DFIs' settings on the same cloud (its normals given) are measured beside
// them: the difference is what the DFN adds (checks, spacing, trimming, orientation, vertex
// normals, fit_fraction).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <pcl/surface/gp3.h>
#include <pcl/surface/poisson.h>

#include "MeshReconstruction.gen.hpp"
#include "bench_support.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/types/kd_tree.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/pcl.hpp"
#include "cdff/types/point_spacing.hpp"
#include "cdff/types/triangle.hpp"

namespace {

using namespace cdff;
constexpr double kSigma = 0.002;        // m, on each axis
constexpr double kCompleteness = 0.01;  // m

const TriangleMesh& truth() {
  static const TriangleMesh mesh = egse::makeTargetSatellite().value().mesh;
  return mesh;
}

PointCloud cloud(std::size_t points, bool normals) {
  PointCloud c = sampleSurface(truth(), points, 21, SampleNormals::kFace).value();
  std::mt19937 rng(21);
  std::normal_distribution<float> noise(0.0f, static_cast<float>(kSigma));
  std::vector<Point4f> noisy(c.points.begin(), c.points.end());
  for (Point4f& p : noisy) {
    p.x += noise(rng);
    p.y += noise(rng);
    p.z += noise(rng);
  }
  c.points = Buffer<Point4f>::fromVector(std::move(noisy));
  if (!normals) c.normals = {};
  c.frame_id = "target";
  return c;
}

/// The distance from p to the nearest of `triangles` of `mesh` (brute force: the truth has a
/// few thousand).
double distanceTo(const TriangleMesh& mesh, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : mesh.triangles)
    best = std::min(best, (closestPointOnTriangle(p, mesh.vertices[t[0]].cast<double>(),
                                                  mesh.vertices[t[1]].cast<double>(),
                                                  mesh.vertices[t[2]].cast<double>()) -
                           p)
                              .norm());
  return best;
}

void addQuality(benchmark::State& state, const TriangleMesh& mesh) {
  constexpr std::size_t kSamples = 2000;
  const PointCloud on_mesh = sampleSurface(mesh, kSamples, 5).value();
  std::vector<double> d;
  for (const Point4f& p : on_mesh.points) d.push_back(distanceTo(truth(), p.vec().cast<double>()));
  auto p95 = d.begin() + static_cast<std::ptrdiff_t>(0.95 * (d.size() - 1));
  std::nth_element(d.begin(), p95, d.end());
  state.counters["p95_mm"] = *p95 * 1e3;
  // Completeness: true-surface samples near a dense sampling of the mesh (1 mm apart on
  // average, so the distance is overstated by at most about that).
  const auto dense = static_cast<std::size_t>(mesh.surfaceArea() / (0.001 * 0.001));
  const PointCloud mesh_dense = sampleSurface(mesh, dense, 6).value();
  const KdTree3f tree(mesh_dense.points.span());
  const PointCloud on_truth = sampleSurface(truth(), kSamples, 7).value();
  std::size_t near = 0;
  KdTree3f::Neighbour found;
  for (const Point4f& p : on_truth.points)
    near += tree.nearest(p.vec(), static_cast<float>(kCompleteness * kCompleteness), found);
  state.counters["completeness"] = static_cast<double>(near) / kSamples;
}

void BM_MeshReconstruction(benchmark::State& state, const char* dfi, bool normals) {
  const PointCloud input = cloud(static_cast<std::size_t>(state.range(0)), normals);
  auto dfn = bench::createConfigured<dfn::MeshReconstruction>("MeshReconstruction", dfi);
  if (!dfn) return state.SkipWithError("MeshReconstruction could not be configured");
  dfn->in.cloud.set(input);
  for (auto _ : state) {
    const Status s = dfn->process();
    if (!s) return state.SkipWithError(s.toString().c_str());
  }
  state.counters["triangles"] = *dfn->out.triangles;
  state.counters["spacing_mm"] = *dfn->out.point_spacing * 1e3;
  state.counters["fit_fraction"] = *dfn->out.fit_fraction;
  addQuality(state, *dfn->out.mesh);
}

/// PCL's Poisson alone, with the DFI's settings for this cloud (depth 9: 1.1 x extent / 2^9 at
/// most the spacing).
void BM_PclPoisson(benchmark::State& state) {
  const PointCloud input = cloud(static_cast<std::size_t>(state.range(0)), true);
  const double spacing = pointSpacing(input);
  Eigen::Array3f lo = Eigen::Array3f::Constant(1e30f), hi = -lo;
  for (const Point4f& p : input.points) {
    lo = lo.min(p.vec().array());
    hi = hi.max(p.vec().array());
  }
  const int depth = static_cast<int>(std::ceil(std::log2(1.1 * (hi - lo).maxCoeff() / spacing)));
  const auto pcl_cloud = toPclWithNormals(input).value();
  std::size_t triangles = 0;
  for (auto _ : state) {
    pcl::Poisson<pcl::PointNormal> poisson;
    poisson.setInputCloud(pcl_cloud);
    poisson.setDepth(depth);
    poisson.setMinDepth(5);
    poisson.setSamplesPerNode(2.0f);
    poisson.setPointWeight(4.0f);
    pcl::PointCloud<pcl::PointNormal> vertices;
    std::vector<pcl::Vertices> polygons;
    poisson.reconstruct(vertices, polygons);
    triangles = polygons.size();
  }
  state.counters["depth"] = depth;
  state.counters["triangles_untrimmed"] = static_cast<double>(triangles);
}

/// PCL's greedy projection alone, with the DFI's default settings for this cloud.
void BM_PclGreedyProjection(benchmark::State& state) {
  const PointCloud input = cloud(static_cast<std::size_t>(state.range(0)), true);
  const double spacing = pointSpacing(input);
  const auto pcl_cloud = toPclWithNormals(input).value();
  std::size_t triangles = 0;
  for (auto _ : state) {
    pcl::GreedyProjectionTriangulation<pcl::PointNormal> gp3;
    gp3.setInputCloud(pcl_cloud);
    gp3.setSearchRadius(3 * spacing);
    gp3.setMu(4);
    gp3.setMaximumNearestNeighbors(100);
    gp3.setMaximumSurfaceAngle(M_PI / 4);
    gp3.setMinimumAngle(M_PI / 18);
    gp3.setMaximumAngle(2 * M_PI / 3);
    gp3.setNormalConsistency(true);
    gp3.setConsistentVertexOrdering(true);
    std::vector<pcl::Vertices> polygons;
    gp3.reconstruct(polygons);
    triangles = polygons.size();
  }
  state.counters["triangles"] = static_cast<double>(triangles);
}

BENCHMARK(BM_PclPoisson)->Arg(50000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PclGreedyProjection)->Arg(50000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_MeshReconstruction, Poisson, "Poisson", true)
    ->Arg(20000)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_MeshReconstruction, GreedyProjection, "GreedyProjection", true)
    ->Arg(20000)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_MeshReconstruction, PoissonEstimatedNormals, "Poisson", false)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_MeshReconstruction, GreedyProjectionEstimatedNormals, "GreedyProjection",
                  false)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
