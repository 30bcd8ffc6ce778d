#pragma once
// One step of model-based edge tracking (seed §4.1.5), composed of the atomic steps that the
// VisibilityDetermination, ContourSampling, EdgeMatching and EdgePoseEstimation DFNs expose:
// for each camera, the visible contours at the predicted pose are sampled and matched to image
// edges; one robust estimate then fuses every camera's matches (and depth points when a depth map
// is given). Further passes repeat the matching from the refined pose with a shorter search.
//
// Camera failure: a camera whose image is missing or yields matches for fewer than
// min_camera_match_ratio of its samples (dark, saturated, blurred) is left out and the others
// carry on; the status is then kDegraded. Track loss (kLost): the model is not in front of any
// camera, too few measurements, divergence, or an inlier ratio below min_inlier_ratio.

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "cdff/tracking/contours.hpp"
#include "cdff/tracking/edge_search.hpp"
#include "cdff/tracking/pose_solver.hpp"
#include "cdff/tracking/tracking_model.hpp"

namespace cdff::tracking {

struct EdgeTrackerOptions {
  TrackingModelOptions model;
  VisibilityOptions visibility;
  SamplingOptions sampling;
  EdgeSearchOptions search;
  PoseSolverOptions solver;
  DepthAssociationOptions depth;
  int refinement_passes = 1;            // matching passes after the first
  int refinement_search_distance = 3;   // px, their search distance
  double min_inlier_ratio = 0.3;        // below: lost
  double degraded_inlier_ratio = 0.5;   // below: degraded
  double min_camera_match_ratio = 0.1;  // a camera matching fewer of its samples has failed
  /// Visible contours are recomputed only after the pose moved this much since they were last
  /// computed (seed Table 7, "minimum parameters w.r.t. the last visibility determination");
  /// 0 recomputes them every pass.
  double visibility_update_translation = 0;  // m
  double visibility_update_rotation = 0;     // rad
};

/// One camera of the rig for one frame. A null or empty image is a missing frame.
struct CameraFrame {
  const Image* image = nullptr;  // 8UC1, undistorted, the size of `camera`
  CameraModel camera;
  Transform camera_T_reference;  // identity for the reference camera
};

/// The first camera with an image (the left one unless it failed); the last camera when none has
/// one. The acquisition measures the prediction's spread and the model's size in it, and the
/// coarse alignment aligns its image.
std::size_t referenceCamera(std::span<const CameraFrame> cameras);

struct TrackingResult {
  Transform reference_T_model;             // the estimate (the prediction when lost)
  Matrix6d covariance = Matrix6d::Zero();  // noInformationCovariance() when lost
  TrackingStatus status = TrackingStatus::kLost;
  std::string reason;  // why the status is not kTracking
  double inlier_ratio = 0;
  double edge_rms = 0;  // px
  std::size_t samples = 0, matched = 0, inliers = 0, depth_points = 0;
  std::vector<bool> camera_used;
  int iterations = 0;
};

/// The status of a pose estimate: kLost below min_inlier_ratio (edges) or without edges and
/// depth; kDegraded when some of the cameras failed or below degraded_inlier_ratio. `reason`
/// says why when the status is not kTracking.
TrackingStatus assessTracking(const PoseSolution& solution, std::size_t cameras,
                              std::size_t failed_cameras, double min_inlier_ratio,
                              double degraded_inlier_ratio, std::string& reason);

/// The covariance a lost track reports with its (predicted) pose: 1e6 m^2 and 1e2 rad^2 per axis,
/// i.e. no information, so that a filter fed with it anyway barely moves.
Matrix6d noInformationCovariance();

/// A rigid transform from [tx, ty, tz, rx, ry, rz] (m, rotation vector in rad).
Result<Eigen::Isometry3d> isometryFromVector(const std::vector<double>& values, const char* what);

/// The image itself when it is 8UC1, else its grey conversion (8UC3, BGR, ITU-R BT.601 weights),
/// with the same stamp, frame and camera model.
Result<Image> toGray8(const Image& image, const char* what);

class EdgeTracker {
 public:
  /// Builds the tracking form of `model`; the previous model stays on error.
  Status setModel(const PolygonModel& model, const TrackingModelOptions& options = {});
  bool hasModel() const { return model_.has_value(); }
  const TrackingModel& model() const { return *model_; }

  /// Tracks one frame from the prediction reference_T_model. `depth` (optional) is placed in the
  /// rig by depth_T_reference. Input errors (wrong formats or sizes) are errors; a lost track is a
  /// result with status kLost.
  Result<TrackingResult> track(std::span<const CameraFrame> cameras, const DepthMap* depth,
                               const Eigen::Isometry3d& depth_T_reference,
                               const Transform& predicted_reference_T_model,
                               const EdgeTrackerOptions& options);

  /// The last frame's matched samples per camera (empty for a failed camera), for display.
  const std::vector<ContourSamples>& lastMatches() const { return matches_; }

 private:
  struct CachedContours {
    std::shared_ptr<const ModelContours> contours;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // camera_T_model when computed
  };
  Result<std::shared_ptr<const ModelContours>> contoursFor(std::size_t camera,
                                                           const CameraFrame& frame,
                                                           const Eigen::Isometry3d& c_T_m,
                                                           const Transform& camera_T_model,
                                                           const EdgeTrackerOptions& options);
  // Matches every camera's contour samples at `pose` to its image edges (matches_); whether
  // each camera matched enough of them to be used.
  Result<std::vector<bool>> matchCameras(std::span<const CameraFrame> cameras,
                                         const Eigen::Isometry3d& pose, const Transform& pose_t,
                                         const EdgeSearchOptions& search,
                                         const EdgeTrackerOptions& options);

  std::optional<TrackingModel> model_;
  std::vector<CachedContours> cache_;
  std::vector<ContourSamples> matches_;
};

}  // namespace cdff::tracking
