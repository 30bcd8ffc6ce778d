#include "linemod_training.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <thread>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "cdff/egse/camera_sensor.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::linemod_templates {

namespace {

constexpr double kPi = 3.14159265358979323846;
/// A view covering fewer matching pixels makes no template (LINEMOD needs 63 scattered edge
/// features on it).
constexpr int kMinimumViewPixels = 200;

double median(std::vector<float>& values) {
  if (values.empty()) return 0.0;
  auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// One view to train, and what it gave.
struct TrainingItem {
  int range_index = 0, view_index = 0, in_plane_index = 0;
  bool ok = false;
  std::vector<cv::linemod::Template> pyramid;
  TemplateView view;
};

/// The part of a view that LINEMOD needs to extract the template of the object in `mask`: its
/// bounding box widened by kCropMargin pixels (more than the 7x7 blur, the gradient's hysteresis,
/// the normals' window and two pyramid levels reach), its corner on a multiple of kCropAlignment
/// so that every pyramid level downsamples the same pixels, clipped to the view.
constexpr int kCropMargin = 32;
constexpr int kCropAlignment = 16;

cv::Rect templateCrop(const cv::Mat& mask) {
  const cv::Rect object = cv::boundingRect(mask);
  const int x0 = std::max(0, (object.x - kCropMargin) / kCropAlignment * kCropAlignment);
  const int y0 = std::max(0, (object.y - kCropMargin) / kCropAlignment * kCropAlignment);
  const int x1 = std::min(mask.cols, object.br().x + kCropMargin);
  const int y1 = std::min(mask.rows, object.br().y + kCropMargin);
  return {x0, y0, x1 - x0, y1 - y0};
}

/// What the training threads share (read-only but for the progress count).
struct TrainingShared {
  const TrainingOptions& options;
  const std::vector<Eigen::Vector3d>& directions;
  Eigen::Vector3d centre;
  double in_plane_step;
  const TrainingProgress& progress;
  int total;
  std::atomic<int> done{0};
  std::mutex progress_mutex;
};

/// Renders and extracts items [begin, end) with the thread's own renderer and detector.
Status trainShare(ViewRenderer& views, TrainingShared& shared, int begin, int end,
                  std::vector<TrainingItem>& items) {
  const CameraModel& matching = views.matchingCamera();
  cv::Ptr<cv::linemod::Detector> detector = createDetector(shared.options.settings, true);
  std::vector<float> depths;
  for (int i = begin; i < end; ++i) {
    TrainingItem& item = items[static_cast<std::size_t>(i)];
    const double range = shared.options.ranges[static_cast<std::size_t>(item.range_index)];
    const Eigen::Isometry3d pose =
        viewPose(shared.centre, shared.directions[static_cast<std::size_t>(item.view_index)],
                 item.in_plane_index * shared.in_plane_step, range);
    Result<RenderedView> view = views.render(pose);
    if (!view) return view.status();
    if (shared.progress) {
      const int n = ++shared.done;
      std::lock_guard<std::mutex> lock(shared.progress_mutex);
      shared.progress(n, shared.total);
    }
    if (cv::countNonZero(view->mask) < kMinimumViewPixels) continue;
    // LINEMOD extracts a template from the whole image it is given (eight distance transforms
    // of it for the normals alone), so it is given the view's bounding box with a margin: the
    // blur, gradient, normal and pyramid windows then see the same pixels as in the full image
    // (the margin is wider than they reach and the crop starts on the coarsest level's grid),
    // and the template is the same, its box moved back by the crop's corner.
    const cv::Rect crop = templateCrop(view->mask);
    cv::Rect box;
    // (LINEMOD reads its images as continuous rows: the crops are copied.)
    const int id =
        detector->addTemplate({asColour(view->image(crop).clone()), view->depth(crop).clone()},
                              "view", view->mask(crop).clone(), &box);
    if (id < 0) continue;
    box += crop.tl();
    depths.clear();
    for (int r = 0; r < view->depth.rows; ++r)
      for (int c = 0; c < view->depth.cols; ++c)
        if (const std::uint16_t z = view->depth.at<std::uint16_t>(r, c); z > 0)
          depths.push_back(z * 1e-3f);
    item.ok = true;
    item.pyramid = detector->getTemplates("view", id);
    TemplateView& t = item.view;
    t.range_index = item.range_index;
    t.view_index = item.view_index;
    t.in_plane_index = item.in_plane_index;
    t.camera_T_object = pose;
    t.range = range;
    t.centre_offset = Eigen::Vector2d(matching.cx - box.x, matching.cy - box.y);
    t.surface_depth_offset = median(depths) - range;
    t.width = box.width;
    t.height = box.height;
  }
  return Status::ok();
}

/// The model's surface points with normals, for the detector's depth check.
Status addModelPoints(const egse::TargetModel& model, int count, TemplateSet& set) {
  Result<PointCloud> points = sampleSurface(
      model.mesh, static_cast<std::size_t>(std::max(1, count)), 1, SampleNormals::kFace);
  if (!points) return points.status().withContext("sampling the model's surface");
  for (std::size_t i = 0; i < points->size(); ++i) {
    const Point4f& p = points->points[i];
    const Point4f& n = points->normals[i];
    set.model_points.emplace_back(p.x, p.y, p.z);
    set.model_normals.emplace_back(n.x, n.y, n.z);
  }
  return Status::ok();
}

Status checkOptions(const TrainingOptions& options) {
  if (options.ranges.empty())
    return invalidParameter("no training range given; expected at least one range in metres");
  for (double r : options.ranges)
    if (!(r > 0) || !std::isfinite(r))
      return invalidParameter("training range {} m; expected a positive range", r);
  if (!(options.view_step > 0) || !(options.in_plane_step > 0))
    return invalidParameter("view step {} rad, in-plane step {} rad; expected both positive",
                            options.view_step, options.in_plane_step);
  if (options.pyramid_level < 0 || options.pyramid_level > 6)
    return invalidParameter("pyramid level {}; expected 0-6", options.pyramid_level);
  return Status::ok();
}

}  // namespace

std::vector<double> geometricRanges(double nearest, double farthest, double ratio) {
  std::vector<double> ranges;
  if (!(nearest > 0) || !(farthest >= nearest) || !(ratio > 1)) return ranges;
  for (double r = nearest; ranges.empty() || ranges.back() < farthest * (1 - 1e-9); r *= ratio)
    ranges.push_back(r);
  return ranges;
}

TrainingOptions defaultTrainingOptions(const egse::TargetModel& model, const CameraModel& camera) {
  TrainingOptions o;
  int level = 0;
  for (int width = camera.width; width > 640; width = (width + 1) / 2) ++level;
  o.pyramid_level = level;
  const double radius = model.boundingRadius();
  const double fx = camera.fx;
  const double shorter_side = std::min(camera.width, camera.height);
  const double nearest = 2 * radius * fx / (2.5 * shorter_side);
  const double farthest = 2 * radius * (fx / std::pow(2.0, level)) / 96.0;
  o.ranges = geometricRanges(nearest, std::max(farthest, nearest), 1.25);
  // Depths beyond the farthest surface are not the target.
  o.settings.normal_distance_threshold =
      static_cast<int>(std::ceil((o.ranges.back() + 2 * radius) * 1000.0));
  return o;
}

std::vector<Eigen::Vector3d> viewSphere(double step) {
  const double area_per_view = std::sqrt(3.0) / 2 * step * step;
  const int n = std::max(1, static_cast<int>(std::lround(4 * kPi / area_per_view)));
  std::vector<Eigen::Vector3d> directions;
  directions.reserve(static_cast<std::size_t>(n));
  const double golden_angle = kPi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * i;
    directions.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return directions;
}

Eigen::Isometry3d viewPose(const Eigen::Vector3d& centre, const Eigen::Vector3d& direction,
                           double in_plane, double range) {
  const Eigen::Vector3d z = -direction.normalized();  // the optical axis, object frame
  const Eigen::Vector3d helper =
      std::abs(z.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d x0 = helper.cross(z).normalized();
  const Eigen::Vector3d y0 = z.cross(x0);
  const Eigen::Vector3d x = std::cos(in_plane) * x0 + std::sin(in_plane) * y0;
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d object_R_camera;
  object_R_camera << x, y, z;
  Eigen::Isometry3d camera_T_object = Eigen::Isometry3d::Identity();
  camera_T_object.linear() = object_R_camera.transpose();
  const Eigen::Vector3d camera_position = centre + range * direction.normalized();
  camera_T_object.translation() = -(object_R_camera.transpose() * camera_position);
  return camera_T_object;
}

Result<ViewRenderer> ViewRenderer::create(const egse::TargetModel& model, const CameraModel& camera,
                                          int pyramid_level, egse::RendererBackend backend,
                                          const Eigen::Vector3d& sun_direction) {
  Result<std::unique_ptr<egse::Renderer>> renderer = egse::createRenderer(backend);
  if (!renderer) return renderer.status();
  ViewRenderer v;
  v.renderer_ = std::move(*renderer);
  Result<int> handle = v.renderer_->addModel(model);
  if (!handle) return handle.status().withContext(fmt::format("model '{}'", model.name));
  v.model_ = *handle;
  v.matching_ = cameraAfterPyrDown(camera, pyramid_level);
  v.canvas_.width = 2 * v.matching_.width;
  v.canvas_.height = 2 * v.matching_.height;
  v.canvas_.fx = 2 * v.matching_.fx;
  v.canvas_.fy = 2 * v.matching_.fy;
  v.canvas_.cx = 2 * v.matching_.cx;
  v.canvas_.cy = 2 * v.matching_.cy;
  v.sun_direction_ = sun_direction.normalized();
  return v;
}

Result<RenderedView> ViewRenderer::render(const Eigen::Isometry3d& camera_T_object) {
  egse::RenderScene scene;
  egse::RenderObject object;
  object.model = model_;
  object.camera_T_object = camera_T_object;
  scene.objects.push_back(object);
  scene.sun_direction = sun_direction_;
  scene.shadows = true;
  CDFF_RETURN_IF_ERROR(renderer_->render(scene, canvas_, output_));
  // The simulated camera's response (egse::CameraSpec): radiance 1 gives
  // sensitivity * exposure / full well of the 8-bit range.
  const egse::CameraSpec spec;
  const float gain =
      static_cast<float>(255.0 * spec.sensitivity * spec.exposure_time / spec.full_well);
  cv::Mat canvas(canvas_.height, canvas_.width, CV_8UC1);
  for (int r = 0; r < canvas.rows; ++r) {
    std::uint8_t* row = canvas.ptr<std::uint8_t>(r);
    for (int c = 0; c < canvas.cols; ++c) {
      const float* rgb = &output_.radiance[3 * (static_cast<std::size_t>(r) * canvas.cols + c)];
      const float luminance = 0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2];
      row[c] = cv::saturate_cast<std::uint8_t>(gain * luminance);
    }
  }
  RenderedView view;
  cv::pyrDown(canvas, view.image);
  view.depth = cv::Mat::zeros(matching_.height, matching_.width, CV_16UC1);
  view.mask = cv::Mat::zeros(matching_.height, matching_.width, CV_8UC1);
  for (int r = 0; r < matching_.height; ++r)
    for (int c = 0; c < matching_.width; ++c) {
      const float z = output_.depth[static_cast<std::size_t>(2 * r) * canvas_.width + 2 * c];
      if (std::isfinite(z) && z > 0 && z < 65.0f) {
        view.depth.at<std::uint16_t>(r, c) = static_cast<std::uint16_t>(std::lround(z * 1000));
        view.mask.at<std::uint8_t>(r, c) = 255;
      }
    }
  return view;
}

Result<TemplateSet> trainTemplates(const egse::TargetModel& model, const CameraModel& camera,
                                   const TrainingOptions& options, const TrainingProgress& progress,
                                   int* skipped) {
  CDFF_RETURN_IF_ERROR(camera.validate().withContext("training camera"));
  CDFF_RETURN_IF_ERROR(checkOptions(options));
  Result<ViewRenderer> renderer = ViewRenderer::create(model, camera, options.pyramid_level,
                                                       options.renderer, options.sun_direction);
  if (!renderer) return renderer.status();

  TemplateSet set;
  set.model_name = model.name;
  set.mesh_hash = meshHash(model.mesh);
  set.camera = camera;
  set.camera.distortion_model = DistortionModel::kNone;
  set.camera.distortion.clear();
  set.pyramid_level = options.pyramid_level;
  set.settings = options.settings;
  set.ranges = options.ranges;
  const std::vector<Eigen::Vector3d> directions = viewSphere(options.view_step);
  const int rotations = std::max(1, static_cast<int>(std::lround(2 * kPi / options.in_plane_step)));
  set.views = static_cast<int>(directions.size());
  set.in_plane_rotations = rotations;
  set.view_step = options.view_step;
  set.in_plane_step = 2 * kPi / rotations;
  set.detector = createDetector(options.settings, true);

  // The work items in (range, view, rotation) order; each thread trains a contiguous share
  // into its own detector, and the templates are then added to the set in that order.
  std::vector<TrainingItem> items;
  for (std::size_t ri = 0; ri < options.ranges.size(); ++ri)
    for (std::size_t vi = 0; vi < directions.size(); ++vi)
      for (int k = 0; k < rotations; ++k)
        items.push_back({static_cast<int>(ri), static_cast<int>(vi), k, false, {}, {}});
  const int total = static_cast<int>(items.size());
  const int threads = std::clamp(
      options.threads > 0 ? options.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())),
      1, std::max(1, total));
  TrainingShared shared{options,           directions, model.boundingCentre(),
                        set.in_plane_step, progress,   total};
  std::vector<Status> failures(static_cast<std::size_t>(threads));
  auto work = [&](int thread, ViewRenderer& views) {
    failures[static_cast<std::size_t>(thread)] =
        trainShare(views, shared, thread * total / threads, (thread + 1) * total / threads, items);
  };
  std::vector<ViewRenderer> renderers;
  renderers.push_back(std::move(renderer).value());
  for (int t = 1; t < threads; ++t) {
    Result<ViewRenderer> r = ViewRenderer::create(model, camera, options.pyramid_level,
                                                  options.renderer, options.sun_direction);
    if (!r) return r.status();
    renderers.push_back(std::move(r).value());
  }
  {
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t)
      pool.emplace_back(work, t, std::ref(renderers[static_cast<std::size_t>(t)]));
    work(0, renderers[0]);
    for (std::thread& t : pool) t.join();
  }
  for (const Status& failure : failures) CDFF_RETURN_IF_ERROR(failure);
  int skipped_views = 0;
  for (TrainingItem& item : items) {
    if (!item.ok) {
      ++skipped_views;
      continue;
    }
    TemplateView t = std::move(item.view);
    t.class_id = fmt::format("range_{}", item.range_index);
    t.template_id = set.detector->addSyntheticTemplate(item.pyramid, t.class_id);
    set.templates.push_back(std::move(t));
  }
  set.index();
  CDFF_RETURN_IF_ERROR(addModelPoints(model, options.model_points, set));
  if (skipped) *skipped = skipped_views;
  if (set.templates.empty())
    return invalidInput(
        "model '{}' gave no template: every view covers fewer than {} pixels or too few edges at "
        "the matching resolution; expected ranges at which the model is seen",
        model.name, kMinimumViewPixels);
  return set;
}

}  // namespace cdff::linemod_templates
