#pragma once
// LINEMOD templates of one target model (Hinterstoisser et al. 2012, cv::linemod): what
// `cdff train` writes and TemplateDetection/Linemod reads, and the geometry that turns a match
// back into a pose.
//
// Each template is a view of the model rendered with its bounding centre on the optical axis
// of the training camera at one range, under one rotation: the view direction on a sphere and
// an in-plane rotation about the optical axis. Templates of one range form one LINEMOD class
// ("range_<i>"), so that a detector can search only the ranges a depth measurement allows. A
// match at (x, y) places the template's bounding box there; the object's centre is then at the
// same offset from the box as in training, and the pose is the template's, turned so that the
// training camera's optical axis becomes the ray through that centre (a camera that sees an
// object off-axis sees the view of a camera pointed at it, rotated).
//
// The file is an OpenCV FileStorage (YAML, gzip when the name ends in .gz) holding the
// detector's classes, the pose of every template, the camera the templates were trained for
// (templates only match images of that focal length: LINEMOD is not scale-invariant) and the
// hash of the mesh, so that templates of another model are refused.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/rgbd/linemod.hpp>

#include "cdff/types/image.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/status.hpp"

namespace cdff::linemod_templates {

/// One trained template: the pose it was rendered at and where the object's centre lies in it.
struct TemplateView {
  std::string class_id;  // "range_<i>"
  int template_id = 0;   // within the class
  int range_index = 0;
  int view_index = 0;      // on the view sphere
  int in_plane_index = 0;  // rotation about the optical axis
  /// The training camera's pose of the object: its bounding centre on the optical axis at
  /// `range`, rotated by the view.
  Eigen::Isometry3d camera_T_object = Eigen::Isometry3d::Identity();
  double range = 0;  // m, depth of the bounding centre
  /// Pixel of the bounding centre minus the template's top-left corner (template resolution).
  Eigen::Vector2d centre_offset = Eigen::Vector2d::Zero();
  /// Median depth of the visible surface minus `range` (m): the measured median depth under a
  /// match, less this, is the centre's depth.
  double surface_depth_offset = 0;
  int width = 0, height = 0;  // the template's bounding box, pixels
};

/// Settings of the LINEMOD detector, written with the templates (a detector matches only
/// templates extracted with the same settings).
struct DetectorSettings {
  int gradient_features = 63;            // features per template, colour gradients
  float gradient_weak_threshold = 10;    // gradient magnitude kept for matching
  float gradient_strong_threshold = 55;  // gradient magnitude for template features
  int normal_features = 63;              // features per template, depth normals (0: no depth)
  int normal_distance_threshold = 0;     // mm: depths beyond are ignored
  int normal_difference_threshold = 50;  // mm: neighbours further in depth are not the surface
  std::vector<int> spreading = {4, 8};   // T per LINEMOD pyramid level
};

/// A trained template set.
struct TemplateSet {
  std::string model_name;
  std::string mesh_hash;  // meshHash() of the model trained on
  /// The camera the templates are for (full resolution, distortion-free) and how many times
  /// its images are halved before matching.
  CameraModel camera;
  int pyramid_level = 0;
  DetectorSettings settings;
  std::vector<double> ranges;  // m, one class per range
  int views = 0, in_plane_rotations = 0;
  double view_step = 0, in_plane_step = 0;  // rad
  std::vector<TemplateView> templates;      // in (class, template id) order
  /// Points on the model's surface with their outward normals (model frame), to check a
  /// detection against a measured depth.
  std::vector<Eigen::Vector3f> model_points, model_normals;
  cv::Ptr<cv::linemod::Detector> detector;  // both modalities when settings.normal_features > 0

  /// The camera of the images matched: `camera` halved pyramid_level times.
  CameraModel matchingCamera() const;
  /// Where each class's templates start in `templates` (they are in (class, template id) order
  /// with ids 0, 1, ...): set by index() once `templates` is complete.
  std::map<std::string, std::size_t, std::less<>> first_of_class;
  void index();
  /// The template of a match, or null.
  const TemplateView* find(const std::string& class_id, int template_id) const;
  /// The object's pose for a match at (x, y) of the matching image, with the centre's depth
  /// along the ray (the template's range when no depth was measured).
  Eigen::Isometry3d poseOfMatch(const TemplateView& view, int x, int y, double centre_depth) const;
};

/// A 64-bit FNV-1a hash of the mesh's triangles (vertex positions rounded to 0.1 mm, in the
/// triangles' order), as 16 hex digits: the same for a model and its exported PLY/OBJ.
std::string meshHash(const TriangleMesh& mesh);

/// A LINEMOD detector with the settings' modalities (colour gradients, and depth normals when
/// normal_features > 0).
cv::Ptr<cv::linemod::Detector> createDetector(const DetectorSettings& settings, bool with_normals);
/// A colour-gradient-only detector with the gradient part of every template of `set`.
cv::Ptr<cv::linemod::Detector> gradientOnlyDetector(const TemplateSet& set);
/// A depth-normal-only detector with the normal part of every template of `set` (a depth camera
/// without an image: a ToF camera); null when `set` has no depth-normal features.
cv::Ptr<cv::linemod::Detector> normalsOnlyDetector(const TemplateSet& set);

Status writeTemplateSet(const TemplateSet& set, const std::filesystem::path& path);
/// Reads a template file; a missing, truncated or foreign file is an error naming it.
Result<TemplateSet> readTemplateSet(const std::filesystem::path& path);

/// The rotation turning the optical axis (0, 0, 1) onto the unit ray `ray`, about their common
/// perpendicular (identity on the axis).
Eigen::Matrix3d rotationFromOpticalAxis(const Eigen::Vector3d& ray);

/// OpenCV's ColorGradient modality reads three channels: grey is replicated (its gradient is
/// then the grey one), colour is passed as it is.
cv::Mat asColour(const cv::Mat& image);
/// The smallest size >= `size` whose width and height, halved once per LINEMOD pyramid level,
/// are multiples of that level's spreading T (what cv::linemod's linear memories require).
cv::Size matchableSize(cv::Size size, const std::vector<int>& spreading);
/// `image` zero-padded at the right and bottom to `size`.
cv::Mat padTo(const cv::Mat& image, cv::Size size);
/// 16UC1 millimetres from a 32FC1 metres depth (NaN, inf, <= 0 and beyond 65 m become 0, the
/// LINEMOD "no depth"), resized to `size` by nearest neighbour.
cv::Mat depthMillimetres(const cv::Mat& depth_m, cv::Size size);

}  // namespace cdff::linemod_templates
