// 3D model detection with no prior (issue 19, seed §4.1.7) on simulated scenes: single LIDAR
// scans and ToF point clouds of the target at an attitude uniform on SO(3) and a range uniform in
// 2-17 m (ToF: 2 m to its maximum range), with at least 80 % of the target within the sensor's
// view (examples/detection/simulated_views.hpp); frame k has the seed 900001 + k (the evaluation
// seeds; CDFF_DRAW_SET=tuning: 1 + k). On the same clouds, in the same run:
//
//   Ours     GlobalRegistration3D/PointPairVoting with its defaults (every size from the model's
//            diameter), then PoseHypothesisSelection/IcpMisfit as below; a ToF scene that the
//            cloud leaves ambiguous (a near-symmetric twin fits it as well) is decided on the
//            depth map by PoseRefinement/DepthIcp (dfpcs/detection_tof.yaml's settings) from the
//            selection's candidates (the verified poses and twins), whose free-space term may
//            tell the twins apart: decided when its best pose is the selection's.
//   Pcl      the seed's pipeline of DFNs: NormalsEstimation/Pca on the scene,
//            KeypointExtraction3D/UniformSampling, FeaturesDescription3D/Shot (BOARD frames),
//            FeaturesMatching3D/KdTreeFlann, CorrespondenceGrouping/Hough3D, then
//            PoseHypothesisSelection/IcpMisfit; the model's keypoints and descriptors once.
//   Open3d   Open3D's FPFH + RANSAC global registration as its tutorial configures it, with the
//            voxel size = the pipeline's keypoint spacing (bench/open3d_global_registration.hpp).
//
// Every distance follows from the model's bounding radius R: keypoints k = R/20 apart, SHOT's
// support 4 k, the local reference frames' 3.2 k, Hough bins k; every scene keypoint matched to
// its nearest model descriptor (no ratio test: the Hough voting rejects the wrong matches, as in
// PCL's correspondence grouping tutorial). Chosen on tuning frames 1-12 among R/12-R/50 and
// supports 2-5 k (CDFF_KEYPOINT_PARTS, CDFF_SUPPORT, CDFF_RATIO, CDFF_MAX_DISTANCE,
// CDFF_GROUPING=GeometricConsistency override them).
//
// Counters per pipeline: correct (found, within 5 % of the range and 5 degrees), wrong (found,
// not correct; Open3D always returns a pose), the CPU per frame of each stage (one thread: run
// with OMP_NUM_THREADS=1 for Open3D), the PCL model's preparation once (ours prepares its model
// on the first frame, inside that frame's time). Environment: CDFF_DRAW_SET, CDFF_FRAMES (200),
// CDFF_PIPELINES (';'-separated among ours, pcl, open3d; all by default), CDFF_VERBOSE=1 (one
// line per frame, with the hypothesis nearest the truth and what the selection makes of the truth
// itself), CDFF_VIEW_SET (scenario overrides, ';'-separated; target.procedural.kind=hexagonal:
// the second target, whose mesh the model is then sampled from), CDFF_FIRST_SEED (the first
// frame's seed). The benchmark's argument is the percentage of the target's returns an occluder
// hides (0, 25, 50; occlude(): a plate in front of the target, at half the range of its nearest
// return, with a straight edge at a random angle).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <sstream>

#include <opencv2/calib3d.hpp>

#include "CorrespondenceGrouping.gen.hpp"
#include "FeaturesDescription3D.gen.hpp"
#include "FeaturesMatching3D.gen.hpp"
#include "GlobalRegistration3D.gen.hpp"
#include "KeypointExtraction3D.gen.hpp"
#include "NormalsEstimation.gen.hpp"
#include "PoseHypothesisSelection.gen.hpp"
#include "PoseRefinement.gen.hpp"
#include "bench_support.hpp"
#include "cdff/egse/model.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/egse/simulator.hpp"
#include "cdff/types/depth_metres.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/opencv.hpp"
#include "open3d_global_registration.hpp"
#include "simulated_views.hpp"

namespace cdff::detection_demo {
namespace {

constexpr double kDeg = M_PI / 180.0;
/// Poses closer than this in attitude are the same twin (PoseHypothesisSelection's
/// distinct_angle).
constexpr double kSameTwinAngle = 10 * kDeg;

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

using bench::firstSeed;
using bench::splitEnvironment;

int framesFromEnvironment() {
  const char* v = std::getenv("CDFF_FRAMES");
  return v ? std::max(1, std::atoi(v)) : 200;
}

/// An occluder in front of the target (the occlusion rows): a plate across the line of sight at
/// half the range of the target's nearest return, whose straight edge crosses the target's image
/// at a random angle (drawn from `seed`) so that it hides `fraction` of the target's returns;
/// those become the plate's (a ToF pixel takes its depth, a LIDAR return the point where its ray
/// meets it). The plate returns as the target does, so free space stays free space: a pose whose
/// hidden part lies behind the plate is not contradicted by it.
Status occlude(SimulatedView& view, double fraction, std::uint64_t seed) {
  if (fraction <= 0) return Status::ok();
  std::mt19937_64 rng(seed ^ 0x6f63636c75646564ULL);
  const double angle = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng);
  // The returns in the order the edge sweeps over them, and how many it hides.
  auto hidden = [&](const std::vector<double>& along) {
    std::vector<std::size_t> order(along.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return along[a] < along[b]; });
    order.resize(
        static_cast<std::size_t>(std::lround(fraction * static_cast<double>(order.size()))));
    return order;
  };
  if (view.source == DepthSource::kLidar) {
    std::vector<Point4f> points(view.scan.points.begin(), view.scan.points.end());
    if (points.empty()) return Status::ok();
    Eigen::Vector3d sight = Eigen::Vector3d::Zero();
    for (const Point4f& p : points) sight += p.vec().cast<double>().normalized();
    sight.normalize();
    const Eigen::Vector3d across = sight.unitOrthogonal(), up = sight.cross(across);
    const Eigen::Vector3d edge = std::cos(angle) * across + std::sin(angle) * up;
    std::vector<double> along;
    double nearest = std::numeric_limits<double>::infinity();
    for (const Point4f& p : points) {
      const Eigen::Vector3d ray = p.vec().cast<double>().normalized();
      along.push_back(ray.dot(edge));
      nearest = std::min(nearest, p.vec().cast<double>().dot(sight));
    }
    const double plate = 0.5 * nearest;
    for (const std::size_t i : hidden(along)) {
      const Eigen::Vector3d ray = points[i].vec().cast<double>().normalized();
      const Eigen::Vector3f q = (ray * (plate / ray.dot(sight))).cast<float>();
      points[i] = Point4f(q.x(), q.y(), q.z());
    }
    view.scan.points = Buffer<Point4f>::fromVector(std::move(points));
    return Status::ok();
  }
  Result<cv::Mat> metres = depthMetres(view.depth);
  if (!metres) return metres.status();
  std::vector<cv::Point> pixels;
  std::vector<double> along;
  double nearest = std::numeric_limits<double>::infinity();
  for (int v = 0; v < metres->rows; ++v)
    for (int u = 0; u < metres->cols; ++u)
      if (const float z = metres->at<float>(v, u); std::isfinite(z)) {
        pixels.emplace_back(u, v);
        along.push_back(u * std::cos(angle) + v * std::sin(angle));
        nearest = std::min(nearest, static_cast<double>(z));
      }
  for (const std::size_t i : hidden(along))
    metres->at<float>(pixels[i]) = static_cast<float>(0.5 * nearest);
  const std::optional<CameraModel> camera = view.depth.image.camera;
  Result<Image> image = fromMat(*metres, view.depth.image.stamp, view.depth.image.frame_id);
  if (!image) return image.status();
  view.depth.image = std::move(image).value();
  view.depth.image.camera = camera;
  view.depth.meters_per_unit = 1.0;
  return Status::ok();
}

/// The scene cloud of a view, in the sensor's frame.
Result<PointCloud> sceneOf(const SimulatedView& view) {
  if (view.source == DepthSource::kLidar) return view.scan;
  return pointsOfDepth(view.depth);
}

/// Distances from the model's bounding radius.
struct Scales {
  double keypoints = 0, support = 0, lrf = 0, bin = 0;
  static Scales of(double radius) {
    const char* parts = std::getenv("CDFF_KEYPOINT_PARTS");
    const char* support = std::getenv("CDFF_SUPPORT");
    const double k = radius / (parts ? std::atof(parts) : 20.0);
    const double f = support ? std::atof(support) : 4.0;
    return {k, f * k, 0.8 * f * k, k};
  }
};

struct Model {
  PointCloud cloud;  // 2 cm apart, outward normals
  Features3D features;
  Scales scales;
  double radius = 0;
};

/// The hypotheses' verification, the same in both pipelines: with the ToF camera's range noise
/// when the scenes are its points (`tof`), with the LIDAR's description passed per scan.
std::unique_ptr<dfn::PoseHypothesisSelection> createSelection(const egse::TofSpec* tof) {
  const char* extra = std::getenv("CDFF_SELECTION");  // more parameters, "key: value, ..."
  std::string parameters = tof ? fmt::format("noise_constant: {}, noise_quadratic: {}",
                                             tof->noise_constant, tof->noise_quadratic)
                               : "";
  if (extra) parameters += (parameters.empty() ? "" : ", ") + std::string(extra);
  return bench::createConfigured<dfn::PoseHypothesisSelection>("PoseHypothesisSelection",
                                                               "IcpMisfit", "{" + parameters + "}");
}

/// Runs `select` on `hypotheses`; the refined pose when one passes.
Result<std::optional<Eigen::Isometry3d>> selectPose(dfn::PoseHypothesisSelection& select,
                                                    const Detections& hypotheses,
                                                    const PointCloud& scene,
                                                    const PointCloud& model,
                                                    const SimulatedView& view, bool lidar) {
  select.in.hypotheses.set(hypotheses);
  select.in.scene.set(scene);
  select.in.model.set(model);
  if (lidar)
    select.in.sensor.set(view.lidar);
  else
    select.in.sensor.clear();
  CDFF_RETURN_IF_ERROR(select.process().withContext("selection"));
  if (!*select.out.found) return std::optional<Eigen::Isometry3d>{};
  return std::optional<Eigen::Isometry3d>{select.out.pose->pose.isometry()};
}

/// The smallest attitude error among `hypotheses` (degrees): whether any was near the truth.
double nearestHypothesisDegrees(const Detections& hypotheses, const Transform& truth) {
  double nearest = 180;
  for (const Detection& d : hypotheses.detections) {
    const Eigen::Isometry3d h = d.pose.isometry(), t = truth.isometry();
    const double angle = Eigen::AngleAxisd(h.linear().transpose() * t.linear()).angle();
    nearest = std::min(nearest, angle / kDeg);
  }
  return nearest;
}

/// Our pipeline: GlobalRegistration3D/PointPairVoting (every size from the model's diameter,
/// the scene's normals fitted, turned towards the sensor at the scene's origin), then the same
/// verification as the seed's pipeline.
class OurPipeline {
 public:
  static Result<OurPipeline> create(bool lidar, const egse::TofSpec* tof) {
    OurPipeline p;
    const char* overrides = std::getenv("CDFF_OURS");
    p.register_ = bench::createConfigured<dfn::GlobalRegistration3D>(
        "GlobalRegistration3D", "PointPairVoting", overrides ? overrides : "{}");
    p.select_ = createSelection(tof);
    if (!p.register_ || !p.select_)
      return invalidParameter("a DFN of our pipeline did not configure");
    if (tof) {
      // The ToF detection's refinement on the depth map (dfpcs/detection_tof.yaml's settings,
      // the noise and the return threshold from the camera's description).
      p.refine_ = bench::createConfigured<dfn::PoseRefinement>(
          "PoseRefinement", "DepthIcp",
          fmt::format("{{candidates: 20, finalists: 6, depth_noise_constant: {}, "
                      "depth_noise_quadratic: {}, missing_depth_cost: 9, min_amplitude: {}, "
                      "min_rival_margin: 0.4, max_misfit: 3}}",
                      tof->noise_constant, tof->noise_quadratic, tof->min_amplitude));
      if (!p.refine_) return invalidParameter("PoseRefinement did not configure");
    }
    p.lidar_ = lidar;
    return p;
  }

  struct Outcome {
    std::optional<Eigen::Isometry3d> pose;  // scene_T_model
    double registration_s = 0, selection_s = 0;
    std::size_t hypotheses = 0;
    double nearest_hypothesis_deg = 180;
    double fitness = 0, visibility = 0, margin = 0, relative_margin = 0;
    std::optional<Eigen::Isometry3d> candidate;  // the selection's pose, found or ambiguous
    int chosen = -1;
    bool ambiguous = false;
    // ToF, when the cloud is ambiguous: the depth refinement's time and rival margin.
    double depth_s = 0, depth_margin = 0;
  };

  Result<Outcome> detect(const PointCloud& scene, const PointCloud& model,
                         const SimulatedView& view) {
    Outcome o;
    double t = cpuSeconds();
    register_->in.scene.set(scene);
    register_->in.model.set(model);
    CDFF_RETURN_IF_ERROR(register_->process().withContext("global registration"));
    o.registration_s = cpuSeconds() - t;
    o.hypotheses = register_->out.hypotheses->detections.size();
    o.nearest_hypothesis_deg =
        nearestHypothesisDegrees(*register_->out.hypotheses, view.camera_truth);
    t = cpuSeconds();
    Result<std::optional<Eigen::Isometry3d>> pose =
        selectPose(*select_, *register_->out.hypotheses, scene, model, view, lidar_);
    if (!pose) return pose.status();
    o.pose = *pose;
    o.selection_s = cpuSeconds() - t;
    o.fitness = *select_->out.fitness;
    o.visibility = *select_->out.visibility;
    o.margin = *select_->out.margin;
    o.relative_margin = *select_->out.relative_margin;
    if (select_->out.pose.hasValue()) o.candidate = select_->out.pose->pose.isometry();
    o.chosen = *select_->out.chosen;
    o.ambiguous = *select_->out.ambiguous;
    // A ToF scene the cloud leaves ambiguous: the depth map decides (free space: the twin that
    // puts surface where the camera sees nothing or something farther loses).
    if (refine_ && o.ambiguous) {
      t = cpuSeconds();
      refine_->in.detections.set(*select_->out.candidates);
      refine_->in.depth.set(view.depth);
      refine_->in.model.set(model);
      CDFF_RETURN_IF_ERROR(refine_->process().withContext("depth refinement"));
      // Decided when the depth map's best pose is the points' best (the selection's pose):
      // two independent kinds of evidence agree. Where they disagree (the depth map prefers a
      // twin the points rank lower) the view stays ambiguous.
      if (*refine_->out.refined && o.candidate) {
        const Eigen::Isometry3d depth_pose = refine_->out.pose->pose.isometry();
        const double apart =
            Eigen::AngleAxisd(depth_pose.linear().transpose() * o.candidate->linear()).angle();
        if (apart < kSameTwinAngle) o.pose = depth_pose;
      }
      o.depth_margin = *refine_->out.rival_margin;
      o.depth_s = cpuSeconds() - t;
    }
    return o;
  }

 private:
  std::unique_ptr<dfn::GlobalRegistration3D> register_;
  std::unique_ptr<dfn::PoseHypothesisSelection> select_;
  std::unique_ptr<dfn::PoseRefinement> refine_;
  bool lidar_ = false;
};

/// The seed's pipeline, its DFNs configured once.
class PclPipeline {
 public:
  /// `tof`: the ToF camera's description when the scenes are its points (their range noise).
  static Result<PclPipeline> create(const Scales& s, bool lidar, const egse::TofSpec* tof) {
    PclPipeline p;
    p.normals_ = bench::createConfigured<dfn::NormalsEstimation>(
        "NormalsEstimation", "Pca", fmt::format("{{radius: {}}}", s.keypoints));
    p.keypoints_ = bench::createConfigured<dfn::KeypointExtraction3D>(
        "KeypointExtraction3D", "UniformSampling", fmt::format("{{radius: {}}}", s.keypoints));
    p.describe_ = bench::createConfigured<dfn::FeaturesDescription3D>(
        "FeaturesDescription3D", "Shot",
        fmt::format("{{radius: {}, lrf_radius: {}}}", s.support, s.lrf));
    const char* ratio = std::getenv("CDFF_RATIO");
    p.match_ = bench::createConfigured<dfn::FeaturesMatching3D>(
        "FeaturesMatching3D", "KdTreeFlann",
        fmt::format("{{ratio: {}, max_distance: {}}}", ratio ? ratio : "1.0",
                    std::getenv("CDFF_MAX_DISTANCE") ? std::getenv("CDFF_MAX_DISTANCE") : "1e6"));
    const char* grouping = std::getenv("CDFF_GROUPING");
    p.group_ = grouping && std::string(grouping) == "GeometricConsistency"
                   ? bench::createConfigured<dfn::CorrespondenceGrouping>(
                         "CorrespondenceGrouping", "GeometricConsistency",
                         fmt::format("{{consensus_size: {}}}", s.bin))
                   : bench::createConfigured<dfn::CorrespondenceGrouping>(
                         "CorrespondenceGrouping", "Hough3D",
                         fmt::format("{{bin_size: {}, lrf_radius: {}}}", s.bin, s.lrf));
    p.select_ = createSelection(tof);
    if (!p.normals_ || !p.keypoints_ || !p.describe_ || !p.match_ || !p.group_ || !p.select_)
      return invalidParameter("a DFN of the PCL pipeline did not configure");
    p.lidar_ = lidar;
    return p;
  }

  /// The model's keypoints and descriptors.
  Result<Features3D> describeModel(const PointCloud& model) {
    keypoints_->in.cloud.set(model);
    CDFF_RETURN_IF_ERROR(keypoints_->process().withContext("model keypoints"));
    describe_->in.keypoints.set(*keypoints_->out.keypoints);
    describe_->in.surface.set(model);
    CDFF_RETURN_IF_ERROR(describe_->process().withContext("model descriptors"));
    return *describe_->out.features;
  }

  struct Outcome {
    std::optional<Eigen::Isometry3d> pose;  // scene_T_model
    std::map<std::string, double> cpu_s;
    std::size_t scene_points = 0, keypoints = 0, matches = 0, right_matches = 0, hypotheses = 0;
    double nearest_hypothesis_deg = 180;  // the hypothesis nearest the truth in attitude
    double fitness = 0, truth_fitness = 0;
  };

  /// `diagnose`: also score the truth itself (outside the stage times).
  Result<Outcome> detect(const PointCloud& scene, const Model& model, const SimulatedView& view,
                         bool diagnose) {
    Outcome o;
    o.scene_points = scene.size();
    double t = cpuSeconds();
    auto lap = [&](const char* stage) {
      const double now = cpuSeconds();
      o.cpu_s[stage] = now - t;
      t = now;
    };
    normals_->in.cloud.set(scene);
    CDFF_RETURN_IF_ERROR(normals_->process().withContext("scene normals"));
    const PointCloud with_normals = *normals_->out.with_normals;
    lap("normals");
    keypoints_->in.cloud.set(with_normals);
    CDFF_RETURN_IF_ERROR(keypoints_->process().withContext("scene keypoints"));
    o.keypoints = keypoints_->out.keypoints->size();
    lap("keypoints");
    describe_->in.keypoints.set(*keypoints_->out.keypoints);
    describe_->in.surface.set(with_normals);
    CDFF_RETURN_IF_ERROR(describe_->process().withContext("scene descriptors"));
    const Features3D scene_features = *describe_->out.features;
    lap("descriptors");
    match_->in.query.set(scene_features);
    match_->in.train.set(model.features);
    CDFF_RETURN_IF_ERROR(match_->process().withContext("matching"));
    o.matches = match_->out.matches->size();
    lap("matching");
    // Right matches: the model keypoint within two keypoint spacings of where the truth puts the
    // scene keypoint (a diagnostic, outside the stage times).
    const Eigen::Isometry3f model_T_scene = view.camera_truth.isometry().inverse().cast<float>();
    for (const Match& m : match_->out.matches->matches) {
      const Eigen::Vector3f at = model_T_scene * scene_features.keypoints[m.query].position;
      o.right_matches +=
          (at - model.features.keypoints[m.train].position).norm() <= 2 * model.scales.keypoints;
    }
    t = cpuSeconds();
    group_->in.scene_features.set(scene_features);
    group_->in.model_features.set(model.features);
    group_->in.matches.set(*match_->out.matches);
    group_->in.scene.set(with_normals);
    group_->in.model.set(model.cloud);
    CDFF_RETURN_IF_ERROR(group_->process().withContext("grouping"));
    o.hypotheses = group_->out.hypotheses->detections.size();
    o.nearest_hypothesis_deg = nearestHypothesisDegrees(*group_->out.hypotheses, view.camera_truth);
    lap("grouping");
    Result<std::optional<Eigen::Isometry3d>> pose =
        selectPose(*select_, *group_->out.hypotheses, scene, model.cloud, view, lidar_);
    if (!pose) return pose.status();
    o.pose = *pose;
    o.fitness = *select_->out.fitness;
    lap("selection");
    if (!diagnose) return o;
    // What the selection makes of the truth itself: the best any hypothesis could score.
    Detections truth = *group_->out.hypotheses;
    truth.detections.assign(1, Detection{});
    truth.detections[0].pose = view.camera_truth;
    truth.detections[0].pose.parent_frame = scene.frame_id;
    truth.detections[0].pose.child_frame = model.cloud.frame_id;
    select_->in.hypotheses.set(truth);
    CDFF_RETURN_IF_ERROR(select_->process());
    o.truth_fitness = *select_->out.fitness;
    return o;
  }

 private:
  std::unique_ptr<dfn::NormalsEstimation> normals_;
  std::unique_ptr<dfn::KeypointExtraction3D> keypoints_;
  std::unique_ptr<dfn::FeaturesDescription3D> describe_;
  std::unique_ptr<dfn::FeaturesMatching3D> match_;
  std::unique_ptr<dfn::CorrespondenceGrouping> group_;
  std::unique_ptr<dfn::PoseHypothesisSelection> select_;
  bool lidar_ = false;
};

/// The pipelines run (CDFF_PIPELINES, ';'-separated among ours, pcl, open3d; all by default).
struct Pipelines {
  bool ours = true, pcl = true, open3d = true;
  static Pipelines fromEnvironment() {
    const std::vector<std::string> names = splitEnvironment("CDFF_PIPELINES");
    if (names.empty()) return {};
    Pipelines p{false, false, false};
    for (const std::string& name : names) {
      p.ours = p.ours || name == "ours";
      p.pcl = p.pcl || name == "pcl";
      p.open3d = p.open3d || name == "open3d";
    }
    return p;
  }
};

/// Within 5 % of the range and 5 degrees of the truth (the correct pose).
bool correct(const Eigen::Isometry3d& estimate, const Transform& truth) {
  const Eigen::Isometry3d t = truth.isometry();
  const double position = (estimate.translation() - t.translation()).norm();
  const double angle = Eigen::AngleAxisd(estimate.linear().transpose() * t.linear()).angle();
  return position <= 0.05 * t.translation().norm() && angle <= 5 * kDeg;
}

void runFrames(benchmark::State& state, DepthSource source) {
  const double occluded = 0.01 * static_cast<double>(state.range(0));
  ViewOptions options;
  options.source = source;
  options.overrides = splitEnvironment("CDFF_VIEW_SET");
  if (source == DepthSource::kTof) options.max_range = 10.0;
  const int frames = framesFromEnvironment();
  const bool verbose = std::getenv("CDFF_VERBOSE") != nullptr;

  // The target's mesh as the scenario builds it (overrides included), sampled 2 cm apart.
  Result<SimulatedView> first = simulateView(options, firstSeed());
  if (!first) return state.SkipWithError(first.status().toString().c_str());
  Result<std::filesystem::path> file = egse::resolveScenario(first->lighting);
  if (!file) return state.SkipWithError(file.status().toString().c_str());
  Result<egse::Scenario> scenario = egse::loadScenario(*file, options.overrides);
  if (!scenario) return state.SkipWithError(scenario.status().toString().c_str());
  Result<std::unique_ptr<egse::Simulator>> sim = egse::Simulator::create(*scenario, 1, 0.01);
  if (!sim) return state.SkipWithError(sim.status().toString().c_str());
  const TriangleMesh& mesh = (*sim)->target().mesh;
  Model model;
  // With the materials' reflectivity as intensity: where a ToF camera returns no depth.
  model.cloud = egse::samplePointCloud(
      (*sim)->target(), static_cast<std::size_t>(mesh.surfaceArea() / (0.02 * 0.02)), 1);
  model.cloud.frame_id = "target";
  Eigen::Vector3f low = model.cloud.points[0].vec(), high = low;
  for (const Point4f& p : model.cloud.points) {
    low = low.cwiseMin(p.vec());
    high = high.cwiseMax(p.vec());
  }
  model.radius = 0.5 * (high - low).norm();
  model.scales = Scales::of(model.radius);
  const bool lidar = source == DepthSource::kLidar;
  const egse::SensorConfig* tof = scenario->sensor("tof");
  Result<PclPipeline> pcl =
      PclPipeline::create(model.scales, lidar, !lidar && tof ? &tof->tof : nullptr);
  if (!pcl) return state.SkipWithError(pcl.status().toString().c_str());
  double t0 = cpuSeconds();
  Result<Features3D> model_features = pcl->describeModel(model.cloud);
  if (!model_features) return state.SkipWithError(model_features.status().toString().c_str());
  model.features = std::move(model_features).value();
  state.counters["model_prep_ms"] = 1e3 * (cpuSeconds() - t0);
  state.counters["model_keypoints"] = static_cast<double>(model.features.size());
  bench::Open3dSettings o3d;
  o3d.voxel = model.scales.keypoints;

  Result<OurPipeline> ours = OurPipeline::create(lidar, !lidar && tof ? &tof->tof : nullptr);
  if (!ours) return state.SkipWithError(ours.status().toString().c_str());
  const Pipelines run = Pipelines::fromEnvironment();

  int ours_ambiguous = 0;
  double ours_depth = 0;
  int ours_correct = 0, ours_wrong = 0, pcl_correct = 0, pcl_wrong = 0, o3d_correct = 0,
      o3d_wrong = 0, used = 0;
  std::map<std::string, double> cpu;
  double ours_registration = 0, ours_selection = 0, o3d_features = 0, o3d_ransac = 0, points = 0,
         right_matches = 0;
  for (auto _ : state) {
    for (int k = 0; k < frames; ++k) {
      const std::uint64_t seed = firstSeed() + static_cast<std::uint64_t>(k);
      Result<SimulatedView> view = simulateView(options, seed);
      if (!view) return state.SkipWithError(view.status().toString().c_str());
      if (Status s = occlude(*view, occluded, seed); !s.isOk())
        return state.SkipWithError(s.toString().c_str());
      Result<PointCloud> scene = sceneOf(*view);
      if (!scene) return state.SkipWithError(scene.status().toString().c_str());
      if (scene->size() < 20) continue;  // nothing to detect on (counted as not used)
      ++used;
      points += static_cast<double>(scene->size());
      std::string line =
          fmt::format("seed {} {:.1f} m {} points:", seed, view->range, scene->size());
      // A pose against the truth, for the frame's line.
      auto describe = [&](const std::optional<Eigen::Isometry3d>& pose) {
        if (!pose) return std::string("none");
        const Eigen::Isometry3d t = view->camera_truth.isometry();
        return fmt::format(
            "{} {:.2f} m {:.1f} deg", correct(*pose, view->camera_truth) ? "correct" : "WRONG",
            (pose->translation() - t.translation()).norm(),
            Eigen::AngleAxisd(pose->linear().transpose() * t.linear()).angle() / kDeg);
      };
      // A pipeline's reported pose, counted as right or wrong.
      auto verdict = [&](const std::optional<Eigen::Isometry3d>& pose, int& right, int& wrong) {
        const bool ok = pose && correct(*pose, view->camera_truth);
        right += ok;
        wrong += pose && !ok;
        return describe(pose);
      };
      if (run.ours) {
        Result<OurPipeline::Outcome> r = ours->detect(*scene, model.cloud, *view);
        if (!r) return state.SkipWithError(r.status().toString().c_str());
        ours_registration += r->registration_s;
        ours_selection += r->selection_s;
        ours_ambiguous += r->ambiguous;
        line += fmt::format(
            " ours {}{} ({} hypotheses, nearest {:.0f} deg, chosen {}, fitness {:.2f}, visibility "
            "{:.2f}, margin {:.1f}, {:.0f} ms)",
            verdict(r->pose, ours_correct, ours_wrong), r->ambiguous ? " ambiguous" : "",
            r->hypotheses, r->nearest_hypothesis_deg, r->chosen, r->fitness, r->visibility,
            r->margin, 1e3 * (r->registration_s + r->selection_s));
        if (r->ambiguous)
          line += fmt::format(" (candidate {}, relative margin {:.2f})", describe(r->candidate),
                              r->relative_margin);
        if (r->ambiguous && view->source == DepthSource::kTof) {
          ours_depth += r->depth_s;
          line += fmt::format(" (ambiguous: the depth refinement {}, margin {:.2f}, {:.0f} ms)",
                              r->pose ? "decided" : "did not decide", r->depth_margin,
                              1e3 * r->depth_s);
        }
      }
      if (run.pcl) {
        Result<PclPipeline::Outcome> r = pcl->detect(*scene, model, *view, verbose);
        if (!r) return state.SkipWithError(r.status().toString().c_str());
        double total = 0;
        for (const auto& [stage, s] : r->cpu_s) {
          cpu[stage] += s;
          total += s;
        }
        if (r->matches > 0)
          right_matches += static_cast<double>(r->right_matches) / static_cast<double>(r->matches);
        line += fmt::format(
            " pcl {} ({} keypoints, {} matches ({} right), {} hypotheses, nearest {:.0f} deg, "
            "fitness {:.2f}, at the truth {:.2f}, {:.0f} ms)",
            verdict(r->pose, pcl_correct, pcl_wrong), r->keypoints, r->matches, r->right_matches,
            r->hypotheses, r->nearest_hypothesis_deg, r->fitness, r->truth_fitness, 1e3 * total);
      }
      if (run.open3d) {
        const bench::Open3dResult peer =
            bench::open3dGlobalRegistration(*scene, model.cloud, o3d, static_cast<unsigned>(seed));
        o3d_features += peer.cpu_features_s;
        o3d_ransac += peer.cpu_ransac_s;
        // Open3D always returns a pose: a wrong one is reported as found.
        line += fmt::format(" open3d {} (fitness {:.2f}, {:.0f} ms)",
                            verdict(peer.scene_T_model, o3d_correct, o3d_wrong), peer.fitness,
                            1e3 * (peer.cpu_features_s + peer.cpu_ransac_s));
      }
      if (verbose) std::fprintf(stderr, "%s\n", line.c_str());
    }
  }
  const double n = std::max(1, used);
  state.counters["frames"] = used;
  state.counters["scene_points"] = points / n;
  if (run.ours) {
    state.counters["ours_correct"] = ours_correct / n;
    state.counters["ours_wrong"] = ours_wrong / n;
    state.counters["ours_ms_registration"] = 1e3 * ours_registration / n;
    state.counters["ours_ms_selection"] = 1e3 * ours_selection / n;
    state.counters["ours_ambiguous"] = ours_ambiguous / n;
    if (source == DepthSource::kTof) state.counters["ours_ms_depth"] = 1e3 * ours_depth / n;
    state.counters["ours_ms"] = 1e3 * (ours_registration + ours_selection + ours_depth) / n;
  }
  if (run.pcl) {
    state.counters["pcl_correct"] = pcl_correct / n;
    state.counters["pcl_wrong"] = pcl_wrong / n;
    state.counters["pcl_right_matches"] = right_matches / n;
    double total = 0;
    for (const auto& [stage, s] : cpu) {
      state.counters["pcl_ms_" + stage] = 1e3 * s / n;
      total += s;
    }
    state.counters["pcl_ms"] = 1e3 * total / n;
  }
  if (run.open3d) {
    state.counters["open3d_correct"] = o3d_correct / n;
    state.counters["open3d_wrong"] = o3d_wrong / n;
    state.counters["open3d_ms_features"] = 1e3 * o3d_features / n;
    state.counters["open3d_ms_ransac"] = 1e3 * o3d_ransac / n;
  }
}

void BM_ModelDetection3D_Lidar(benchmark::State& state) {
  runFrames(state, DepthSource::kLidar);
}
void BM_ModelDetection3D_Tof(benchmark::State& state) {
  runFrames(state, DepthSource::kTof);
}
/// One row per share of the target's returns an occluder hides (occlude()), in percent.
void occlusionRows(benchmark::internal::Benchmark* b) {
  b->ArgName("occluded_percent")->Arg(0)->Arg(25)->Arg(50)->Unit(benchmark::kSecond)->Iterations(1);
}
BENCHMARK(BM_ModelDetection3D_Lidar)->Apply(occlusionRows);
BENCHMARK(BM_ModelDetection3D_Tof)->Apply(occlusionRows);

}  // namespace
}  // namespace cdff::detection_demo

CDFF_BENCHMARK_MAIN();
