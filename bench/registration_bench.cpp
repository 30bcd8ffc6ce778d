// LIDAR tracking DFNs on a full VLP-16-like scan (16 rings x 1800 azimuths, ~29 000 points,
// 3 cm range noise) of the satellite-like test target inside a test-bench room, at close
// (2.5 m) and mid (10 m) range: PointCloudFiltering (Fast, Pcl), NormalsEstimation (Pca, Pcl),
// Registration3D (FastIcp, PclIcpPointToPlane, each in several configurations) on the same scan /
// guess pairs, with the pose errors each reaches and its iterations as counters, and the whole
// per-scan chain of the LIDAR tracking DFPC (crop + voxel grid, ICP, EKF correction); and
// ScanPosition (VisibleCentroid), the target's position from a sparse scan at 15 and 50 m (per
// scan, and the first call that builds the model's visible-surface statistics).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

#include "EstimationFilter.gen.hpp"
#include "ModelPointCloud.gen.hpp"
#include "NormalsEstimation.gen.hpp"
#include "PointCloudFiltering.gen.hpp"
#include "PointCloudMotionCompensation.gen.hpp"
#include "Registration3D.gen.hpp"
#include "ScanPosition.gen.hpp"
#include "SymmetryCheck.gen.hpp"
#include "bench_support.hpp"
#include "cdff/egse/procedural.hpp"
#include "support/lidar.hpp"

namespace {

using namespace cdff;
constexpr double kDeg = M_PI / 180.0;
constexpr int kPairs = 8;

Eigen::Isometry3d truthAt(double range) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = (Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation() = Eigen::Vector3d(range, 0.1 * range, 0.05 * range);
  return pose;
}

struct Scene {
  Eigen::Isometry3d truth;
  PointCloud scan;                 // the full scan, target and room
  PointCloud filtered;             // cropped around the guess, voxel grid 3 cm
  std::vector<Transform> guesses;  // tracking-sized errors: 5 cm, 2 deg
};

const PointCloud& model() {
  static const PointCloud cloud = [] {
    auto sampler = bench::createConfigured<dfn::ModelPointCloud>("ModelPointCloud", "MeshSampler",
                                                                 "{point_spacing: 0.01}");
    sampler->in.mesh.set(testing::satelliteMesh());
    (void)sampler->process();
    return *sampler->out.model;
  }();
  return cloud;
}

// The filter of the DFPC: a box around the predicted target (its bounds plus 0.3 m), 3 cm voxels.
const char* kFilterYaml =
    "{crop_box: true, crop_min: [-1.3, -3.1, -1.0], crop_max: [1.3, 3.1, 1.3], voxel_size: 0.03}";

const Scene& scene(double range) {
  static std::map<double, Scene> scenes;
  auto it = scenes.find(range);
  if (it != scenes.end()) return it->second;
  Scene s;
  s.truth = truthAt(range);
  testing::ScanOptions options;
  options.room_half_size = 15.0;
  s.scan = testing::simulateScan(testing::satelliteMesh(), s.truth, options, 1);
  for (int k = 0; k < kPairs; ++k)
    s.guesses.push_back(Transform::fromIsometry(testing::perturb(s.truth, 0.05, 2.0 * kDeg, 10 + k),
                                                "lidar", "target"));
  auto filter =
      bench::createConfigured<dfn::PointCloudFiltering>("PointCloudFiltering", "Fast", kFilterYaml);
  filter->in.cloud.set(s.scan);
  filter->in.box_pose.set(s.guesses[0]);
  (void)filter->process();
  s.filtered = *filter->out.filtered;
  return scenes.emplace(range, std::move(s)).first->second;
}

void BM_Filtering(benchmark::State& state, const char* dfi, double range) {
  const Scene& s = scene(range);
  auto filter =
      bench::createConfigured<dfn::PointCloudFiltering>("PointCloudFiltering", dfi, kFilterYaml);
  if (!filter) return state.SkipWithError("configure failed");
  filter->in.box_pose.set(s.guesses[0]);
  for (auto _ : state) {
    filter->in.cloud.set(s.scan);
    if (!filter->process()) return state.SkipWithError("filter failed");
  }
  state.counters["in_points"] = static_cast<double>(s.scan.size());
  state.counters["out_points"] = static_cast<double>(filter->out.filtered->size());
}
BENCHMARK_CAPTURE(BM_Filtering, Fast_close, "Fast", 2.5)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Filtering, Pcl_close, "Pcl", 2.5)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Filtering, Fast_mid, "Fast", 10.0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Filtering, Pcl_mid, "Pcl", 10.0)->Unit(benchmark::kMicrosecond);

// De-skewing the full scan (before the crop, as in the DFPC): each point's time from its
// azimuth over a 100 ms sweep, the target approaching at 0.25 m/s and tumbling at 5 deg/s.
void BM_MotionCompensation(benchmark::State& state, double range) {
  const Scene& s = scene(range);
  auto deskew = bench::createConfigured<dfn::PointCloudMotionCompensation>(
      "PointCloudMotionCompensation", "ConstantTwist");
  if (!deskew) return state.SkipWithError("configure failed");
  PointCloud scan = s.scan;
  std::vector<std::int32_t> offsets;
  for (const Point4f& p : scan.points) {
    const double azimuth = std::atan2(-static_cast<double>(p.y), static_cast<double>(p.x));
    offsets.push_back(
        static_cast<std::int32_t>((azimuth < 0 ? azimuth + 2 * M_PI : azimuth) / (2 * M_PI) * 1e5));
  }
  scan.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(offsets));
  RigidBodyState predicted;
  predicted.pose = Transform::fromIsometry(s.truth, "lidar", "target", scan.stamp);
  predicted.twist.linear = Eigen::Vector3d(-0.25, 0.0, 0.0);
  predicted.twist.angular = Eigen::Vector3d(2.0, -3.0, 3.5) * kDeg;
  predicted.covariance = Matrix12d::Identity() * 1e-4;
  deskew->in.state.set(predicted);
  for (auto _ : state) {
    deskew->in.cloud.set(scan);
    if (!deskew->process()) return state.SkipWithError("motion compensation failed");
  }
  state.counters["in_points"] = static_cast<double>(scan.size());
  state.counters["max_correction_mm"] = 1e3 * *deskew->out.max_correction;
}
BENCHMARK_CAPTURE(BM_MotionCompensation, close, 2.5)->Unit(benchmark::kMicrosecond);

void BM_Normals(benchmark::State& state, const char* dfi) {
  const Scene& s = scene(2.5);
  auto normals =
      bench::createConfigured<dfn::NormalsEstimation>("NormalsEstimation", dfi, "{neighbours: 12}");
  if (!normals) return state.SkipWithError("configure failed");
  for (auto _ : state) {
    normals->in.cloud.set(s.filtered);
    if (!normals->process()) return state.SkipWithError("normals failed");
  }
  state.counters["points"] = static_cast<double>(s.filtered.size());
}
BENCHMARK_CAPTURE(BM_Normals, Pca, "Pca")->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Normals, Pcl, "Pcl")->Unit(benchmark::kMicrosecond);

// Both ICPs with the same shared parameters (correspondence gate 0.3 m, 50 iterations, the
// same step epsilons), each in its variants on the same filtered scan and guesses:
//   FastIcp     grid: its nearest-point lookup grid in the fine iterations (the DFI's default);
//               grid_refined: then up to 3 exact iterations (as dfpcs/lidar_tracking.yaml);
//               exact: KD-tree only; exact_eps: KD-tree only and the epsilons as its only
//               stopping rule (PCL's), without convergence_sigma; plain: PCL's plain algorithm
//               (KD-tree, fixed gate, no kernel, no rejection, the epsilons only).
//   PclIcpPointToPlane  plain: fixed gate, no rejection; median: PCL's median-distance
//               rejector at 3 robust standard deviations (its adaptive gate, FastIcp's
//               shrinking rule); rejectors: that and back-face rejection (PCL's surface-normal
//               rejector), PCL configured for the job as FastIcp is.
// CDFF_FASTICP_PARAMS (e.g. "min_correspondence_distance: 0.05") adds FastIcp parameters.
const char* kShared =
    "max_correspondence_distance: 0.3, inlier_distance: 0.1, max_iterations: 50, "
    "translation_epsilon: 1.0e-4, rotation_epsilon: 0.005729577951308232";

std::string icpYaml(const std::string& dfi, const std::string& variant) {
  std::string yaml = kShared;
  if (!variant.empty()) yaml += ", " + variant;
  if (dfi == "FastIcp" && std::getenv("CDFF_FASTICP_PARAMS"))
    yaml += std::string(", ") + std::getenv("CDFF_FASTICP_PARAMS");
  return "{" + yaml + "}";
}

// One warmed-up instance per DFI, variant and scene, kept across Google Benchmark's repeated
// runs: the model's search structures are built once, as in a DFPC (BM_FirstRegistration
// measures that).
dfn::Registration3D* warmRegistration(const std::string& dfi, const std::string& variant,
                                      double range) {
  static std::map<std::string, std::unique_ptr<dfn::Registration3D>> cache;
  auto& icp = cache[dfi + "|" + variant + "|" + std::to_string(range)];
  if (!icp) {
    icp =
        bench::createConfigured<dfn::Registration3D>("Registration3D", dfi, icpYaml(dfi, variant));
    if (!icp) return nullptr;
    const Scene& s = scene(range);
    icp->in.model.set(model());
    icp->in.source.set(s.filtered);
    icp->in.initial_guess.set(s.guesses[0]);
    if (!icp->process()) return nullptr;
  }
  return icp.get();
}

// Counters: means over the calls of the pose error against the truth (t_err_mm, r_err_deg),
// the largest (t_max_mm, r_max_deg), iterations per registration, the fraction converged and
// the inlier RMS at the final pose (the shared quality measure of both DFIs).
void BM_Registration(benchmark::State& state, const char* dfi, const char* variant, double range) {
  const Scene& s = scene(range);
  dfn::Registration3D* icp = warmRegistration(dfi, variant, range);
  if (!icp) return state.SkipWithError("configure or warm-up failed");
  double sum_t = 0, sum_r = 0, max_t = 0, max_r = 0, sum_iterations = 0, sum_rms = 0;
  long calls = 0, converged = 0;
  for (auto _ : state) {
    icp->in.source.set(s.filtered);
    icp->in.initial_guess.set(s.guesses[calls % kPairs]);
    if (!icp->process()) return state.SkipWithError("registration failed");
    state.PauseTiming();
    const testing::PoseError e = testing::poseError(icp->out.transform->isometry(), s.truth);
    sum_t += e.translation;
    sum_r += e.rotation;
    max_t = std::max(max_t, e.translation);
    max_r = std::max(max_r, e.rotation);
    sum_iterations += *icp->out.iterations;
    sum_rms += *icp->out.inlier_rms;
    converged += *icp->out.converged ? 1 : 0;
    ++calls;
    state.ResumeTiming();
  }
  state.counters["points"] = static_cast<double>(s.filtered.size());
  state.counters["t_err_mm"] = 1e3 * sum_t / calls;
  state.counters["r_err_deg"] = sum_r / calls / kDeg;
  state.counters["t_max_mm"] = 1e3 * max_t;
  state.counters["r_max_deg"] = max_r / kDeg;
  state.counters["iterations"] = sum_iterations / calls;
  state.counters["converged"] = static_cast<double>(converged) / calls;
  state.counters["inlier_rms_mm"] = 1e3 * sum_rms / calls;
}

const char* kGridRefined = "exact_refinement_iterations: 3";
const char* kExact = "lookup_grid_cell: 0";
const char* kExactEps = "lookup_grid_cell: 0, convergence_sigma: 0";
const char* kPlain =
    "lookup_grid_cell: 0, convergence_sigma: 0, robust_kernel: none, back_face_rejection: false, "
    "min_correspondence_distance: 0.3";
const char* kMedian = "median_rejection_factor: 4.45";
const char* kRejectors = "median_rejection_factor: 4.45, back_face_rejection: true";

#define CDFF_REGISTRATION_CASES(range_name, range)                                                 \
  BENCHMARK_CAPTURE(BM_Registration, FastIcp_grid_##range_name, "FastIcp", "", range)              \
      ->Unit(benchmark::kMicrosecond);                                                             \
  BENCHMARK_CAPTURE(BM_Registration, FastIcp_grid_refined_##range_name, "FastIcp", kGridRefined,   \
                    range)                                                                         \
      ->Unit(benchmark::kMicrosecond);                                                             \
  BENCHMARK_CAPTURE(BM_Registration, FastIcp_exact_##range_name, "FastIcp", kExact, range)         \
      ->Unit(benchmark::kMicrosecond);                                                             \
  BENCHMARK_CAPTURE(BM_Registration, FastIcp_exact_eps_##range_name, "FastIcp", kExactEps, range)  \
      ->Unit(benchmark::kMicrosecond);                                                             \
  BENCHMARK_CAPTURE(BM_Registration, FastIcp_plain_##range_name, "FastIcp", kPlain, range)         \
      ->Unit(benchmark::kMicrosecond);                                                             \
  BENCHMARK_CAPTURE(BM_Registration, Pcl_plain_##range_name, "PclIcpPointToPlane", "", range)      \
      ->Unit(benchmark::kMicrosecond);                                                             \
  BENCHMARK_CAPTURE(BM_Registration, Pcl_median_##range_name, "PclIcpPointToPlane", kMedian,       \
                    range)                                                                         \
      ->Unit(benchmark::kMicrosecond);                                                             \
  BENCHMARK_CAPTURE(BM_Registration, Pcl_rejectors_##range_name, "PclIcpPointToPlane", kRejectors, \
                    range)                                                                         \
      ->Unit(benchmark::kMicrosecond)
CDFF_REGISTRATION_CASES(close, 2.5);
CDFF_REGISTRATION_CASES(mid, 10.0);

// The DFPC's per-scan work: predict to the scan, crop around the prediction and thin, register
// from the prediction, correct with the registered pose.
void BM_TrackingStep(benchmark::State& state, double range) {
  const Scene& s = scene(range);
  auto filter =
      bench::createConfigured<dfn::PointCloudFiltering>("PointCloudFiltering", "Fast", kFilterYaml);
  dfn::Registration3D* icp = warmRegistration("FastIcp", "", range);
  auto ekf = bench::createConfigured<dfn::EstimationFilter>("EstimationFilter", "ExtendedKalman");
  if (!filter || !icp || !ekf) return state.SkipWithError("configure failed");
  RigidBodyState initial;
  initial.pose = s.guesses[0];
  initial.covariance = Matrix12d::Identity() * 1e-3;
  ekf->in.initial_state.set(initial);
  (void)ekf->process();
  PointCloud scan = s.scan;
  double sum_t = 0;
  long calls = 0;
  for (auto _ : state) {
    scan.stamp += 100'000;  // 10 Hz
    ekf->in.time.set(scan.stamp);
    if (!ekf->process()) return state.SkipWithError("prediction failed");
    filter->in.cloud.set(scan);
    filter->in.box_pose.set(ekf->out.pose.shared());
    if (!filter->process()) return state.SkipWithError("filter failed");
    icp->in.source.set(filter->out.filtered.shared());
    icp->in.initial_guess.set(ekf->out.pose.shared());
    if (!icp->process()) return state.SkipWithError("registration failed");
    ekf->in.pose_measurement.set(icp->out.pose.shared());
    if (!ekf->process()) return state.SkipWithError("correction failed");
    sum_t += testing::poseError(ekf->out.pose->isometry(), s.truth).translation;
    ++calls;
  }
  state.counters["scan_points"] = static_cast<double>(s.scan.size());
  state.counters["t_err_mm"] = 1e3 * sum_t / calls;
}
BENCHMARK_CAPTURE(BM_TrackingStep, close, 2.5)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_TrackingStep, mid, 10.0)->Unit(benchmark::kMicrosecond);

// One-off costs: sampling the dense model (1 cm spacing) and building the ICP's model index.
void BM_ModelBuild(benchmark::State& state) {
  auto sampler = bench::createConfigured<dfn::ModelPointCloud>("ModelPointCloud", "MeshSampler",
                                                               "{point_spacing: 0.01}");
  const TriangleMesh mesh = testing::satelliteMesh();
  for (auto _ : state) {
    sampler->in.mesh.set(mesh);
    if (!sampler->process()) return state.SkipWithError("sampling failed");
  }
  state.counters["points"] = static_cast<double>(sampler->out.model->size());
}
BENCHMARK(BM_ModelBuild)->Unit(benchmark::kMillisecond);

void BM_FirstRegistration(benchmark::State& state, const char* dfi) {
  const Scene& s = scene(2.5);
  for (auto _ : state) {
    auto icp =
        bench::createConfigured<dfn::Registration3D>("Registration3D", dfi, icpYaml(dfi, ""));
    icp->in.model.set(model());
    icp->in.source.set(s.filtered);
    icp->in.initial_guess.set(s.guesses[0]);
    if (!icp->process()) return state.SkipWithError("registration failed");
  }
}
BENCHMARK_CAPTURE(BM_FirstRegistration, FastIcp, "FastIcp")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_FirstRegistration, PclIcpPointToPlane, "PclIcpPointToPlane")
    ->Unit(benchmark::kMillisecond);

/// SymmetryCheck/ScanMisfit (the LIDAR tracking DFPC's check of the tracked pose against the
/// model's near-symmetric poses, every 0.5 s) on a VLP-16 scan of a procedural target at 8 m
/// (0: the box satellite, 3 near-symmetries; 1: the hexagonal one, 11), both sampled 1 cm apart
/// as the DFPC samples them: one check (`BM_SymmetryCheck`), and the near-symmetry search when
/// the model arrives (`BM_SymmetryCheckModel`).
struct SymmetryScene {
  PointCloud model, scan;
  Transform tracked;
};

const SymmetryScene& symmetryScene(int target) {
  static std::map<int, SymmetryScene> scenes;
  auto it = scenes.find(target);
  if (it != scenes.end()) return it->second;
  SymmetryScene s;
  const Result<egse::TargetModel> mesh =
      target == 0 ? egse::makeTargetSatellite() : egse::makeHexagonalSatellite();
  auto sampler = bench::createConfigured<dfn::ModelPointCloud>("ModelPointCloud", "MeshSampler",
                                                               "{point_spacing: 0.01}");
  sampler->in.mesh.set(mesh->mesh);
  (void)sampler->process();
  s.model = *sampler->out.model;
  const Eigen::Isometry3d truth = truthAt(8.0);
  s.scan = testing::simulateScan(mesh->mesh, truth, {}, 1);
  s.tracked = Transform::fromIsometry(truth, "lidar", "target", s.scan.stamp);
  return scenes.emplace(target, std::move(s)).first->second;
}

void BM_SymmetryCheck(benchmark::State& state) {
  const SymmetryScene& s = symmetryScene(static_cast<int>(state.range(0)));
  auto check = bench::createConfigured<dfn::SymmetryCheck>("SymmetryCheck", "ScanMisfit",
                                                           "{min_interval: 0}");
  check->in.model.set(s.model);
  check->in.sensor.set(testing::lidarInfo({}));
  if (!check->process()) return state.SkipWithError("model preparation failed");
  for (auto _ : state) {
    check->in.source.set(s.scan);
    check->in.pose.set(s.tracked);
    if (!check->process()) return state.SkipWithError("check failed");
  }
  state.counters["symmetries"] = static_cast<double>(*check->out.symmetries);
  state.counters["scan_points"] = static_cast<double>(s.scan.size());
}
BENCHMARK(BM_SymmetryCheck)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_SymmetryCheckModel(benchmark::State& state) {
  const SymmetryScene& s = symmetryScene(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    auto check = bench::createConfigured<dfn::SymmetryCheck>("SymmetryCheck", "ScanMisfit");
    // A copy: a new buffer, so that the shared model cache does not hand back the last index.
    PointCloud model = s.model;
    model.points = Buffer<Point4f>::fromVector(
        std::vector<Point4f>(s.model.points.begin(), s.model.points.end()));
    check->in.model.set(std::move(model));
    if (!check->process()) return state.SkipWithError("model preparation failed");
  }
  state.counters["model_points"] = static_cast<double>(s.model.size());
}
BENCHMARK(BM_SymmetryCheckModel)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(2);

// The target alone at `range` m (no room: a sparse mid-range scan), with a prediction 0.3 m off.
struct SparseScene {
  PointCloud scan;
  RigidBodyState prediction;
  LidarInfo sensor;
};

const SparseScene& sparseScene(double range) {
  static std::map<double, SparseScene> scenes;
  auto [it, inserted] = scenes.try_emplace(range);
  if (inserted) {
    const Eigen::Isometry3d truth = truthAt(range);
    testing::ScanOptions options;
    it->second.scan = testing::simulateScan(testing::satelliteMesh(), truth, options, 11, "lidar");
    it->second.scan.stamp = 1'000'000;
    it->second.sensor = testing::lidarInfo(options, "lidar");
    RigidBodyState& p = it->second.prediction;
    p.pose = Transform::identity("servicer", "target", 900'000);
    p.pose.translation = truth.translation() + Eigen::Vector3d(0.3, -0.2, 0.1);
    p.covariance = Matrix12d::Identity() * 0.09;
  }
  return it->second;
}

std::unique_ptr<dfn::ScanPosition> scanPosition(const SparseScene& s) {
  auto node = bench::createConfigured<dfn::ScanPosition>("ScanPosition", "VisibleCentroid");
  node->in.sensor_pose.set(Transform::identity("servicer", "lidar"));
  node->in.sensor.set(s.sensor);
  node->in.model.set(model());
  return node;
}

void BM_ScanPosition(benchmark::State& state) {
  const SparseScene& s = sparseScene(static_cast<double>(state.range(0)));
  auto node = scanPosition(s);
  node->in.cloud.set(s.scan);
  node->in.prediction.set(s.prediction);
  if (!node->process() || !node->out.position.hasValue())
    return state.SkipWithError("no position from the scan");
  for (auto _ : state) {
    node->in.cloud.set(s.scan);
    node->in.prediction.set(s.prediction);
    if (!node->process()) return state.SkipWithError("ScanPosition failed");
  }
  state.counters["returns_used"] = static_cast<double>(*node->out.points_used);
}
BENCHMARK(BM_ScanPosition)->Arg(15)->Arg(50)->Unit(benchmark::kMicrosecond);

// The first scan: the model's visible surface at 200 attitudes, built once per 0.01 rad of R / r.
void BM_ScanPositionFirstScan(benchmark::State& state) {
  const SparseScene& s = sparseScene(static_cast<double>(state.range(0)));
  for (auto _ : state) {
    auto node = scanPosition(s);
    node->in.cloud.set(s.scan);
    node->in.prediction.set(s.prediction);
    if (!node->process()) return state.SkipWithError("ScanPosition failed");
  }
  state.counters["model_points"] = static_cast<double>(model().size());
}
BENCHMARK(BM_ScanPositionFirstScan)->Arg(15)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

CDFF_BENCHMARK_MAIN();
