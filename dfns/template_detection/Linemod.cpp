#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "TemplateDetection.gen.hpp"
#include "cdff/egse/model_io.hpp"
#include "cdff/types/depth_metres.hpp"
#include "cdff/types/opencv.hpp"
#include "linemod_templates.hpp"

namespace cdff::dfn {

namespace {

using linemod_templates::TemplateSet;
using linemod_templates::TemplateView;

bool near(double a, double b, double tolerance) {
  return std::abs(a - b) <= tolerance;
}

bool sameCamera(const CameraModel& a, const CameraModel& b) {
  return a.width == b.width && a.height == b.height && near(a.fx, b.fx, 1e-3 * b.fx) &&
         near(a.fy, b.fy, 1e-3 * b.fy) && near(a.cx, b.cx, 0.5) && near(a.cy, b.cy, 0.5);
}

std::string describe(const CameraModel& c) {
  return fmt::format("{}x{} px, fx {:.2f}, fy {:.2f}, cx {:.2f}, cy {:.2f}", c.width, c.height,
                     c.fx, c.fy, c.cx, c.cy);
}

/// One pose hypothesis of a match.
struct Hypothesis {
  const TemplateView* view = nullptr;
  cv::linemod::Match match;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  double agreement = std::numeric_limits<double>::quiet_NaN();
  double score = 0;
};

double percentile(std::vector<float>& values, double q) {
  auto at = values.begin() + static_cast<std::ptrdiff_t>(q * (values.size() - 1));
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

}  // namespace

class TemplateDetectionLinemod final : public TemplateDetectionLinemodBase {
 protected:
  Status onConfigure() override {
    set_.reset();
    if (params_.template_file.empty()) return Status::ok();  // said at process(): no templates
    Result<TemplateSet> set = linemod_templates::readTemplateSet(params_.template_file);
    if (!set)
      return Status(set.status().code(), "parameter 'template_file': " + set.status().message());
    if (!params_.model_file.empty()) {
      Result<egse::TargetModel> model = egse::loadModel(params_.model_file);
      if (!model)
        return Status(model.status().code(), "parameter 'model_file': " + model.status().message());
      const std::string hash = linemod_templates::meshHash(model->mesh);
      if (hash != set->mesh_hash)
        return invalidParameter(
            "templates '{}' were trained on a mesh with hash {} (model '{}'), but parameter "
            "'model_file' '{}' has hash {}; expected templates trained on this model (`cdff "
            "train {}`)",
            params_.template_file, set->mesh_hash, set->model_name, params_.model_file, hash,
            params_.model_file);
    }
    if (params_.depth_normals && set->settings.normal_features <= 0)
      return invalidParameter(
          "parameter 'depth_normals' is true but templates '{}' have no depth-normal features; "
          "expected templates trained with depth normals, or depth_normals: false",
          params_.template_file);
    set_ = std::make_shared<TemplateSet>(std::move(set).value());
    gradients_ = linemod_templates::gradientOnlyDetector(*set_);
    normals_ = linemod_templates::normalsOnlyDetector(*set_);
    matching_ = set_->matchingCamera();
    return Status::ok();
  }

  Status onProcess() override {
    if (!set_)
      return invalidParameter(
          "no templates: parameter 'template_file' is empty; expected the file `cdff train` "
          "wrote");
    if (!in.image.hasValue() && !in.depth.hasValue())
      return invalidInput(
          "neither input 'image' nor input 'depth' has a value; expected an image (with or "
          "without its depth), or a depth alone");
    // The frame searched: the image's, or the depth's when there is no image (a ToF camera).
    const Image& frame = in.image.hasValue() ? *in.image : in.depth->image;
    const char* port = in.image.hasValue() ? "input 'image'" : "input 'depth'";
    CDFF_RETURN_IF_ERROR(checkFrameFormat(frame, port));
    Result<int> level = cameraLevel(frame, port);
    if (!level) return level.status();
    const CameraModel matching_grid =
        cameraAfterPyrDown(*frame.camera, set_->pyramid_level - *level);
    const cv::Size size(matching_grid.width, matching_grid.height);

    cv::Mat depth;  // metres, 32FC1, matching grid, NaN where none
    if (in.depth.hasValue()) {
      Result<cv::Mat> d = depthOnMatchingGrid(*in.depth, *frame.camera, size);
      if (!d) return d.status();
      depth = *d;
    }
    if (params_.depth_normals && depth.empty())
      return invalidInput(
          "parameter 'depth_normals' is true but input 'depth' has no value; expected a depth "
          "map with every image");

    std::vector<cv::linemod::Match> matches;
    CDFF_RETURN_IF_ERROR(match(frame, *level, depth, size, matches));

    std::vector<Hypothesis> hypotheses = distinctHypotheses(matches, size);
    if (!depth.empty())
      for (Hypothesis& h : hypotheses) verify(h, depth);
    for (Hypothesis& h : hypotheses)
      h.score = h.match.similarity / 100.0 * (std::isnan(h.agreement) ? 1.0 : h.agreement);
    std::stable_sort(hypotheses.begin(), hypotheses.end(),
                     [](const Hypothesis& a, const Hypothesis& b) { return a.score > b.score; });

    Detections detections;
    detections.stamp = frame.stamp;
    detections.frame_id = frame.frame_id;
    const int scale = 1 << (set_->pyramid_level - *level);
    for (const Hypothesis& h : hypotheses) {
      if (static_cast<int>(detections.detections.size()) >= params_.max_detections) break;
      if (!std::isnan(h.agreement) && h.agreement < params_.min_depth_agreement) continue;
      Detection d;
      d.pose = Transform::fromIsometry(h.pose, frame.frame_id, set_->model_name, frame.stamp);
      d.similarity = std::clamp(h.match.similarity / 100.0, 0.0, 1.0);
      d.depth_agreement = h.agreement;
      d.template_id = fmt::format("{}/{}", h.match.class_id, h.match.template_id);
      d.x = h.match.x * scale;
      d.y = h.match.y * scale;
      d.width = h.view->width * scale;
      d.height = h.view->height * scale;
      detections.detections.push_back(std::move(d));
    }
    out.detected.set(!detections.detections.empty());
    out.detections.set(std::move(detections));
    return Status::ok();
  }

 private:
  /// The frame's pixel format: an 8-bit image, or without one a depth map (then the templates
  /// must have their depth-normal part).
  Status checkFrameFormat(const Image& frame, const char* port) const {
    if (in.image.hasValue()) return frame.validate(port, {PixelFormat::kGray8, PixelFormat::kBgr8});
    CDFF_RETURN_IF_ERROR(frame.validate(port, {PixelFormat::kFloat32, PixelFormat::kGray16}));
    if (!normals_)
      return invalidInput(
          "input 'image' has no value and templates '{}' have no depth-normal features; "
          "expected an image, or templates trained with depth normals (`cdff train`) to match a "
          "depth alone",
          params_.template_file);
    return Status::ok();
  }

  /// LINEMOD's matches in the searched range classes: the image's gradients (and, with
  /// depth_normals, the depth's normals), or without an image the depth's normals alone.
  Status match(const Image& frame, int level, const cv::Mat& depth, cv::Size size,
               std::vector<cv::linemod::Match>& matches) const {
    const cv::Size padded = linemod_templates::matchableSize(size, set_->settings.spreading);
    std::vector<cv::Mat> sources;
    cv::Ptr<cv::linemod::Detector> detector = normals_;
    if (in.image.hasValue()) {
      cv::Mat grey = toMat(frame);
      if (grey.channels() == 3) cv::cvtColor(grey, grey, cv::COLOR_BGR2GRAY);
      grey = pyrDownTimes(grey, set_->pyramid_level - level);
      sources.push_back(linemod_templates::padTo(linemod_templates::asColour(grey), padded));
      detector = params_.depth_normals ? set_->detector : gradients_;
    }
    if (!depth.empty() && detector != gradients_)
      sources.push_back(
          linemod_templates::padTo(linemod_templates::depthMillimetres(depth, size), padded));
    try {
      detector->match(sources, static_cast<float>(params_.similarity_threshold), matches,
                      classesToSearch(depth));
    } catch (const cv::Exception& e) {
      return numericalFailure("LINEMOD matching failed: {}", e.what());
    }
    return Status::ok();
  }

  /// The level in the templates' camera pyramid of `frame` (the image, or the depth without an
  /// image), once its camera model is checked.
  Result<int> cameraLevel(const Image& frame, const char* port) const {
    if (!frame.camera)
      return invalidInput(
          "{} has no camera model; expected the calibrated camera the templates were trained for "
          "({})",
          port, describe(set_->camera));
    if (frame.camera->hasDistortion())
      return invalidInput("{} has lens distortion ({}); expected an undistorted or rectified {}",
                          port, toString(frame.camera->distortion_model),
                          in.image.hasValue() ? "image" : "depth map");
    const CameraModel& camera = *frame.camera;
    for (int l = 0; l <= set_->pyramid_level; ++l)
      if (sameCamera(camera, cameraAfterPyrDown(set_->camera, l))) return l;
    return invalidInput(
        "{} has camera {} but templates '{}' were trained for {} (matched at {}); expected that "
        "camera or one of its cv::pyrDown levels down to the matching one, or templates trained "
        "for this camera (`cdff train`)",
        port, describe(camera), params_.template_file, describe(set_->camera), describe(matching_));
  }

  /// The depth map as metres on the matching grid; it must share the image's field of view.
  Result<cv::Mat> depthOnMatchingGrid(const DepthMap& map, const CameraModel& image_camera,
                                      cv::Size size) const {
    const Image& d = map.image;
    CDFF_RETURN_IF_ERROR(
        d.validate("input 'depth'", {PixelFormat::kFloat32, PixelFormat::kGray16}));
    if (!d.camera)
      return invalidInput(
          "input 'depth' has no camera model; expected the image's camera at any resolution");
    // Same field of view: fx / width and cx / width agree (any pyramid level).
    const double ratio = static_cast<double>(image_camera.width) / d.width;
    if (!near(d.camera->fx * ratio, image_camera.fx, 0.01 * image_camera.fx) ||
        !near((d.camera->cx + 0.5) * ratio, image_camera.cx + 0.5, 0.02 * image_camera.width))
      return invalidInput(
          "input 'depth' has camera {}, which does not cover the image's field of view ({}); "
          "expected a depth map in the image's camera (e.g. StereoMatching's of the rectified "
          "left image)",
          describe(*d.camera), describe(image_camera));
    Result<cv::Mat> metres = depthMetres(map);
    if (!metres)
      return Status(metres.status().code(), "input 'depth': " + metres.status().message());
    cv::Mat resized;
    cv::resize(*metres, resized, size, 0, 0, cv::INTER_NEAREST);
    return resized;
  }

  /// The range classes the measured depths allow: those within range_margin of the 5th-95th
  /// percentile of the depths (the target is the only surface near the servicer), or all when
  /// too few pixels have a depth to say (a target in shadow gives little stereo depth).
  std::vector<cv::String> classesToSearch(const cv::Mat& depth) const {
    std::vector<cv::String> all;
    for (std::size_t i = 0; i < set_->ranges.size(); ++i) all.push_back(fmt::format("range_{}", i));
    if (depth.empty()) return all;
    std::vector<float> values;
    for (int r = 0; r < depth.rows; ++r)
      for (int c = 0; c < depth.cols; ++c)
        if (const float z = depth.at<float>(r, c); std::isfinite(z)) values.push_back(z);
    if (values.size() < kMinimumDepthPixels) return all;
    const double nearest = percentile(values, 0.05) * (1 - params_.range_margin);
    const double farthest = percentile(values, 0.95) * (1 + params_.range_margin);
    std::vector<cv::String> chosen;
    for (std::size_t i = 0; i < set_->ranges.size(); ++i) {
      // A class covers its range +- half a step.
      const double r = set_->ranges[i];
      const double step = set_->ranges.size() > 1 ? set_->ranges[1] / set_->ranges[0] : 1.25;
      if (r * std::sqrt(step) >= nearest && r / std::sqrt(step) <= farthest)
        chosen.push_back(all[i]);
    }
    return chosen.empty() ? all : chosen;
  }

  /// Matches in similarity order, each turned into a pose; a match whose pose repeats a better
  /// one (centre within 4 matching pixels and rotation within half a view step) is dropped, and
  /// at most verify_candidates are kept.
  std::vector<Hypothesis> distinctHypotheses(const std::vector<cv::linemod::Match>& matches,
                                             cv::Size size) const {
    std::vector<Hypothesis> kept;
    for (const cv::linemod::Match& m : matches) {
      if (static_cast<int>(kept.size()) >= params_.verify_candidates) break;
      const TemplateView* view = set_->find(m.class_id, m.template_id);
      if (!view) continue;
      // LINEMOD lets a template wrap around the image's right edge: such matches are not real.
      if (m.x < 0 || m.y < 0 || m.x + view->width > size.width + view->width / 2 ||
          m.y + view->height > size.height + view->height / 2)
        continue;
      Hypothesis h;
      h.view = view;
      h.match = m;
      h.pose = set_->poseOfMatch(*view, m.x, m.y, view->range);
      const Eigen::Vector2d centre = Eigen::Vector2d(m.x, m.y) + view->centre_offset;
      bool repeated = false;
      for (const Hypothesis& k : kept) {
        const Eigen::Vector2d other = Eigen::Vector2d(k.match.x, k.match.y) + k.view->centre_offset;
        const double angle =
            Eigen::AngleAxisd(k.pose.linear().transpose() * h.pose.linear()).angle();
        if ((centre - other).norm() <= 4.0 && angle < set_->view_step / 2 &&
            std::abs(std::log(k.view->range / view->range)) < 0.05) {
          repeated = true;
          break;
        }
      }
      if (!repeated) kept.push_back(h);
    }
    return kept;
  }

  /// Moves the hypothesis along its line of sight to the measured depth (the median difference
  /// over the model points it shows) and scores the fraction of those points whose measured
  /// depth then agrees within depth_tolerance of the range.
  void verify(Hypothesis& h, const cv::Mat& depth) const {
    const CameraModel c = cameraOfGrid(depth.size());
    auto visible = [&](const Eigen::Isometry3d& pose, std::vector<Eigen::Vector3d>& points,
                       std::vector<cv::Point>& pixels) {
      points.clear();
      pixels.clear();
      // A coarse z-buffer (4x4 matching pixels) hides the points behind nearer surfaces.
      const int cell = 4;
      const int gw = depth.cols / cell + 1, gh = depth.rows / cell + 1;
      zbuffer_.assign(static_cast<std::size_t>(gw * gh), std::numeric_limits<float>::infinity());
      candidates_.clear();
      for (std::size_t i = 0; i < set_->model_points.size(); ++i) {
        const Eigen::Vector3d p = pose * set_->model_points[i].cast<double>();
        const Eigen::Vector3d n = pose.linear() * set_->model_normals[i].cast<double>();
        if (p.z() <= 0 || n.dot(p) >= 0) continue;
        const int u = static_cast<int>(std::lround(c.fx * p.x() / p.z() + c.cx));
        const int v = static_cast<int>(std::lround(c.fy * p.y() / p.z() + c.cy));
        if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows) continue;
        float& z = zbuffer_[static_cast<std::size_t>((v / cell) * gw + u / cell)];
        z = std::min(z, static_cast<float>(p.z()));
        candidates_.push_back({p, cv::Point(u, v)});
      }
      for (const auto& [p, px] : candidates_) {
        const float z = zbuffer_[static_cast<std::size_t>((px.y / cell) * gw + px.x / cell)];
        if (p.z() <= z + 0.02 * z + 0.05) {
          points.push_back(p);
          pixels.push_back(px);
        }
      }
    };
    std::vector<Eigen::Vector3d> points;
    std::vector<cv::Point> pixels;
    std::vector<float> differences;
    for (int pass = 0; pass < 2; ++pass) {
      visible(h.pose, points, pixels);
      differences.clear();
      for (std::size_t i = 0; i < points.size(); ++i)
        if (const float z = depth.at<float>(pixels[i]); std::isfinite(z))
          differences.push_back(static_cast<float>(z - points[i].z()));
      if (differences.size() < kMinimumCheckedPoints) return;  // nothing to say: NaN
      if (pass == 1) break;
      // Slide the object along the ray through its centre by the median difference.
      const double shift = percentile(differences, 0.5);
      const Eigen::Vector3d centre =
          h.pose * h.view->camera_T_object.inverse() * Eigen::Vector3d(0, 0, h.view->range);
      h.pose.pretranslate(centre.normalized() * (shift / centre.normalized().z()));
    }
    const double range =
        (h.pose * (h.view->camera_T_object.inverse() * Eigen::Vector3d(0, 0, h.view->range))).z();
    const double tolerance = params_.depth_tolerance * range;
    int agree = 0;
    for (float d : differences) agree += std::abs(d) <= tolerance;
    h.agreement = static_cast<double>(agree) / differences.size();
  }

  CameraModel cameraOfGrid(cv::Size size) const {
    CameraModel c = matching_;
    c.width = size.width;
    c.height = size.height;
    return c;
  }

  static constexpr std::size_t kMinimumDepthPixels = 50;
  static constexpr std::size_t kMinimumCheckedPoints = 20;

  std::shared_ptr<const TemplateSet> set_;
  cv::Ptr<cv::linemod::Detector> gradients_;
  cv::Ptr<cv::linemod::Detector> normals_;  // null: templates without depth normals
  CameraModel matching_;
  mutable std::vector<float> zbuffer_;
  mutable std::vector<std::pair<Eigen::Vector3d, cv::Point>> candidates_;
};

CDFF_REGISTER_DFI(TemplateDetectionLinemod);

}  // namespace cdff::dfn
