// Haptic scanning's octree (OctomapUpdate/OcTree) against OctoMap's own insertion: the same contact
// points (a 10 cm x 10 cm patch of a face touched on a 1 mm grid, in the target frame) inserted
// by the DFN one contact sample per call (as the DFPC calls it at 1 kHz) and as one cloud, by
// OcTree::updateNode per point (the hits alone, what the DFI does in the tree) and by
// OcTree::insertPointCloud from the sensor's position (OctoMap's scan insertion: the hits and the
// free space along each ray, which a contact does not observe). Then the mesher
// (ForceMeshGeneration/TangentDelaunay) on maps of growing size, and the whole DFPC
// (dfpcs/haptic_scanning.yaml) on the simulator's haptic_scanning run, per force/torque sample.
// The DFPC's two per-sample DFNs on their own: ForwardKinematics/Kdl per joint state and
// ContactDetection (both DFIs) per wrench sample, free and pressed.
#include <benchmark/benchmark.h>

#include <octomap/OcTree.h>

#include <filesystem>
#include <random>
#include <vector>

#include "ContactDetection.gen.hpp"
#include "ForceMeshGeneration.gen.hpp"
#include "ForwardKinematics.gen.hpp"
#include "OctomapUpdate.gen.hpp"
#include "bench_support.hpp"
#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/graph.hpp"
#include "cdff/egse/simulator.hpp"

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

/// The mesher on a map of n contacts spread at random over a 10 cm disc of a face (the DFPC's
/// map after n voxels), 0.1 mm off it, normals within 0.8 deg.
void BM_ForceMeshGeneration(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<Point4f> points, normals;
  while (points.size() < n) {
    const float y = 0.05f * u(rng), z = 0.05f * u(rng);
    if (y * y + z * z > 0.05f * 0.05f) continue;
    points.emplace_back(0.3f + 1e-4f * u(rng), y, z);
    const Eigen::Vector3f normal = Eigen::Vector3f(1, 0.01f * u(rng), 0.01f * u(rng)).normalized();
    normals.emplace_back(normal.x(), normal.y(), normal.z());
  }
  PointCloud map;
  map.stamp = 1000;
  map.frame_id = "target";
  map.points = Buffer<Point4f>::fromVector(std::move(points));
  map.normals = Buffer<Point4f>::fromVector(std::move(normals));
  map.intensity = Buffer<float>::fromVector(std::vector<float>(n, 10.0f));
  // Edges up to three times the spacing of n contacts over the disc's area.
  const double spacing = std::sqrt(M_PI * 0.05 * 0.05 / static_cast<double>(n));
  auto dfn = bench::createConfigured<dfn::ForceMeshGeneration>(
      "ForceMeshGeneration", "TangentDelaunay",
      fmt::format("{{max_edge_length: {}}}", 3 * spacing));
  if (!dfn) return state.SkipWithError("ForceMeshGeneration/TangentDelaunay not configured");
  for (auto _ : state) {
    dfn->in.contacts.set(map);
    if (!dfn->process().isOk()) return state.SkipWithError("process failed");
  }
  state.counters["triangles"] = *dfn->out.triangles;
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(n));
}
BENCHMARK(BM_ForceMeshGeneration)->Arg(30)->Arg(300)->Arg(3000)->Unit(benchmark::kMillisecond);

/// ForwardKinematics/Kdl on the servicer arm (data/arms/servicer_arm.urdf), to the tool's link
/// or the force/torque sensor's (the DFPC's), per joint state: 1000 postures drawn uniformly
/// within the joints' limits, cycled, each with the next stamp.
void BM_ForwardKinematicsKdl(benchmark::State& state, const std::string& link) {
  auto dfn = bench::createConfigured<dfn::ForwardKinematics>(
      "ForwardKinematics", "Kdl",
      fmt::format("{{description: {}/data/arms/servicer_arm.urdf, link: {}}}", CDFF_SOURCE_DIR,
                  link));
  if (!dfn) return state.SkipWithError("ForwardKinematics/Kdl not configured");
  // The joints' limits (rad) in the URDF: roll joints +-170 deg, pitch +-120, wrist roll +-175.
  const double limits[7] = {2.96706, 2.094395, 2.96706, 2.094395, 2.96706, 2.094395, 3.054326};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<JointState> postures(1000);
  for (JointState& s : postures)
    for (int j = 0; j < 7; ++j) {
      s.names.push_back(fmt::format("joint_{}", j + 1));
      s.position.push_back(limits[j] * u(rng));
    }
  Timestamp stamp = 0;
  std::size_t i = 0;
  for (auto _ : state) {
    JointState& s = postures[i++ % postures.size()];
    s.stamp = stamp += 1000;
    dfn->in.joints.set(s);
    if (!dfn->process().isOk()) return state.SkipWithError("process failed");
    benchmark::DoNotOptimize(dfn->out.pose->translation);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_ForwardKinematicsKdl, tool_tip, std::string("tool_tip"))
    ->Name("BM_ForwardKinematics/Kdl/tool_tip");
BENCHMARK_CAPTURE(BM_ForwardKinematicsKdl, ft_sensor, std::string("ft_sensor"))
    ->Name("BM_ForwardKinematics/Kdl/ft_sensor");

/// Wrench samples of the servicer arm's sensor (the simulator's figures: noise 0.02 N and
/// 1 mN m per axis, a turn-on bias of 0.4-0.6 N and 10-20 mN m) with its tool (tip centre
/// 0.12 m along z, radius 10 mm): `pressed` false, the tool free (bias and noise only); true, a
/// 1 s press of an oblique face (normal 20 deg off the tool's axis) rising at 1 N per ms to
/// 10 N, with a Coulomb friction of 0.3 of the push across the normal (so the force is 17 deg
/// off the normal and HysteresisLineOfAction's normal fit runs on every sample).
std::vector<Wrench> wrenchSamples(bool pressed, std::size_t count) {
  const Eigen::Vector3d centre(0, 0, 0.12);
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.2, -1).normalized();
  const Eigen::Vector3d across = n.unitOrthogonal();
  const Eigen::Vector3d at = centre - 0.01 * n;
  const Eigen::Vector3d bias_force(0.4, -0.3, 0.6), bias_torque(0.01, 0.02, -0.015);
  std::mt19937_64 rng(17);
  std::normal_distribution<double> noise;
  std::vector<Wrench> samples(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double push = pressed ? std::min(10.0, static_cast<double>(i + 1)) : 0.0;
    const Eigen::Vector3d force = push * n + 0.3 * push * across;
    Wrench& w = samples[i];
    w.frame_id = "ft_sensor";
    w.force = force + bias_force + 0.02 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    w.torque =
        at.cross(force) + bias_torque + 0.001 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  return samples;
}

/// ContactDetection per wrench sample, as the DFPC calls it at 1 kHz: the DFI with its defaults
/// (the servicer arm's tool and sensor), after 0.6 s of free samples (HysteresisLineOfAction's
/// initial bias, 0.5 s, not timed); then free samples (the bias tracked) or the press above,
/// cycled (each cycle a new 1 s press from 1 N, no release between). The counters: the fraction
/// of samples in contact, and of all samples those with a contact point and normal out (`given`).
void BM_ContactDetection(benchmark::State& state, const std::string& dfi, bool pressed) {
  auto dfn = bench::createConfigured<dfn::ContactDetection>("ContactDetection", dfi);
  if (!dfn) return state.SkipWithError(("ContactDetection/" + dfi + " not configured").c_str());
  Timestamp stamp = 0;
  for (Wrench w : wrenchSamples(false, 600)) {
    w.stamp = stamp += 1000;
    dfn->in.wrench.set(w);
    if (!dfn->process().isOk()) return state.SkipWithError("process failed");
  }
  std::vector<Wrench> samples = wrenchSamples(pressed, 1000);
  std::size_t i = 0;
  std::int64_t in_contact = 0, given = 0;
  for (auto _ : state) {
    Wrench& w = samples[i++ % samples.size()];
    w.stamp = stamp += 1000;
    dfn->in.wrench.set(w);
    if (!dfn->process().isOk()) return state.SkipWithError("process failed");
    in_contact += *dfn->out.in_contact;
    given += dfn->out.contact.hasValue() && dfn->out.contact->stamp == stamp;
  }
  const double samples_run = static_cast<double>(std::max<std::int64_t>(1, state.iterations()));
  // Every free sample free; the press a contact but for its first newtons (ForceThreshold's
  // 2 N with the bias), over whole presses.
  const bool whole = state.iterations() >= static_cast<std::int64_t>(samples.size());
  if (pressed ? whole && in_contact < 0.99 * samples_run : in_contact > 0)
    return state.SkipWithError(pressed ? "the press is not a contact"
                                       : "a free sample is a contact");
  state.counters["in_contact"] = static_cast<double>(in_contact) / samples_run;
  state.counters["given"] = static_cast<double>(given) / samples_run;
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_ContactDetection, hysteresis_free, std::string("HysteresisLineOfAction"),
                  false)
    ->Name("BM_ContactDetection/HysteresisLineOfAction/free");
BENCHMARK_CAPTURE(BM_ContactDetection, hysteresis_pressed, std::string("HysteresisLineOfAction"),
                  true)
    ->Name("BM_ContactDetection/HysteresisLineOfAction/pressed");
BENCHMARK_CAPTURE(BM_ContactDetection, threshold_free, std::string("ForceThreshold"), false)
    ->Name("BM_ContactDetection/ForceThreshold/free");
BENCHMARK_CAPTURE(BM_ContactDetection, threshold_pressed, std::string("ForceThreshold"), true)
    ->Name("BM_ContactDetection/ForceThreshold/pressed");

/// The DFPC's inputs of a simulated haptic_scanning run (its first 30 s, seed 7), in log order.
struct ScanRun {
  std::vector<std::pair<std::string, dfpc::Message>> messages;  // DFPC input, message
  std::int64_t samples = 0;                                     // force/torque samples
  std::string error;                                            // why there are none
};

const ScanRun& scanRun() {
  static const ScanRun run = [] {
    ScanRun r;
    auto path = egse::resolveScenario("haptic_scanning");
    auto scenario = path ? egse::loadScenario(*path) : Result<egse::Scenario>(path.status());
    if (!scenario) {
      r.error = scenario.status().toString();
      return r;
    }
    auto sim = egse::Simulator::create(*scenario, 7);
    egse::MemorySink sink;
    const Status ran = sim ? (*sim)->run(sink) : sim.status();
    if (!ran) {
      r.error = ran.toString();
      return r;
    }
    for (const egse::SimMessage& m : sink.messages()) {
      if (const auto* j = std::get_if<JointState>(&m.payload))
        r.messages.emplace_back("joints", dfpc::Message::of(m.channel, j->stamp, *j));
      if (const auto* w = std::get_if<Wrench>(&m.payload); w && m.channel == "/chaser/arm/wrench") {
        r.messages.emplace_back("wrench", dfpc::Message::of(m.channel, w->stamp, *w));
        ++r.samples;
      }
      if (const auto* p = std::get_if<PoseWithCovariance>(&m.payload);
          p && m.channel == "/truth/arm/target_pose")
        r.messages.emplace_back("target_pose", dfpc::Message::of(m.channel, p->pose.stamp, *p));
    }
    return r;
  }();
  return run;
}

/// The whole DFPC over the run, as `cdff run` steps it: the time per force/torque sample (each
/// with its joints, and the target pose at 50 Hz), from an empty map to the scan's end.
void BM_HapticScanningDfpc(benchmark::State& state) {
  // The graph names the arm's URDF relative to the repository root.
  std::filesystem::current_path(CDFF_SOURCE_DIR);
  const ScanRun& run = scanRun();
  if (run.samples == 0)
    return state.SkipWithError(("no haptic_scanning run: " + run.error).c_str());
  Result<dfpc::GraphSpec> spec = dfpc::loadGraphFile("dfpcs/haptic_scanning.yaml");
  if (!spec) return state.SkipWithError(spec.status().toString().c_str());
  std::vector<std::size_t> inputs;
  for (auto _ : state) {
    state.PauseTiming();
    auto dfpc = dfpc::Dfpc::create(*spec);
    if (!dfpc || !(*dfpc)->start()) return state.SkipWithError("the DFPC does not start");
    inputs.clear();
    for (const auto& [input, message] : run.messages) inputs.push_back(*(*dfpc)->inputIndex(input));
    state.ResumeTiming();
    for (std::size_t i = 0; i < run.messages.size(); ++i)
      if (!(*dfpc)->deliver(inputs[i], run.messages[i].second))
        return state.SkipWithError("a message does not fit its input");
    (*dfpc)->finish();
    if ((*dfpc)->status().faults > 0) return state.SkipWithError("the DFPC reported faults");
  }
  state.counters["per_sample"] = benchmark::Counter(
      static_cast<double>(run.samples),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_HapticScanningDfpc)->Unit(benchmark::kMillisecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
