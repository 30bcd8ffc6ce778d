#include "cdff/tracking/edge_tracker.hpp"

#include <cmath>
#include <limits>

namespace cdff::tracking {

TrackingStatus assessTracking(const PoseSolution& solution, std::size_t cameras,
                              std::size_t failed_cameras, double min_inlier_ratio,
                              double degraded_inlier_ratio, std::string& reason) {
  const bool edges_used = solution.samples > 0;
  if (!edges_used && solution.depth_inliers == 0) {
    reason = "no edge sample and no depth point supports the estimate";
    return TrackingStatus::kLost;
  }
  if (edges_used && solution.inlierRatio() < min_inlier_ratio) {
    reason = fmt::format("inlier ratio {:.2f} is below min_inlier_ratio {:.2f}",
                         solution.inlierRatio(), min_inlier_ratio);
    return TrackingStatus::kLost;
  }
  if (failed_cameras > 0) {
    reason = fmt::format("{} of {} cameras failed (no image, or too few edges matched)",
                         failed_cameras, cameras);
    return TrackingStatus::kDegraded;
  }
  if (edges_used && solution.inlierRatio() < degraded_inlier_ratio) {
    reason = fmt::format("inlier ratio {:.2f} is below degraded_inlier_ratio {:.2f}",
                         solution.inlierRatio(), degraded_inlier_ratio);
    return TrackingStatus::kDegraded;
  }
  reason.clear();
  return TrackingStatus::kTracking;
}

std::size_t referenceCamera(std::span<const CameraFrame> cameras) {
  std::size_t reference = 0;
  while (reference + 1 < cameras.size() && !cameras[reference].image) ++reference;
  return reference;
}

Matrix6d noInformationCovariance() {
  Matrix6d c = Matrix6d::Zero();
  c.diagonal() << 1e6, 1e6, 1e6, 1e2, 1e2, 1e2;
  return c;
}

Result<Eigen::Isometry3d> isometryFromVector(const std::vector<double>& v, const char* what) {
  if (v.size() != 6)
    return invalidParameter("{} has {} values; expected 6 (tx ty tz in m, rx ry rz in rad)", what,
                            v.size());
  for (double x : v)
    if (!std::isfinite(x)) return invalidParameter("{} has a non-finite value {}", what, x);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() << v[0], v[1], v[2];
  t.linear() = expSO3(Eigen::Vector3d(v[3], v[4], v[5])).toRotationMatrix();
  return t;
}

Result<Image> toGray8(const Image& image, const char* what) {
  CDFF_RETURN_IF_ERROR(image.validate(what, {PixelFormat::kGray8, PixelFormat::kBgr8}));
  if (image.format == PixelFormat::kGray8) return image;
  std::vector<std::uint8_t> grey(static_cast<std::size_t>(image.width) * image.height);
  for (int y = 0; y < image.height; ++y) {
    const std::uint8_t* row = image.row(y);
    std::uint8_t* out = grey.data() + static_cast<std::size_t>(y) * image.width;
    for (int x = 0; x < image.width; ++x) {
      const int b = row[3 * x], g = row[3 * x + 1], r = row[3 * x + 2];
      out[x] = static_cast<std::uint8_t>((29 * b + 150 * g + 77 * r + 128) >> 8);
    }
  }
  Result<Image> out =
      Image::fromBytes(std::move(grey), image.width, image.height, PixelFormat::kGray8);
  if (!out) return out;
  out->stamp = image.stamp;
  out->frame_id = image.frame_id;
  out->camera = image.camera;
  return out;
}

Status EdgeTracker::setModel(const PolygonModel& model, const TrackingModelOptions& options) {
  Result<TrackingModel> built = TrackingModel::build(model, options);
  if (!built) return built.status();
  model_ = std::move(built).value();
  cache_.clear();
  return Status::ok();
}

Result<std::shared_ptr<const ModelContours>> EdgeTracker::contoursFor(
    std::size_t camera, const CameraFrame& frame, const Eigen::Isometry3d& c_T_m,
    const Transform& camera_T_model, const EdgeTrackerOptions& options) {
  if (cache_.size() <= camera) cache_.resize(camera + 1);
  CachedContours& cached = cache_[camera];
  const bool reuse_allowed =
      options.visibility_update_translation > 0 || options.visibility_update_rotation > 0;
  if (reuse_allowed && cached.contours && cached.contours->camera.width == frame.camera.width &&
      cached.contours->camera.height == frame.camera.height &&
      (cached.pose.translation() - c_T_m.translation()).norm() <
          options.visibility_update_translation &&
      Eigen::AngleAxisd(cached.pose.linear().transpose() * c_T_m.linear()).angle() <
          options.visibility_update_rotation) {
    // Same visible segments, projected from the new pose.
    auto moved = std::make_shared<ModelContours>(*cached.contours);
    moved->camera_T_model = camera_T_model;
    moved->camera = frame.camera;
    moved->camera_T_reference = frame.camera_T_reference;
    return std::shared_ptr<const ModelContours>(std::move(moved));
  }
  Result<ModelContours> contours = computeContours(*model_, frame.camera, camera_T_model,
                                                   frame.camera_T_reference, options.visibility);
  if (!contours) return contours.status();
  cached.contours = std::make_shared<const ModelContours>(std::move(contours).value());
  cached.pose = c_T_m;
  return cached.contours;
}

namespace {

// Input errors: each image 8UC1 and the size of its pinhole camera, a valid prediction.
Status checkTrackingInputs(std::span<const CameraFrame> cameras, const DepthMap* depth,
                           const Transform& predicted) {
  if (cameras.empty() && !depth)
    return invalidInput("no camera and no depth map; expected at least one image");
  CDFF_RETURN_IF_ERROR(predicted.validate().withContext("predicted pose"));
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const CameraFrame& frame = cameras[c];
    CDFF_RETURN_IF_ERROR(checkPinhole(frame.camera, "camera"));
    if (frame.image && !frame.image->empty()) {
      CDFF_RETURN_IF_ERROR(frame.image->validate("image", {PixelFormat::kGray8}));
      if (frame.image->width != frame.camera.width || frame.image->height != frame.camera.height)
        return invalidInput("image {} is {}x{}; expected {}x{}, the size of its camera model", c,
                            frame.image->width, frame.image->height, frame.camera.width,
                            frame.camera.height);
    }
  }
  return Status::ok();
}

// Whether the model's bounding sphere at `pose` reaches in front of some sensor's near
// clipping plane, and the largest depth of its centre in the sensors (for the message when not).
struct Placement {
  bool in_front = false;
  double nearest = -std::numeric_limits<double>::infinity();
};

Placement placeModel(const TrackingModel& model, std::span<const CameraFrame> cameras,
                     const DepthMap* depth, const Eigen::Isometry3d& depth_T_reference,
                     const Eigen::Isometry3d& pose, double near_clipping) {
  Placement out;
  for (const CameraFrame& frame : cameras) {
    const double z = (frame.camera_T_reference.isometry() * pose * model.centre).z();
    out.nearest = std::max(out.nearest, z);
    out.in_front = out.in_front || z + model.radius > near_clipping;
  }
  if (depth) {
    const double z = (depth_T_reference * pose * model.centre).z();
    out.nearest = std::max(out.nearest, z);
    out.in_front = out.in_front || z + model.radius > near_clipping;
  }
  return out;
}

// The depth points on the faces the depth camera sees at `pose`.
Result<DepthPoints> depthPoints(const TrackingModel& model, const DepthMap& depth,
                                const Eigen::Isometry3d& depth_T_reference,
                                const Eigen::Isometry3d& pose, const Transform& predicted,
                                const EdgeTrackerOptions& options) {
  if (!depth.image.camera)
    return invalidInput(
        "depth map has no camera model; expected the depth camera's "
        "intrinsics with the image");
  const Eigen::Isometry3d d_T_m = depth_T_reference * pose;
  Transform d_T_m_t =
      Transform::fromIsometry(d_T_m, depth.image.frame_id, predicted.child_frame, predicted.stamp);
  VisibilityOptions faces_only = options.visibility;
  faces_only.compute_segments = false;
  Result<ModelContours> seen = computeContours(
      model, *depth.image.camera, d_T_m_t,
      Transform::fromIsometry(depth_T_reference, depth.image.frame_id, predicted.parent_frame),
      faces_only);
  if (!seen) return seen.status();
  return associateDepth(depth, depth_T_reference, seen->faces, pose, options.depth);
}

// The estimate, its statistics and its status into `result`; a lost track keeps the prediction
// with no information.
void reportEstimate(const PoseSolution& solution, const Eigen::Isometry3d& pose,
                    std::span<const CameraFrame> cameras, const Transform& predicted,
                    const EdgeTrackerOptions& options, TrackingResult& result) {
  result.reference_T_model =
      Transform::fromIsometry(pose, predicted.parent_frame, predicted.child_frame, predicted.stamp);
  for (const CameraFrame& frame : cameras)
    if (frame.image && frame.image->stamp != 0) {
      result.reference_T_model.stamp = frame.image->stamp;
      break;
    }
  result.covariance = solution.covariance;
  result.inlier_ratio = solution.inlierRatio();
  result.edge_rms = solution.edge_rms;
  result.samples = solution.samples;
  result.inliers = solution.inliers;
  result.depth_points = solution.depth_inliers;
  for (const ViewStatistics& v : solution.views) result.matched += v.matched;

  std::size_t failed = 0;
  for (std::size_t c = 0; c < cameras.size(); ++c) failed += result.camera_used[c] ? 0 : 1;
  result.status = assessTracking(solution, cameras.size(), failed, options.min_inlier_ratio,
                                 options.degraded_inlier_ratio, result.reason);
  if (result.status == TrackingStatus::kLost) {
    result.reference_T_model = predicted;
    result.covariance = noInformationCovariance();
  }
}

}  // namespace

Result<std::vector<bool>> EdgeTracker::matchCameras(std::span<const CameraFrame> cameras,
                                                    const Eigen::Isometry3d& pose,
                                                    const Transform& pose_t,
                                                    const EdgeSearchOptions& search,
                                                    const EdgeTrackerOptions& options) {
  matches_.assign(cameras.size(), ContourSamples{});
  std::vector<bool> used(cameras.size(), false);
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const CameraFrame& frame = cameras[c];
    if (!frame.image || frame.image->empty()) continue;
    const Eigen::Isometry3d c_T_m = frame.camera_T_reference.isometry() * pose;
    Result<Transform> camera_T_model = frame.camera_T_reference.compose(pose_t);
    if (!camera_T_model) return camera_T_model.status().withContext(fmt::format("camera {}", c));
    auto contours = contoursFor(c, frame, c_T_m, *camera_T_model, options);
    if (!contours) return contours.status();
    ContourSamples samples = sampleContours(*contours, options.sampling);
    if (samples.samples.empty()) continue;
    Result<ContourSamples> matched = searchEdges(*frame.image, samples, search);
    if (!matched) return matched.status();
    const double ratio =
        static_cast<double>(matched->matchedCount()) / static_cast<double>(matched->samples.size());
    matches_[c] = std::move(matched).value();
    if (ratio < options.min_camera_match_ratio) continue;
    used[c] = true;
  }
  return used;
}

Result<TrackingResult> EdgeTracker::track(std::span<const CameraFrame> cameras,
                                          const DepthMap* depth,
                                          const Eigen::Isometry3d& depth_T_reference,
                                          const Transform& predicted,
                                          const EdgeTrackerOptions& options) {
  if (!model_) return invalidInput("no model; expected a polygon model before tracking");
  CDFF_RETURN_IF_ERROR(checkTrackingInputs(cameras, depth, predicted));

  TrackingResult result;
  result.reference_T_model = predicted;
  result.covariance = noInformationCovariance();  // until an estimate replaces it
  result.camera_used.assign(cameras.size(), false);
  Eigen::Isometry3d pose = predicted.isometry();

  // The model must be in front of at least one sensor.
  const Placement placement = placeModel(*model_, cameras, depth, depth_T_reference, pose,
                                         options.visibility.near_clipping);
  if (!placement.in_front) {
    result.reason = fmt::format(
        "the predicted pose puts the model behind the camera (centre at "
        "z = {:.3f} m, radius {:.3f} m)",
        placement.nearest, model_->radius);
    matches_.assign(cameras.size(), ContourSamples{});
    return result;
  }

  const int passes = 1 + std::max(0, options.refinement_passes);
  PoseSolution solution;
  bool solved = false;
  for (int pass = 0; pass < passes; ++pass) {
    const Transform pose_t = Transform::fromIsometry(pose, predicted.parent_frame,
                                                     predicted.child_frame, predicted.stamp);
    EdgeSearchOptions search = options.search;
    if (pass > 0) search.search_distance = std::max(1, options.refinement_search_distance);
    Result<std::vector<bool>> used = matchCameras(cameras, pose, pose_t, search, options);
    if (!used) return used.status();
    std::vector<EdgeView> views;
    for (std::size_t c = 0; c < cameras.size(); ++c)
      if ((*used)[c]) views.push_back({&matches_[c]});

    DepthPoints depth_points;
    if (depth) {
      Result<DepthPoints> associated =
          depthPoints(*model_, *depth, depth_T_reference, pose, predicted, options);
      if (!associated) return associated.status();
      depth_points = std::move(associated).value();
    }
    if (views.empty() && depth_points.points.empty()) {
      result.reason = cameras.empty() ? "the depth map shows none of the model"
                                      : "no camera matched enough contour samples to image edges "
                                        "(dark, saturated or missing images, or the model out of "
                                        "view)";
      return result;
    }
    Result<PoseSolution> solved_pass =
        solvePose(pose, views, depth ? &depth_points : nullptr, options.solver);
    if (!solved_pass) {
      result.reason = solved_pass.status().message();
      return result;
    }
    solution = std::move(solved_pass).value();
    result.iterations += solution.iterations;
    result.camera_used = *used;
    if (solution.diverged) {
      result.reason = fmt::format(
          "the pose estimate diverged from the prediction (more than "
          "{} m or {} rad)",
          options.solver.divergence_translation, options.solver.divergence_rotation);
      return result;
    }
    pose = solution.reference_T_model;
    solved = true;
  }
  if (!solved) return result;
  reportEstimate(solution, pose, cameras, predicted, options, result);
  return result;
}

}  // namespace cdff::tracking
