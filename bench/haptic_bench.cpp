// Haptic scanning's octree (OctomapUpdate/OcTree) against OctoMap's own insertion: the same contact
// points (a 10 cm x 10 cm patch of a face touched on a 1 mm grid, in the target frame) inserted
// by the DFN one contact sample per call (as the DFPC calls it at 1 kHz) and as one cloud, by
// OcTree::updateNode per point (the hits alone, what the DFI does in the tree) and by
// OcTree::insertPointCloud from the sensor's position (OctoMap's scan insertion: the hits and the
// free space along each ray, which a contact does not observe).
#include <benchmark/benchmark.h>

#include <octomap/OcTree.h>

#include <vector>

#include "OctomapUpdate.gen.hpp"
#include "bench_support.hpp"

namespace {

using namespace cdff;

constexpr double kResolution = 0.002;  // the DFI's default

/// The contact points: a grid of `side` x `side` points 1 mm apart on the face x = 0.3 m.
std::vector<Eigen::Vector3d> patch(int side) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j) points.emplace_back(0.3, 0.001 * i, 0.001 * j);
  return points;
}

/// The DFN with its poses set: the sensor at the target's origin plus 0.5 m along x, both in a
/// base whose origin is the target's (the poses' composition is part of the measured cost).
std::unique_ptr<dfn::OctomapUpdate> configured(const std::string& yaml) {
  auto dfn = bench::createConfigured<dfn::OctomapUpdate>("OctomapUpdate", "OcTree", yaml);
  if (!dfn) return nullptr;
  PoseWithCovariance target;
  target.pose = Transform::identity("base_link", "target", 0);
  dfn->in.target_pose.set(target);
  return dfn;
}

PointCloud contactCloud(const std::vector<Eigen::Vector3d>& points, Timestamp stamp) {
  std::vector<Point4f> xyz, normals(points.size(), Point4f(1, 0, 0));
  for (const Eigen::Vector3d& p : points)
    xyz.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                     static_cast<float>(p.z()));
  PointCloud c;
  c.stamp = stamp;
  c.frame_id = "ft_sensor";
  c.points = Buffer<Point4f>::fromVector(std::move(xyz));
  c.normals = Buffer<Point4f>::fromVector(std::move(normals));
  c.intensity = Buffer<float>::fromVector(std::vector<float>(points.size(), 10.0f));
  return c;
}

/// One contact sample per process() as at 1 kHz: contacts at the points of a 10 x 10 patch
/// (1 mm apart), each held for 100 samples (0.1 s; the map output every 0.1 s and on each new
/// voxel, the DFI's default).
void BM_OctomapUpdatePerSample(benchmark::State& state) {
  const std::vector<Eigen::Vector3d> points = patch(10);
  const int hold = static_cast<int>(state.range(0));
  std::vector<PointCloud> samples;
  for (const Eigen::Vector3d& p : points)
    for (int k = 0; k < hold; ++k)
      samples.push_back(contactCloud({p}, static_cast<Timestamp>(1000 * (samples.size() + 1))));
  for (auto _ : state) {
    state.PauseTiming();
    auto dfn = configured("{}");
    if (!dfn) return state.SkipWithError("OctomapUpdate/OcTree not configured");
    state.ResumeTiming();
    PoseWithCovariance target;
    for (const PointCloud& sample : samples) {
      dfn->in.contact.set(sample);
      dfn->in.sensor_pose.set(Transform::identity("base_link", "ft_sensor", sample.stamp));
      // The target's pose as a 10 Hz estimator gives it (the DFN refuses one older than 0.1 s).
      if (sample.stamp % 100000 == 1000) {
        target.pose = Transform::identity("base_link", "target", sample.stamp);
        dfn->in.target_pose.set(target);
      }
      if (!dfn->process().isOk()) return state.SkipWithError("process failed");
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(samples.size()));
}
BENCHMARK(BM_OctomapUpdatePerSample)->Arg(100)->Unit(benchmark::kMillisecond);

/// The patch as one cloud through the DFN (one map output).
void BM_OctomapUpdateCloud(benchmark::State& state) {
  const std::vector<Eigen::Vector3d> points = patch(static_cast<int>(state.range(0)));
  const PointCloud cloud = contactCloud(points, 1000);
  for (auto _ : state) {
    state.PauseTiming();
    auto dfn = configured("{}");
    if (!dfn) return state.SkipWithError("OctomapUpdate/OcTree not configured");
    state.ResumeTiming();
    dfn->in.contact.set(cloud);
    dfn->in.sensor_pose.set(Transform::identity("base_link", "ft_sensor", 1000));
    if (!dfn->process().isOk()) return state.SkipWithError("process failed");
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.size()));
}
BENCHMARK(BM_OctomapUpdateCloud)->Arg(100)->Unit(benchmark::kMillisecond);

/// OctoMap alone: a hit per point with updateNode.
void BM_OctoMapUpdateNode(benchmark::State& state) {
  const std::vector<Eigen::Vector3d> points = patch(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    octomap::OcTree tree(kResolution);
    for (const Eigen::Vector3d& p : points) tree.updateNode(p.x(), p.y(), p.z(), true);
    benchmark::DoNotOptimize(tree.size());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.size()));
}
BENCHMARK(BM_OctoMapUpdateNode)->Arg(100)->Unit(benchmark::kMillisecond);

/// OctoMap's scan insertion of the same points from the sensor 0.5 m in front of the face.
void BM_OctoMapInsertPointCloud(benchmark::State& state) {
  const std::vector<Eigen::Vector3d> points = patch(static_cast<int>(state.range(0)));
  octomap::Pointcloud scan;
  for (const Eigen::Vector3d& p : points)
    scan.push_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
  for (auto _ : state) {
    octomap::OcTree tree(kResolution);
    tree.insertPointCloud(scan, octomap::point3d(0.8f, 0.05f, 0.05f));
    benchmark::DoNotOptimize(tree.size());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.size()));
}
BENCHMARK(BM_OctoMapInsertPointCloud)->Arg(100)->Unit(benchmark::kMillisecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
