#include "linemod_templates.hpp"

#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "cdff/egse/rng.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::linemod_templates {

namespace {

constexpr int kFileVersion = 1;
constexpr const char* kFormatTag = "cdff.linemod_templates";

std::string hex64(std::uint64_t x) {
  return fmt::format("{:016x}", x);
}

void writeCamera(cv::FileStorage& fs, const CameraModel& c) {
  fs << "camera"
     << "{"
     << "width" << c.width << "height" << c.height << "fx" << c.fx << "fy" << c.fy << "cx" << c.cx
     << "cy" << c.cy << "}";
}

/// The template poses of a file (the message says what is wrong, without the file name).
Status readViews(const cv::FileNode& templates, std::vector<TemplateView>& out) {
  if (templates.empty() || !templates.isSeq()) return corruptData("has no 'templates' list");
  for (const cv::FileNode& n : templates) {
    TemplateView t;
    t.class_id = static_cast<std::string>(n["class_id"]);
    t.template_id = static_cast<int>(n["template_id"]);
    t.range_index = static_cast<int>(n["range_index"]);
    t.view_index = static_cast<int>(n["view_index"]);
    t.in_plane_index = static_cast<int>(n["in_plane_index"]);
    t.range = static_cast<double>(n["range"]);
    std::vector<double> q, p, offset;
    std::vector<int> size;
    n["rotation_wxyz"] >> q;
    n["translation"] >> p;
    n["centre_offset"] >> offset;
    n["size"] >> size;
    if (q.size() != 4 || p.size() != 3 || offset.size() != 2 || size.size() != 2 || !(t.range > 0))
      return corruptData("has a malformed template (entry {} of 'templates')", out.size());
    t.camera_T_object.linear() =
        Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
    t.camera_T_object.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
    t.centre_offset = Eigen::Vector2d(offset[0], offset[1]);
    t.surface_depth_offset = static_cast<double>(n["surface_depth_offset"]);
    t.width = size[0];
    t.height = size[1];
    out.push_back(std::move(t));
  }
  return Status::ok();
}

void readSettings(const cv::FileNode& s, DetectorSettings& d) {
  d.gradient_features = static_cast<int>(s["gradient_features"]);
  d.gradient_weak_threshold = static_cast<float>(s["gradient_weak_threshold"]);
  d.gradient_strong_threshold = static_cast<float>(s["gradient_strong_threshold"]);
  d.normal_features = static_cast<int>(s["normal_features"]);
  d.normal_distance_threshold = static_cast<int>(s["normal_distance_threshold"]);
  d.normal_difference_threshold = static_cast<int>(s["normal_difference_threshold"]);
  s["spreading"] >> d.spreading;
}

}  // namespace

CameraModel TemplateSet::matchingCamera() const {
  return cameraAfterPyrDown(camera, pyramid_level);
}

void TemplateSet::index() {
  first_of_class.clear();
  for (std::size_t i = 0; i < templates.size(); ++i)
    first_of_class.try_emplace(templates[i].class_id, i);
}

const TemplateView* TemplateSet::find(const std::string& class_id, int template_id) const {
  const auto first = first_of_class.find(class_id);
  if (first == first_of_class.end() || template_id < 0) return nullptr;
  const std::size_t i = first->second + static_cast<std::size_t>(template_id);
  if (i >= templates.size() || templates[i].class_id != class_id ||
      templates[i].template_id != template_id)
    return nullptr;
  return &templates[i];
}

Eigen::Isometry3d TemplateSet::poseOfMatch(const TemplateView& view, int x, int y,
                                           double centre_depth) const {
  const CameraModel c = matchingCamera();
  const Eigen::Vector2d centre = Eigen::Vector2d(x, y) + view.centre_offset;
  const Eigen::Vector3d ray =
      Eigen::Vector3d((centre.x() - c.cx) / c.fx, (centre.y() - c.cy) / c.fy, 1.0).normalized();
  // In training the centre was at depth `range` on the axis, i.e. at distance `range` from the
  // camera; off-axis, the same apparent size means the same distance along the ray.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const Eigen::Matrix3d turn = rotationFromOpticalAxis(ray);
  pose.linear() = turn * view.camera_T_object.linear();
  const Eigen::Vector3d centre_in_object =
      view.camera_T_object.inverse() * Eigen::Vector3d(0, 0, view.range);
  const double distance = centre_depth / ray.z();
  pose.translation() = ray * distance - pose.linear() * centre_in_object;
  return pose;
}

std::string meshHash(const TriangleMesh& mesh) {
  // The rounded coordinates as little-endian 64-bit integers, hashed by the simulator's FNV-1a.
  std::string bytes;
  bytes.reserve(mesh.triangles.size() * 9 * 8);
  for (const std::array<std::uint32_t, 3>& triangle : mesh.triangles)
    for (std::uint32_t index : triangle) {
      const Eigen::Vector3f& p = mesh.vertices[index];
      for (int a = 0; a < 3; ++a) {
        const auto v = static_cast<std::uint64_t>(std::llround(static_cast<double>(p[a]) * 1e4));
        for (int b = 0; b < 8; ++b) bytes.push_back(static_cast<char>((v >> (8 * b)) & 0xffu));
      }
    }
  return hex64(egse::hashName(bytes));
}

cv::Ptr<cv::linemod::Detector> createDetector(const DetectorSettings& s, bool with_normals) {
  std::vector<cv::Ptr<cv::linemod::Modality>> modalities;
  modalities.push_back(cv::makePtr<cv::linemod::ColorGradient>(
      s.gradient_weak_threshold, static_cast<std::size_t>(s.gradient_features),
      s.gradient_strong_threshold));
  if (with_normals && s.normal_features > 0)
    modalities.push_back(cv::makePtr<cv::linemod::DepthNormal>(
        s.normal_distance_threshold, s.normal_difference_threshold,
        static_cast<std::size_t>(s.normal_features), 2));
  return cv::makePtr<cv::linemod::Detector>(modalities, s.spreading);
}

namespace {

/// A detector of one modality (0: gradients, 1: normals) holding that part of every template.
cv::Ptr<cv::linemod::Detector> singleModalityDetector(const TemplateSet& set, int modality) {
  const DetectorSettings& s = set.settings;
  std::vector<cv::Ptr<cv::linemod::Modality>> modalities;
  if (modality == 0)
    modalities.push_back(cv::makePtr<cv::linemod::ColorGradient>(
        s.gradient_weak_threshold, static_cast<std::size_t>(s.gradient_features),
        s.gradient_strong_threshold));
  else
    modalities.push_back(cv::makePtr<cv::linemod::DepthNormal>(
        s.normal_distance_threshold, s.normal_difference_threshold,
        static_cast<std::size_t>(s.normal_features), 2));
  auto detector = cv::makePtr<cv::linemod::Detector>(modalities, s.spreading);
  const int count_of_modalities = static_cast<int>(set.detector->getModalities().size());
  const int levels = set.detector->pyramidLevels();
  for (const std::string& class_id : set.detector->classIds()) {
    const int count = set.detector->numTemplates(class_id);
    for (int id = 0; id < count; ++id) {
      const std::vector<cv::linemod::Template>& pyramid = set.detector->getTemplates(class_id, id);
      std::vector<cv::linemod::Template> part;
      for (int l = 0; l < levels; ++l) part.push_back(pyramid[l * count_of_modalities + modality]);
      // Template ids must stay those of `set` (TemplateSet::find): every template is added,
      // also one whose part has no feature (it then never matches).
      detector->addSyntheticTemplate(part, class_id);
    }
  }
  return detector;
}

}  // namespace

cv::Ptr<cv::linemod::Detector> gradientOnlyDetector(const TemplateSet& set) {
  return singleModalityDetector(set, 0);
}

cv::Ptr<cv::linemod::Detector> normalsOnlyDetector(const TemplateSet& set) {
  if (set.settings.normal_features <= 0 || set.detector->getModalities().size() < 2) return {};
  return singleModalityDetector(set, 1);
}

Status writeTemplateSet(const TemplateSet& set, const std::filesystem::path& path) {
  try {
    cv::FileStorage fs(path.string(), cv::FileStorage::WRITE);
    if (!fs.isOpened())
      return ioError("{}", fmt::format("cannot write template file '{}'", path.string()));
    fs << "format" << kFormatTag << "version" << kFileVersion;
    fs << "model_name" << set.model_name << "mesh_hash" << set.mesh_hash;
    writeCamera(fs, set.camera);
    fs << "pyramid_level" << set.pyramid_level;
    const DetectorSettings& s = set.settings;
    fs << "settings"
       << "{"
       << "gradient_features" << s.gradient_features << "gradient_weak_threshold"
       << s.gradient_weak_threshold << "gradient_strong_threshold" << s.gradient_strong_threshold
       << "normal_features" << s.normal_features << "normal_distance_threshold"
       << s.normal_distance_threshold << "normal_difference_threshold"
       << s.normal_difference_threshold << "spreading" << s.spreading << "}";
    fs << "ranges" << set.ranges << "views" << set.views << "in_plane_rotations"
       << set.in_plane_rotations << "view_step" << set.view_step << "in_plane_step"
       << set.in_plane_step;
    fs << "templates"
       << "[";
    for (const TemplateView& t : set.templates) {
      const Eigen::Quaterniond q(t.camera_T_object.linear());
      const Eigen::Vector3d p = t.camera_T_object.translation();
      fs << "{"
         << "class_id" << t.class_id << "template_id" << t.template_id << "range_index"
         << t.range_index << "view_index" << t.view_index << "in_plane_index" << t.in_plane_index
         << "range" << t.range << "rotation_wxyz" << std::vector<double>{q.w(), q.x(), q.y(), q.z()}
         << "translation" << std::vector<double>{p.x(), p.y(), p.z()} << "centre_offset"
         << std::vector<double>{t.centre_offset.x(), t.centre_offset.y()} << "surface_depth_offset"
         << t.surface_depth_offset << "size" << std::vector<int>{t.width, t.height} << "}";
    }
    fs << "]";
    cv::Mat points(static_cast<int>(set.model_points.size()), 6, CV_32F);
    for (int i = 0; i < points.rows; ++i)
      for (int a = 0; a < 3; ++a) {
        points.at<float>(i, a) = set.model_points[i][a];
        points.at<float>(i, 3 + a) = set.model_normals[i][a];
      }
    fs << "model_points" << points;
    fs << "detector"
       << "{";
    set.detector->write(fs);
    fs << "}";
    fs << "classes"
       << "[";
    for (const std::string& class_id : set.detector->classIds()) {
      fs << "{";
      set.detector->writeClass(class_id, fs);
      fs << "}";
    }
    fs << "]";
    fs.release();
  } catch (const cv::Exception& e) {
    return ioError("{}",
                   fmt::format("cannot write template file '{}': {}", path.string(), e.what()));
  }
  return Status::ok();
}

Result<TemplateSet> readTemplateSet(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    return notFound(
        "{}",
        fmt::format("template file '{}' does not exist; expected a file written by `cdff train`",
                    name));
  auto corrupt = [&name](const std::string& what) {
    return corruptData(
        "{}", fmt::format("template file '{}' {}; expected a file written by `cdff train` (format "
                          "'{}' version {})",
                          name, what, kFormatTag, kFileVersion));
  };
  try {
    cv::FileStorage fs(name, cv::FileStorage::READ);
    if (!fs.isOpened()) return corrupt("cannot be parsed");
    if (fs["format"].empty() || static_cast<std::string>(fs["format"]) != kFormatTag)
      return corrupt("has no 'format: cdff.linemod_templates'");
    if (static_cast<int>(fs["version"]) != kFileVersion)
      return corrupt(fmt::format("has version {}", static_cast<int>(fs["version"])));
    TemplateSet set;
    set.model_name = static_cast<std::string>(fs["model_name"]);
    set.mesh_hash = static_cast<std::string>(fs["mesh_hash"]);
    const cv::FileNode camera = fs["camera"];
    if (camera.empty()) return corrupt("has no 'camera'");
    set.camera.width = static_cast<int>(camera["width"]);
    set.camera.height = static_cast<int>(camera["height"]);
    set.camera.fx = static_cast<double>(camera["fx"]);
    set.camera.fy = static_cast<double>(camera["fy"]);
    set.camera.cx = static_cast<double>(camera["cx"]);
    set.camera.cy = static_cast<double>(camera["cy"]);
    if (!set.camera.validate()) return corrupt("has an invalid 'camera'");
    set.pyramid_level = static_cast<int>(fs["pyramid_level"]);
    if (set.pyramid_level < 0 || set.pyramid_level > 6)
      return corrupt(fmt::format("has pyramid_level {} (expected 0-6)", set.pyramid_level));
    const cv::FileNode s = fs["settings"];
    if (s.empty()) return corrupt("has no 'settings'");
    readSettings(s, set.settings);
    fs["ranges"] >> set.ranges;
    set.views = static_cast<int>(fs["views"]);
    set.in_plane_rotations = static_cast<int>(fs["in_plane_rotations"]);
    set.view_step = static_cast<double>(fs["view_step"]);
    set.in_plane_step = static_cast<double>(fs["in_plane_step"]);
    if (Status parsed = readViews(fs["templates"], set.templates); !parsed)
      return corrupt(parsed.message());
    cv::Mat points;
    fs["model_points"] >> points;
    if (points.empty() || points.cols != 6 || points.type() != CV_32F)
      return corrupt("has no 'model_points' (N x 6 floats)");
    for (int i = 0; i < points.rows; ++i) {
      set.model_points.emplace_back(points.at<float>(i, 0), points.at<float>(i, 1),
                                    points.at<float>(i, 2));
      set.model_normals.emplace_back(points.at<float>(i, 3), points.at<float>(i, 4),
                                     points.at<float>(i, 5));
    }
    const cv::FileNode detector = fs["detector"];
    const cv::FileNode classes = fs["classes"];
    if (detector.empty() || classes.empty() || !classes.isSeq())
      return corrupt("has no 'detector' or 'classes'");
    set.detector = cv::makePtr<cv::linemod::Detector>();
    set.detector->read(detector);
    for (const cv::FileNode& c : classes) set.detector->readClass(c);
    if (set.detector->numTemplates() != static_cast<int>(set.templates.size()))
      return corrupt(fmt::format("holds {} LINEMOD templates but {} template poses",
                                 set.detector->numTemplates(), set.templates.size()));
    set.index();
    for (const TemplateView& t : set.templates) {
      if (t.template_id < 0 || t.template_id >= set.detector->numTemplates(t.class_id))
        return corrupt(fmt::format("has a pose for template {} of class '{}', which it lacks",
                                   t.template_id, t.class_id));
      if (set.find(t.class_id, t.template_id) != &t)
        return corrupt(fmt::format("lists template {} of class '{}' out of (class, id) order",
                                   t.template_id, t.class_id));
    }
    return set;
  } catch (const cv::Exception& e) {
    return corrupt(fmt::format("cannot be read ({})", e.what()));
  }
}

Eigen::Matrix3d rotationFromOpticalAxis(const Eigen::Vector3d& ray) {
  return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), ray.normalized())
      .toRotationMatrix();
}

cv::Mat asColour(const cv::Mat& image) {
  if (image.channels() == 3) return image;
  cv::Mat colour;
  cv::cvtColor(image, colour, cv::COLOR_GRAY2BGR);
  return colour;
}

cv::Size matchableSize(cv::Size size, const std::vector<int>& spreading) {
  auto fits = [&spreading](int n) {
    for (std::size_t l = 0; l < spreading.size(); ++l)
      if ((n >> l) % spreading[l] != 0 || (l > 0 && n % (1 << l) != 0)) return false;
    return true;
  };
  int w = size.width, h = size.height;
  while (!fits(w)) ++w;
  while (!fits(h)) ++h;
  return {w, h};
}

cv::Mat padTo(const cv::Mat& image, cv::Size size) {
  if (image.size() == size) return image;
  cv::Mat padded;
  cv::copyMakeBorder(image, padded, 0, size.height - image.rows, 0, size.width - image.cols,
                     cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return padded;
}

cv::Mat depthMillimetres(const cv::Mat& depth_m, cv::Size size) {
  cv::Mat mm(depth_m.size(), CV_16UC1);
  for (int r = 0; r < depth_m.rows; ++r) {
    const float* in = depth_m.ptr<float>(r);
    std::uint16_t* o = mm.ptr<std::uint16_t>(r);
    for (int c = 0; c < depth_m.cols; ++c) {
      const float z = in[c];
      o[c] = (std::isfinite(z) && z > 0 && z < 65.0f)
                 ? static_cast<std::uint16_t>(std::lround(z * 1000.0f))
                 : std::uint16_t{0};
    }
  }
  if (mm.size() == size) return mm;
  cv::Mat resized;
  cv::resize(mm, resized, size, 0, 0, cv::INTER_NEAREST);
  return resized;
}

}  // namespace cdff::linemod_templates
