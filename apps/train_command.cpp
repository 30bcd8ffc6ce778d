// cdff train MODEL -o TEMPLATES: LINEMOD templates of a target model for the detection
// (TemplateDetection/Linemod). MODEL is a mesh file or a scenario (its target); the camera is a
// scenario's camera (its intrinsics without distortion: the detection matches rectified
// images). At the end the templates are checked on views they were not trained on: random
// attitudes, ranges and sun directions, rendered with their depth.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>

#include <unistd.h>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "PoseRefinement.gen.hpp"
#include "StereoRectification.gen.hpp"
#include "TemplateDetection.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/egse/range_sensors.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/opencv.hpp"
#include "commands.hpp"
#include "linemod_training.hpp"
#include "model_source.hpp"

namespace cdff::app {

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;
/// Detections output by the check's TemplateDetection, all of them refined.
constexpr int kCheckedDetections = 10;

struct TrainOptions {
  std::string source;
  std::vector<std::string> overrides;
  std::string output;
  std::string camera_scenario;  // "": the source when it is a scenario, else mid_range_approach
  std::string sensor = "camera_left";
  std::string
      rectified_with;  // "": the camera itself; else the stereo partner it is rectified with
  double view_step = 15, in_plane_step = 15;  // deg
  std::vector<double> ranges;
  int pyramid_level = -1;
  int threads = 0;
  int check_views = 50;
  std::uint64_t check_seed = 20261205;
};

/// The camera (or, with `tof_allowed`, ToF camera) `name` of `scenario`, an error naming the
/// scenario when it has none.
Result<const egse::SensorConfig*> cameraOf(const egse::Scenario& scenario,
                                           const std::string& scenario_name,
                                           const std::string& name, const char* option,
                                           bool tof_allowed) {
  const egse::SensorConfig* sensor = scenario.sensor(name);
  if (!sensor || !(sensor->type == egse::SensorType::kCamera ||
                   (tof_allowed && sensor->type == egse::SensorType::kTof)))
    return notFound("scenario '{}' has no {} '{}'; expected {} naming one of its cameras{}",
                    scenario_name, tof_allowed ? "camera or ToF camera" : "camera", name, option,
                    tof_allowed ? " or its ToF camera" : "");
  return sensor;
}

/// The camera the templates are trained for: an image camera, or a ToF camera, which gives a
/// depth and no image (its templates are matched on their depth normals alone).
struct TrainingCamera {
  CameraModel model;
  bool depth_only = false;
  double max_range = 0;  // m, a ToF camera's: nothing beyond is measured (0: no limit)
};

/// The left camera of the pair (`left`, `right`) as StereoRectification/OpenCV (its defaults)
/// rectifies it: the camera the detection's images have in a stereo graph.
Result<CameraModel> rectifiedCamera(const egse::SensorConfig& left,
                                    const egse::SensorConfig& right) {
  Result<std::unique_ptr<dfn::StereoRectification>> dfn =
      dfn::Registry::instance().createAs<dfn::StereoRectification>("StereoRectification", "OpenCV");
  if (!dfn) return dfn.status();
  CDFF_RETURN_IF_ERROR((*dfn)->configure(YAML::Load("{}")));
  StereoImagePair pair;
  for (auto [image, sensor] : {std::pair{&pair.left, &left}, std::pair{&pair.right, &right}}) {
    const CameraModel& m = sensor->camera.model;
    Result<Image> black = fromMat(cv::Mat::zeros(m.height, m.width, CV_8UC1), 0, sensor->frame());
    if (!black) return black.status();
    *image = *black;
    image->camera = m;
  }
  pair.right_T_left = Transform::fromIsometry(
      right.servicerTframe().inverse() * left.servicerTframe(), right.frame(), left.frame(), 0);
  (*dfn)->in.stereo.set(pair);
  CDFF_RETURN_IF_ERROR((*dfn)->process().withContext(
      fmt::format("rectifying the pair ({}, {})", left.name, right.name)));
  return *(*dfn)->out.rectified->left.camera;
}

Result<TrainingCamera> trainingCamera(const TrainOptions& o) {
  const std::string name = !o.camera_scenario.empty() ? o.camera_scenario
                           : isMeshFile(o.source)     ? std::string("mid_range_approach")
                                                      : o.source;
  Result<std::filesystem::path> path = egse::resolveScenario(name);
  if (!path) return path.status();
  Result<egse::Scenario> scenario =
      egse::loadScenario(*path, isMeshFile(o.source) ? std::vector<std::string>{} : o.overrides);
  if (!scenario) return scenario.status();
  Result<const egse::SensorConfig*> sensor =
      cameraOf(*scenario, name, o.sensor, "--sensor", o.rectified_with.empty());
  if (!sensor) return sensor.status();
  if (!o.rectified_with.empty()) {
    Result<const egse::SensorConfig*> partner =
        cameraOf(*scenario, name, o.rectified_with, "--rectified-with", false);
    if (!partner) return partner.status();
    Result<CameraModel> rectified = rectifiedCamera(**sensor, **partner);
    if (!rectified) return rectified.status();
    return TrainingCamera{*rectified};
  }
  TrainingCamera camera;
  if ((*sensor)->type == egse::SensorType::kTof) {
    camera.model = (*sensor)->tof.model;
    camera.depth_only = true;
    camera.max_range = (*sensor)->tof.max_range;
  } else {
    camera.model = (*sensor)->camera.model;
  }
  camera.model.distortion_model = DistortionModel::kNone;
  camera.model.distortion.clear();
  return camera;
}

/// A bar on a terminal; otherwise one line per tenth (logs stay short).
void progressBar(int done, int total) {
  static const bool terminal = isatty(fileno(stderr)) != 0;
  if (!terminal) {
    if (done == total || (10 * done / total) != (10 * (done - 1) / total))
      fmt::print(stderr, "{}/{} views\n", done, total);
    return;
  }
  static auto last = std::chrono::steady_clock::now();
  const auto now = std::chrono::steady_clock::now();
  if (done != total && now - last < std::chrono::milliseconds(200)) return;
  last = now;
  const int width = 40;
  const int filled = static_cast<int>(static_cast<long long>(width) * done / total);
  fmt::print(stderr, "\r[{}{}] {:3d}% {}/{} views", std::string(filled, '#'),
             std::string(width - filled, '.'), 100 * done / total, done, total);
  if (done == total) fmt::print(stderr, "\n");
}

struct CheckFigures {
  int views = 0, detected = 0, correct = 0;
  int correct_among_output = 0;  // a correct one among every detection output (max_detections)
  int refined_correct = 0;       // within 2 deg and 1 % of the range after the refinement
  std::vector<double> angle_errors, range_errors;
  double seconds = 0, refinement_seconds = 0;
};

/// The errors of camera_T_object `pose`: angle (deg) and distance of the bounding centres as a
/// fraction of the range.
std::pair<double, double> errorsOf(const Eigen::Isometry3d& pose, const Eigen::Isometry3d& truth,
                                   const egse::TargetModel& model) {
  const Eigen::Vector3d centre = truth * model.boundingCentre();
  return {Eigen::AngleAxisd(pose.linear().transpose() * truth.linear()).angle() / kDeg,
          ((pose * model.boundingCentre()) - centre).norm() / centre.norm()};
}

/// Counts the detections of one view into `f`: the best one's errors and correctness, and
/// whether any output one is correct.
void countDetections(const Detections& detections, const Eigen::Isometry3d& truth,
                     const egse::TargetModel& model, CheckFigures& f) {
  bool any = false;
  for (const Detection& d : detections.detections) {
    const auto [angle, range_error] = errorsOf(d.pose.isometry(), truth, model);
    const bool correct = angle <= 15 && range_error <= 0.1;
    if (&d == &detections.detections.front()) {
      f.angle_errors.push_back(angle);
      f.range_errors.push_back(range_error);
      f.correct += correct;
    }
    any = any || correct;
  }
  f.correct_among_output += any;
}

/// The refinement of the checked detections: PoseRefinement/DepthIcp on the rendered depth, set
/// as for a ToF camera (a depth wherever the target is; the noise of egse::TofSpec's defaults).
struct Refinement {
  std::unique_ptr<dfn::PoseRefinement> dfn;
  PointCloud model;
};

Result<Refinement> makeRefinement(const egse::TargetModel& model) {
  Result<std::unique_ptr<dfn::PoseRefinement>> dfn =
      dfn::Registry::instance().createAs<dfn::PoseRefinement>("PoseRefinement", "DepthIcp");
  if (!dfn) return dfn.status();
  const egse::TofSpec tof;
  CDFF_RETURN_IF_ERROR((*dfn)->configure(YAML::Load(
      fmt::format("{{missing_depth_cost: 9, depth_noise_constant: {}, depth_noise_quadratic: {}, "
                  "candidates: {}}}",
                  tof.noise_constant, tof.noise_quadratic, kCheckedDetections))));
  // A point every 2 cm: finer than the matching resolution's pixels at the trained ranges.
  const auto points = static_cast<std::size_t>(model.surfaceArea() / (0.02 * 0.02));
  Result<PointCloud> cloud = sampleSurface(model.mesh, points, 7);
  if (!cloud) return cloud.status();
  return Refinement{std::move(dfn).value(), std::move(cloud).value()};
}

/// Detects on views the templates were not trained on (random attitude, range log-uniform
/// over the trained ones, centre within the middle half of the image, sun anywhere behind the
/// camera's plane) with their rendered depth (`depth_only`: the depth without the image, as a
/// ToF camera gives it).
Result<CheckFigures> check(const egse::TargetModel& model,
                           const linemod_templates::TemplateSet& set, const std::string& file,
                           int views, std::uint64_t seed, bool depth_only) {
  Result<std::unique_ptr<dfn::TemplateDetection>> dfn =
      dfn::Registry::instance().createAs<dfn::TemplateDetection>("TemplateDetection", "Linemod");
  if (!dfn) return dfn.status();
  CDFF_RETURN_IF_ERROR((*dfn)->configure(YAML::Load(
      fmt::format("{{template_file: '{}', max_detections: {}}}", file, kCheckedDetections))));
  Result<Refinement> refinement = makeRefinement(model);
  if (!refinement) return refinement.status();
  std::mt19937 rng(static_cast<std::mt19937::result_type>(seed));
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0, 1);
  CheckFigures f;
  const CameraModel camera = set.matchingCamera();
  Result<linemod_templates::ViewRenderer> renderer = linemod_templates::ViewRenderer::create(
      model, set.camera, set.pyramid_level, egse::RendererBackend::kCpu, -Eigen::Vector3d::UnitZ());
  if (!renderer) return renderer.status();
  for (int i = 0; i < views; ++i) {
    renderer->setSunDirection(Eigen::Vector3d(g(rng), g(rng), -std::abs(g(rng)) - 0.3));
    const double range =
        set.ranges.front() * std::pow(set.ranges.back() / set.ranges.front(), u(rng));
    const Eigen::Vector3d centre((u(rng) - 0.5) * 0.5 * camera.width / camera.fx * range,
                                 (u(rng) - 0.5) * 0.5 * camera.height / camera.fy * range, range);
    Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
    truth.linear() =
        Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    truth.translation() = centre - truth.linear() * model.boundingCentre();
    Result<linemod_templates::RenderedView> view = renderer->render(truth);
    if (!view) return view.status();
    Result<Image> image = fromMat(view->image.clone(), 0, "camera");
    if (!image) return image.status();
    image->camera = camera;
    cv::Mat metres;
    view->depth.convertTo(metres, CV_32F, 1e-3);
    DepthMap depth;
    Result<Image> depth_image = fromMat(metres, 0, "camera");
    if (!depth_image) return depth_image.status();
    depth.image = *depth_image;
    depth.image.camera = camera;
    if (!depth_only) (*dfn)->in.image.set(*image);
    (*dfn)->in.depth.set(depth);
    const auto t0 = std::chrono::steady_clock::now();
    CDFF_RETURN_IF_ERROR((*dfn)->process());
    f.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ++f.views;
    if (!*(*dfn)->out.detected) continue;
    ++f.detected;
    countDetections(*(*dfn)->out.detections, truth, model, f);
    refinement->dfn->in.detections.set(*(*dfn)->out.detections);
    refinement->dfn->in.depth.set(depth);
    refinement->dfn->in.model.set(refinement->model);
    const auto t1 = std::chrono::steady_clock::now();
    CDFF_RETURN_IF_ERROR(refinement->dfn->process());
    f.refinement_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    if (!refinement->dfn->out.pose.hasValue()) continue;
    const auto [angle, range_error] =
        errorsOf(refinement->dfn->out.pose->pose.isometry(), truth, model);
    f.refined_correct += angle <= 2 && range_error <= 0.01;
  }
  return f;
}

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// The output's folder is created, and the file opened for writing, before the training (minutes)
// rather than after it: a path that cannot be written fails at once.
Status checkWritable(const std::string& output) {
  const std::filesystem::path path(output);
  std::error_code error;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), error);
  if (error)
    return invalidInput("cannot create the folder '{}' of --output: {}",
                        path.parent_path().string(), error.message());
  const bool existed = std::filesystem::exists(path);
  if (!std::ofstream(path, std::ios::app))
    return invalidInput("cannot write --output '{}'; expected a writable path", output);
  if (!existed) std::filesystem::remove(path, error);
  return Status::ok();
}

int runTrain(const TrainOptions& o) {
  if (Status s = checkWritable(o.output); !s) {
    fmt::print(stderr, "error: cdff train: {}\n", s.message());
    return 1;
  }
  Result<egse::TargetModel> model = loadModelSource(o.source, o.overrides);
  if (!model) {
    fmt::print(stderr, "error: cdff train {}: {}\n", o.source, model.status().message());
    return 1;
  }
  Result<TrainingCamera> training_camera = trainingCamera(o);
  if (!training_camera) {
    fmt::print(stderr, "error: cdff train: {}\n", training_camera.status().message());
    return 1;
  }
  const CameraModel* camera = &training_camera->model;
  linemod_templates::TrainingOptions options =
      linemod_templates::defaultTrainingOptions(*model, *camera);
  if (training_camera->max_range > 0) {
    // A ToF camera measures nothing beyond its maximum range: the classes whose ranges lie
    // wholly beyond it would never be searched.
    const double half_step = std::sqrt(1.25);
    std::erase_if(options.ranges,
                  [&](double r) { return r / half_step > training_camera->max_range; });
    if (options.ranges.empty()) {
      fmt::print(stderr,
                 "error: cdff train: every default range of model '{}' lies beyond the ToF "
                 "camera's maximum range {} m; expected --ranges within it\n",
                 model->name, training_camera->max_range);
      return 1;
    }
    options.settings.normal_distance_threshold =
        static_cast<int>(std::ceil((options.ranges.back() + 2 * model->boundingRadius()) * 1000.0));
  }
  options.view_step = o.view_step * kDeg;
  options.in_plane_step = o.in_plane_step * kDeg;
  if (!o.ranges.empty()) options.ranges = o.ranges;
  if (o.pyramid_level >= 0) options.pyramid_level = o.pyramid_level;
  options.threads = o.threads;
  fmt::print(
      "model '{}' (radius {:.2f} m), camera {}x{} fx {:.1f} cx {:.1f} cy {:.1f}{}, matching at "
      "pyramid level {}\n",
      model->name, model->boundingRadius(), camera->width, camera->height, camera->fx, camera->cx,
      camera->cy,
      !o.rectified_with.empty()     ? " (rectified with " + o.rectified_with + ")"
      : training_camera->depth_only ? std::string(" (a ToF camera: matched on its depth alone)")
                                    : std::string(),
      options.pyramid_level);
  fmt::print("ranges (m):");
  for (double r : options.ranges) fmt::print(" {:.2f}", r);
  fmt::print("; view step {} deg, in-plane step {} deg\n", o.view_step, o.in_plane_step);
  std::fflush(stdout);
  const auto t0 = std::chrono::steady_clock::now();
  int skipped = 0;
  Result<linemod_templates::TemplateSet> set =
      linemod_templates::trainTemplates(*model, *camera, options, progressBar, &skipped);
  if (!set) {
    fmt::print(stderr, "error: cdff train: {}\n", set.status().message());
    return 1;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (Status s = linemod_templates::writeTemplateSet(*set, o.output); !s) {
    fmt::print(stderr, "error: cdff train: {}\n", s.message());
    return 1;
  }
  fmt::print(
      "wrote {}: {} templates ({} views gave none: too few edge features), mesh hash {}, "
      "trained in {:.1f} s\n",
      o.output, set->templates.size(), skipped, set->mesh_hash, seconds);
  if (o.check_views <= 0) return 0;
  Result<CheckFigures> f =
      check(*model, *set, o.output, o.check_views, o.check_seed, training_camera->depth_only);
  if (!f) {
    fmt::print(stderr, "error: cdff train: checking the templates: {}\n", f.status().message());
    return 1;
  }
  fmt::print(
      "check on {} untrained views with depth: detected {} ({:.0f} %), correct (15 deg, 10 % of "
      "the range) {} ({:.0f} %), a correct one among the (up to {}) detections {} ({:.0f} %); "
      "median errors {:.1f} deg, {:.1f} % of the range; {:.1f} ms per view\n"
      "after PoseRefinement/DepthIcp on the depth: within 2 deg and 1 % of the range {} ({:.0f} "
      "%), {:.1f} ms per detected view\n",
      f->views, f->detected, 100.0 * f->detected / f->views, f->correct,
      100.0 * f->correct / f->views, kCheckedDetections, f->correct_among_output,
      100.0 * f->correct_among_output / f->views, median(f->angle_errors),
      100 * median(f->range_errors), 1e3 * f->seconds / f->views, f->refined_correct,
      100.0 * f->refined_correct / f->views,
      1e3 * f->refinement_seconds / std::max(1, f->detected));
  return 0;
}

}  // namespace

void addTrainCommand(CLI::App& root, int& exit_code) {
  auto o = std::make_shared<TrainOptions>();
  CLI::App* train = root.add_subcommand(
      "train", "Train the detection's LINEMOD templates from a target model (TemplateDetection)");
  train
      ->add_option("MODEL", o->source,
                   "A mesh file (OBJ, PLY, STL, glTF) or a scenario (library name or YAML file: "
                   "its target)")
      ->required();
  train->add_option("-o,--output", o->output, "The template file to write (.yml.gz)")->required();
  train->add_option("--set", o->overrides, "Override a scenario key (as cdff sim --set)");
  train->add_option("--camera", o->camera_scenario,
                    "The scenario whose camera the templates are for (default: MODEL when it is a "
                    "scenario, else mid_range_approach)");
  train
      ->add_option("--sensor", o->sensor,
                   "The camera's name in that scenario, or its ToF camera's (templates matched "
                   "on the depth alone)")
      ->default_str("camera_left");
  train->add_option("--rectified-with", o->rectified_with,
                    "Train for the --sensor camera as StereoRectification rectifies it with this "
                    "stereo partner (the detection's images in a stereo graph); default: the "
                    "camera without its distortion");
  train->add_option("--view-step", o->view_step, "Degrees between neighbouring view directions")
      ->check(CLI::Range(1.0, 90.0))
      ->default_str("15");
  train->add_option("--in-plane-step", o->in_plane_step, "Degrees between in-plane rotations")
      ->check(CLI::Range(1.0, 180.0))
      ->default_str("15");
  train
      ->add_option("--ranges", o->ranges,
                   "Training ranges in metres (default: from the camera and the model's size)")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  train
      ->add_option("--pyramid-level", o->pyramid_level,
                   "Times the camera's images are halved before matching (default: until at "
                   "most 640 px wide)")
      ->check(CLI::Range(0, 6));
  train->add_option("--threads", o->threads, "Rendering threads (default: every core)")
      ->check(CLI::NonNegativeNumber);
  train
      ->add_option("--check", o->check_views,
                   "Untrained views to check the templates on at the end (0: none)")
      ->check(CLI::NonNegativeNumber)
      ->default_str("50");
  train
      ->add_option("--check-seed", o->check_seed,
                   "Seed of the checked views (their attitudes, ranges and sun directions)")
      ->default_str("20261205");
  train->callback([o, &exit_code] { exit_code = runTrain(*o); });
}

}  // namespace cdff::app
