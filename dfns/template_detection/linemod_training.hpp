#pragma once
// Training LINEMOD templates from a target model: the simulator's renderer draws the model over
// a view sphere, in-plane rotations and ranges, and each view becomes one template with its
// pose (linemod_templates.hpp). `cdff train` and the tests call this.
//
// Defaults follow from the camera and the model's size (defaultTrainingOptions):
//  - the matching resolution halves the camera's images until they are at most 640 px wide
//    (LINEMOD's design resolution; the cost of matching grows with the pixels);
//  - the ranges run from where the bounding sphere's diameter is 2.5 times the image's
//    shorter side (closer, less than about half of a long target can be in view, too little
//    for a template to be specific) to where it spans 96 matching pixels (LINEMOD's 63 features
//    need an outline of a few hundred pixels), in steps of 1.25x: LINEMOD's spreading tolerates
//    about +-12 % of scale, so every range in between is within reach of one class;
//  - view and in-plane steps of 15 degrees: the nearest template is then within about 8
//    degrees of view and 7.5 degrees of in-plane rotation, inside the detection's 15 degrees.
// Views are rendered at twice the matching resolution and halved by cv::pyrDown, the filter the
// detector applies to camera images, with the sun behind the camera so that every face the
// camera sees is lit and the outline and creases give the gradients.

#include <functional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "cdff/egse/model.hpp"
#include "cdff/egse/render.hpp"
#include "linemod_templates.hpp"

namespace cdff::linemod_templates {

struct TrainingOptions {
  double view_step = 0.2617993877991494;      // rad, between neighbouring view directions
  double in_plane_step = 0.2617993877991494;  // rad, about the optical axis
  std::vector<double> ranges;                 // m, one class each
  int pyramid_level = 0;                      // of the camera's images
  DetectorSettings settings;
  /// Towards the sun, in the camera frame (behind the camera, above and to the left).
  Eigen::Vector3d sun_direction = Eigen::Vector3d(-0.3, -0.4, -1.0).normalized();
  egse::RendererBackend renderer = egse::RendererBackend::kCpu;
  int threads = 0;          // 0: every core
  int model_points = 2000;  // surface points kept for the depth check
};

/// The defaults of the header comment for `model` seen by `camera`.
TrainingOptions defaultTrainingOptions(const egse::TargetModel& model, const CameraModel& camera);
/// Ranges from `nearest` to at least `farthest` in steps of `ratio`.
std::vector<double> geometricRanges(double nearest, double farthest, double ratio);
/// About 4 pi / (step^2 sqrt(3) / 2) unit directions spread evenly on the sphere (a Fibonacci
/// lattice): neighbours `step` apart.
std::vector<Eigen::Vector3d> viewSphere(double step);
/// The camera_T_object of a view: the camera on `direction` (object frame, from the object's
/// bounding centre towards the camera) at `range` from the centre, looking at it, rolled by
/// `in_plane` about its optical axis.
Eigen::Isometry3d viewPose(const Eigen::Vector3d& centre, const Eigen::Vector3d& direction,
                           double in_plane, double range);

/// One rendered view at the matching resolution.
struct RenderedView {
  cv::Mat image;  // 8UC1
  cv::Mat depth;  // 16UC1 millimetres, 0 where no surface
  cv::Mat mask;   // 8UC1, 255 on the model
};

/// Renders views of one model for one camera (matching resolution).
class ViewRenderer {
 public:
  static Result<ViewRenderer> create(const egse::TargetModel& model, const CameraModel& camera,
                                     int pyramid_level, egse::RendererBackend backend,
                                     const Eigen::Vector3d& sun_direction);
  Result<RenderedView> render(const Eigen::Isometry3d& camera_T_object);
  /// Towards the sun, camera frame, for the next renders.
  void setSunDirection(const Eigen::Vector3d& sun_direction) {
    sun_direction_ = sun_direction.normalized();
  }
  const CameraModel& matchingCamera() const { return matching_; }

 private:
  std::shared_ptr<egse::Renderer> renderer_;
  int model_ = -1;
  CameraModel matching_;
  egse::PinholeCamera canvas_;
  Eigen::Vector3d sun_direction_;
  egse::RenderOutput output_;
};

/// Progress of a training: templates done out of the total.
using TrainingProgress = std::function<void(int done, int total)>;

/// Trains the templates of `model` for `camera`, views rendered on `options.threads` threads
/// (each with its own renderer; the result does not depend on the thread count). Views whose
/// model covers too few pixels or edges for a template are skipped (counted in `skipped` when
/// given). `progress` is called from one thread at a time.
Result<TemplateSet> trainTemplates(const egse::TargetModel& model, const CameraModel& camera,
                                   const TrainingOptions& options,
                                   const TrainingProgress& progress = {}, int* skipped = nullptr);

}  // namespace cdff::linemod_templates
