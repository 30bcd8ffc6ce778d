#include "simulated_views.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <random>

#include <fmt/format.h>

#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/graph.hpp"
#include "cdff/dfpc/orchestrator.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/egse/simulator.hpp"
#include "cdff/egse/sink.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/types/mesh.hpp"

#ifndef CDFF_SOURCE_DIR
#define CDFF_SOURCE_DIR "."
#endif

namespace cdff::detection_demo {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr const char* kLeft = "/chaser/camera/left/image";
constexpr const char* kRight = "/chaser/camera/right/image";
constexpr const char* kLeftMounting = "/chaser/tf/camera_left_optical";
constexpr const char* kRightMounting = "/chaser/tf/camera_right_optical";
constexpr const char* kCameraTruth = "/truth/camera_left/target_pose";
constexpr const char* kPair = "/chaser/stereo/pair";
constexpr const char* kTofDepth = "/chaser/tof/depth";
constexpr const char* kTofMounting = "/chaser/tf/tof_optical";
constexpr const char* kTofTruth = "/truth/tof/target_pose";
constexpr const char* kLidarScan = "/chaser/lidar/points";
constexpr const char* kLidarInfo = "/chaser/lidar/info";
constexpr const char* kLidarMounting = "/chaser/tf/lidar";
constexpr const char* kLidarTruth = "/truth/lidar/target_pose";

std::string vec3(const Eigen::Vector3d& v) {
  return fmt::format("[{:.17g}, {:.17g}, {:.17g}]", v.x(), v.y(), v.z());
}

// Fraction of `points` (target frame) in front of the camera and inside its image.
double fractionInView(const PointCloud& points, const Eigen::Isometry3d& camera_T_target,
                      const CameraModel& camera) {
  if (points.size() == 0) return 0;
  std::size_t inside = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = camera_T_target * points.points[i].vec().cast<double>();
    if (p.z() <= 1e-3) continue;
    const double u = camera.fx * p.x() / p.z() + camera.cx;
    const double v = camera.fy * p.y() / p.z() + camera.cy;
    if (u >= 0 && v >= 0 && u < camera.width && v < camera.height) ++inside;
  }
  return static_cast<double>(inside) / points.size();
}

Timestamp stampOf(const Image& v) {
  return v.stamp;
}
Timestamp stampOf(const Transform& v) {
  return v.stamp;
}
Timestamp stampOf(const DepthMap& v) {
  return v.image.stamp;
}
Timestamp stampOf(const PointCloud& v) {
  return v.stamp;
}
Timestamp stampOf(const LidarInfo& v) {
  return v.stamp;
}

// Fraction of `points` (target frame) within the LIDAR's lasers' elevations and ranges.
double fractionInLidarView(const PointCloud& points, const Eigen::Isometry3d& lidar_T_target,
                           const egse::LidarSpec& lidar) {
  if (points.size() == 0 || lidar.elevations.empty()) return 0;
  const auto [low, high] = std::minmax_element(lidar.elevations.begin(), lidar.elevations.end());
  std::size_t inside = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = lidar_T_target * points.points[i].vec().cast<double>();
    const double elevation = std::atan2(p.z(), p.head<2>().norm());
    const double range = p.norm();
    if (elevation >= *low && elevation <= *high && range >= lidar.min_range &&
        range <= lidar.max_range)
      ++inside;
  }
  return static_cast<double>(inside) / points.size();
}

// The first `T` on `channel` (stamped `stamp`, or any when `stamp` < 0).
template <typename T>
const T* payloadAt(const egse::MemorySink& sink, const std::string& channel, Timestamp stamp) {
  for (const egse::SimMessage& m : sink.messages())
    if (m.channel == channel)
      if (const T* v = std::get_if<T>(&m.payload); v && (stamp < 0 || stampOf(*v) == stamp))
        return v;
  return nullptr;
}

const Transform* truthPose(const egse::MemorySink& sink, const std::string& channel,
                           Timestamp stamp) {
  for (const egse::SimMessage& m : sink.messages()) {
    if (m.channel != channel) continue;
    const Transform* pose = nullptr;
    if (const PoseWithCovariance* p = std::get_if<PoseWithCovariance>(&m.payload)) pose = &p->pose;
    if (const RigidBodyState* s = std::get_if<RigidBodyState>(&m.payload)) pose = &s->pose;
    if (pose && pose->stamp == stamp) return pose;
  }
  return nullptr;
}

}  // namespace

Result<SimulatedView> simulateView(const ViewOptions& options, std::uint64_t seed,
                                   bool with_target) {
  if (options.lighting.empty()) return invalidInput("ViewOptions::lighting is empty");
  if (!(options.min_range > 0 && options.max_range >= options.min_range))
    return invalidInput("ViewOptions ranges [{}, {}] m; expected 0 < min_range <= max_range",
                        options.min_range, options.max_range);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const std::string lighting = options.lighting[std::uniform_int_distribution<std::size_t>(
      0, options.lighting.size() - 1)(rng)];
  Result<std::filesystem::path> file = egse::resolveScenario(lighting);
  if (!file) return file.status();
  Result<egse::Scenario> base = egse::loadScenario(*file, options.overrides);
  if (!base) return base.status();
  // The servicer stays on the scenario's first line of sight, which its lighting is set for.
  const Eigen::Vector3d line_of_sight = base->start.normalized();

  std::normal_distribution<double> normal;
  constexpr int kAttempts = 100;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    const double range = options.min_range + (options.max_range - options.min_range) * unit(rng);
    Eigen::Quaterniond attitude(normal(rng), normal(rng), normal(rng), normal(rng));
    attitude.normalize();  // uniform on SO(3)
    const Eigen::Vector3d ypr = attitude.toRotationMatrix().eulerAngles(2, 1, 0);
    // Pointing offsets: within the inner part of the field of view with the target, turned at
    // least 60 degrees away from it without.
    double yaw = 0, pitch = 0;
    if (with_target) {
      yaw = (2 * unit(rng) - 1) * 12.0;
      pitch = (2 * unit(rng) - 1) * 9.0;
    } else {
      yaw = (unit(rng) < 0.5 ? -1 : 1) * (60 + 120 * unit(rng));
      pitch = (2 * unit(rng) - 1) * 60.0;
    }
    const bool tof = options.source == DepthSource::kTof;
    const bool lidar = options.source == DepthSource::kLidar;
    std::vector<std::string> overrides = {
        lidar ? "sensors.lidar.enabled=true" : "sensors.lidar.enabled=false",
        tof ? "sensors.tof.enabled=true" : "sensors.tof.enabled=false",
        tof || lidar ? "sensors.camera_left.enabled=false" : "sensors.camera_left.enabled=true",
        tof || lidar ? "sensors.camera_right.enabled=false" : "sensors.camera_right.enabled=true",
        "sensors.imu.enabled=false",
        fmt::format("servicer.trajectory={{type: hold, position: {}}}",
                    vec3(range * line_of_sight)),
        fmt::format("target.attitude={{mode: lvlh, rpy_deg: {}}}",
                    vec3(Eigen::Vector3d(ypr[2], ypr[1], ypr[0]) / kDeg)),
        fmt::format("servicer.attitude.yaw_offset_deg={:.6f}", yaw),
        fmt::format("servicer.attitude.pitch_offset_deg={:.6f}", pitch)};
    overrides.insert(overrides.begin(), options.overrides.begin(), options.overrides.end());
    Result<egse::Scenario> scenario = egse::loadScenario(*file, overrides);
    if (!scenario) return scenario.status().withContext(fmt::format("frame seed {}", seed));
    // A LIDAR scan is published one revolution after it starts.
    Result<std::unique_ptr<egse::Simulator>> sim =
        egse::Simulator::create(*scenario, seed, /*duration=*/lidar ? 0.15 : 0.01);
    if (!sim) return sim.status();
    if (lidar) {
      const egse::SensorConfig* sensor = (*sim)->scenario().sensor("lidar");
      if (!sensor) return invalidInput("scenario '{}' has no lidar", lighting);
      Result<PointCloud> samples = sampleSurface((*sim)->target().mesh, 1000, seed);
      if (!samples) return samples.status();
      const double in_view =
          fractionInLidarView(*samples, (*sim)->sensorTtarget(*sensor, 0.0), sensor->lidar);
      if (with_target ? in_view < options.min_in_view : in_view > 0) continue;
      egse::MemorySink sink;
      CDFF_RETURN_IF_ERROR((*sim)->run(sink));
      const PointCloud* scan = payloadAt<PointCloud>(sink, kLidarScan, -1);
      if (!scan) return notFound("frame seed {}: the simulation gave no {}", seed, kLidarScan);
      const LidarInfo* info = payloadAt<LidarInfo>(sink, kLidarInfo, scan->stamp);
      const Transform* mounting = payloadAt<Transform>(sink, kLidarMounting, -1);
      const Transform* sensor_truth = truthPose(sink, kLidarTruth, scan->stamp);
      if (!info || !mounting || !sensor_truth)
        return notFound("frame seed {}: the simulation lacks {}, {} or the truth at {} us", seed,
                        kLidarInfo, kLidarMounting, scan->stamp);
      SimulatedView view;
      view.source = DepthSource::kLidar;
      view.scan = *scan;
      view.lidar = *info;
      view.camera_mounting = *mounting;
      Result<Transform> truth = mounting->compose(*sensor_truth);
      if (!truth) return truth.status();
      view.truth = *truth;
      view.truth.stamp = scan->stamp;
      view.camera_truth = *sensor_truth;
      view.lighting = lighting;
      view.range = sensor_truth->translation.norm();
      view.target_in_view = with_target;
      return view;
    }
    if (tof) {
      const egse::SensorConfig* sensor = (*sim)->scenario().sensor("tof");
      if (!sensor) return invalidInput("scenario '{}' has no tof", lighting);
      Result<PointCloud> samples = sampleSurface((*sim)->target().mesh, 1000, seed);
      if (!samples) return samples.status();
      const double in_view =
          fractionInView(*samples, (*sim)->sensorTtarget(*sensor, 0.0), sensor->tof.model);
      if (with_target ? in_view < options.min_in_view : in_view > 0) continue;
      egse::MemorySink sink;
      CDFF_RETURN_IF_ERROR((*sim)->run(sink));
      const DepthMap* depth = payloadAt<DepthMap>(sink, kTofDepth, -1);
      if (!depth) return notFound("frame seed {}: the simulation gave no {}", seed, kTofDepth);
      const Transform* mounting = payloadAt<Transform>(sink, kTofMounting, -1);
      const Transform* camera_truth = truthPose(sink, kTofTruth, depth->image.stamp);
      if (!mounting || !camera_truth)
        return notFound("frame seed {}: the simulation lacks {} or the truth at {} us", seed,
                        kTofMounting, depth->image.stamp);
      SimulatedView view;
      view.source = DepthSource::kTof;
      view.depth = *depth;
      view.camera_mounting = *mounting;
      Result<Transform> truth = mounting->compose(*camera_truth);
      if (!truth) return truth.status();
      view.truth = *truth;
      view.truth.stamp = depth->image.stamp;
      view.camera_truth = *camera_truth;
      view.lighting = lighting;
      view.range = camera_truth->translation.norm();
      view.target_in_view = with_target;
      return view;
    }
    const egse::SensorConfig* left = (*sim)->scenario().sensor("camera_left");
    if (!left || !(*sim)->scenario().sensor("camera_right"))
      return invalidInput("scenario '{}' has no camera_left and camera_right", lighting);
    Result<PointCloud> samples = sampleSurface((*sim)->target().mesh, 1000, seed);
    if (!samples) return samples.status();
    const double in_view =
        fractionInView(*samples, (*sim)->sensorTtarget(*left, 0.0), left->camera.model);
    if (with_target ? in_view < options.min_in_view : in_view > 0) continue;

    egse::MemorySink sink;
    CDFF_RETURN_IF_ERROR((*sim)->run(sink));
    const Image* l = payloadAt<Image>(sink, kLeft, -1);
    if (!l) return notFound("frame seed {}: the simulation gave no {}", seed, kLeft);
    const Image* r = payloadAt<Image>(sink, kRight, l->stamp);
    const Transform* lm = payloadAt<Transform>(sink, kLeftMounting, -1);
    const Transform* rm = payloadAt<Transform>(sink, kRightMounting, -1);
    const Transform* camera_truth = truthPose(sink, kCameraTruth, l->stamp);
    if (!r || !lm || !rm || !camera_truth)
      return notFound(
          "frame seed {}: the simulation lacks the right image, a mounting or the "
          "truth at {} us",
          seed, l->stamp);
    SimulatedView view;
    view.pair.left = *l;
    view.pair.right = *r;
    Result<Transform> right_T_left = rm->inverse().compose(*lm);
    if (!right_T_left) return right_T_left.status();
    view.pair.right_T_left = *right_T_left;
    view.camera_mounting = *lm;
    Result<Transform> truth = lm->compose(*camera_truth);
    if (!truth) return truth.status();
    view.truth = *truth;
    view.truth.stamp = l->stamp;
    view.camera_truth = *camera_truth;
    view.lighting = lighting;
    view.range = camera_truth->translation.norm();
    view.target_in_view = with_target;
    return view;
  }
  return Status(StatusCode::kInternal,
                fmt::format("frame seed {}: no draw in {} attempts put {} the target in view", seed,
                            kAttempts, with_target ? "enough of" : "none of"));
}

struct Detector::State {
  std::string product_prefix;  // /cdff/<graph name>/
  bool has_camera_pose = false;
  dfpc::MemorySink products;
  std::unique_ptr<dfpc::Orchestrator> orchestrator;
  std::int64_t frames = 0;
  std::optional<Transform> mounting;  // the last one sent
};

Detector::Detector(std::unique_ptr<State> state) : state_(std::move(state)) {}
Detector::~Detector() = default;

Result<std::unique_ptr<Detector>> Detector::create(const std::vector<std::string>& settings,
                                                   const std::string& source_dir,
                                                   DepthSource depth_source) {
  const std::filesystem::path source = source_dir.empty() ? CDFF_SOURCE_DIR : source_dir;
  const char* graph =
      depth_source == DepthSource::kTof ? "dfpcs/detection_tof.yaml" : "dfpcs/detection.yaml";
  Result<dfpc::GraphSpec> spec = dfpc::loadGraphFile((source / graph).string(), settings);
  if (!spec) return spec.status();
  auto state = std::make_unique<State>();
  state->product_prefix = "/cdff/" + spec->name + "/";
  for (const dfpc::DfpcOutputSpec& output : spec->outputs)
    state->has_camera_pose = state->has_camera_pose || output.name == "camera_pose";
  // The graph's file parameters are relative to the repository.
  for (dfpc::InstanceSpec& inst : spec->instances)
    for (const char* key : {"template_file", "model_file", "mesh_file"})
      if (inst.parameters[key] && !inst.parameters[key].as<std::string>().empty() &&
          std::filesystem::path(inst.parameters[key].as<std::string>()).is_relative())
        inst.parameters[key] = (source / inst.parameters[key].as<std::string>()).string();
  Result<std::unique_ptr<dfpc::Dfpc>> dfpc = dfpc::Dfpc::create(std::move(spec).value());
  if (!dfpc) return dfpc.status();
  dfpc::OrchestratorOptions o;
  o.sink = &state->products;
  state->orchestrator = std::make_unique<dfpc::Orchestrator>(o);
  CDFF_RETURN_IF_ERROR(state->orchestrator->add(std::move(dfpc).value()));
  CDFF_RETURN_IF_ERROR(state->orchestrator->startAll());
  return std::unique_ptr<Detector>(new Detector(std::move(state)));
}

Result<DetectionOutcome> Detector::run(const SimulatedView& view) {
  State& s = *state_;
  const Timestamp stamp = ++s.frames * 1'000'000;
  // The mounting comes as a recording's static channel gives it: once, and again only when it
  // changes (a graph must keep it from its first message).
  const bool tof = view.source == DepthSource::kTof;
  const Transform& mounting = view.camera_mounting;
  if (!s.mounting || !s.mounting->isometry().isApprox(mounting.isometry()) ||
      s.mounting->child_frame != mounting.child_frame) {
    Transform sent = mounting;
    sent.stamp = stamp;
    CDFF_RETURN_IF_ERROR(s.orchestrator->process(
        dfpc::Message::of(tof ? kTofMounting : kLeftMounting, stamp, sent)));
    s.mounting = mounting;
  }
  if (tof) {
    DepthMap depth = view.depth;
    depth.image.stamp = stamp;
    CDFF_RETURN_IF_ERROR(
        s.orchestrator->process(dfpc::Message::of(kTofDepth, stamp, std::move(depth))));
  } else {
    StereoImagePair pair = view.pair;
    pair.left.stamp = pair.right.stamp = pair.right_T_left.stamp = stamp;
    CDFF_RETURN_IF_ERROR(s.orchestrator->process(dfpc::Message::of(kPair, stamp, std::move(pair))));
  }

  const auto at = [&](const std::string& output) -> std::optional<dfpc::Message> {
    for (const dfpc::Message& m : s.products.messages(s.product_prefix + output))
      if (m.stamp == stamp) return m;
    return std::nullopt;
  };
  DetectionOutcome out;
  const auto number = [&](const std::string& output) {
    const std::optional<dfpc::Message> m = at(output);
    const double* v = m ? m->as<double>() : nullptr;
    return v ? *v : std::nan("");
  };
  if (const std::optional<dfpc::Message> d = at("detected"); d && d->as<bool>())
    out.detected = *d->as<bool>();
  out.fitness = number("fitness");
  out.confirmed = number("confirmed");
  out.misfit = number("misfit");
  out.rival_margin = number("rival_margin");
  out.inlier_ratio = number("inlier_ratio");
  if (const std::optional<dfpc::Message> a = at("alternatives"); a && a->as<int>())
    out.alternatives = *a->as<int>();
  const std::optional<dfpc::Message> camera_pose = at("camera_pose");
  const std::optional<dfpc::Message> pose = at("pose");
  if (out.detected != pose.has_value() ||
      (s.has_camera_pose && out.detected != camera_pose.has_value()))
    return Status(StatusCode::kInternal,
                  fmt::format("frame at {} us: detected is {} but the DFPC published {} pose and "
                              "{} camera pose",
                              stamp, out.detected, pose ? "a" : "no", camera_pose ? "a" : "no"));
  if (out.detected) {
    out.pose = *pose->as<RigidBodyState>();
    out.camera_pose =
        s.has_camera_pose ? *camera_pose->as<PoseWithCovariance>() : out.pose.poseWithCovariance();
    const Transform& truth = s.has_camera_pose ? view.camera_truth : view.truth;
    out.position_error = (out.camera_pose.pose.translation - truth.translation).norm();
    out.angle_error = angularDistance(out.camera_pose.pose.rotation, truth.rotation);
    out.nees = eval::poseNees(out.camera_pose.pose, truth, out.camera_pose.covariance);
  }
  std::map<std::string, double> per_node;
  for (const dfpc::MemorySink::Timing& t : s.products.timings()) {
    if (t.stamp != stamp) continue;
    if (t.status != StatusCode::kOk) ++out.dfn_errors;
    out.cpu_s += t.cpu_s;
    per_node[t.instance] += t.cpu_s;
  }
  out.node_cpu_s.assign(per_node.begin(), per_node.end());
  if (out.dfn_errors > 0) {
    const std::vector<dfpc::DfpcStatus> statuses = s.orchestrator->statuses();
    if (!statuses.empty()) out.fault = statuses.front().last_fault;
  }
  return out;
}

}  // namespace cdff::detection_demo
