// ModelBasedTracking/EdgeTracker: maps the DFN's parameters and ports onto
// tracking::AcquiringEdgeTracker (src/cdff/tracking/), the edge tracker with its acquisition.
#include "cdff/tracking/acquiring_edge_tracker.hpp"

#include <optional>

#include "ModelBasedTracking.gen.hpp"
#include "tracking_common.hpp"

namespace cdff::dfn {

class ModelBasedTrackingEdgeTracker final : public ModelBasedTrackingEdgeTrackerBase {
 protected:
  Status onConfigure() override {
    Result<Eigen::Isometry3d> depth_T_camera = mbt::depthExtrinsics(params_.depth_extrinsics);
    if (!depth_T_camera) return depth_T_camera.status();
    CDFF_RETURN_IF_ERROR(models_.load(params_.model_file));
    depth_T_camera_ = *depth_T_camera;
    tracker_.configure(options(params_));
    // The model file's tracking form is built now rather than in the first frame, which also
    // runs the acquisition and has the same time budget as the others.
    if (std::shared_ptr<const PolygonModel> file_model = models_.useFileModel())
      CDFF_RETURN_IF_ERROR(tracker_.setModel(*file_model).withContext("parameter 'model_file'"));
    return Status::ok();
  }

  Status onProcess() override {
    Result<PoseWithCovariance> predicted = mbt::prediction(in);
    if (!predicted) return predicted.status();
    tracking::PosePrediction prediction{*predicted, std::nullopt};
    if (in.predicted_state.hasValue())
      prediction.carried_covariance =
          tracking::carriedPoseCovariance(*in.predicted_state, mbt::sensorStamp(in));
    bool changed = false;
    Result<std::shared_ptr<const PolygonModel>> model = models_.select(in.model, changed);
    if (!model) return model.status();
    if (changed || !tracker_.hasModel())
      CDFF_RETURN_IF_ERROR(tracker_.setModel(**model).withContext("model"));
    Result<mbt::Cameras> cameras = mbt::gatherCameras(in, predicted->pose.parent_frame);
    if (!cameras) return cameras.status();
    if (cameras->frames.empty() && !in.depth.hasValue())
      return invalidInput("no 'image', 'stereo_images' or 'depth'; expected at least one sensor");
    if (in.depth.hasValue())
      CDFF_RETURN_IF_ERROR(in.depth->validate().withContext("input 'depth'"));

    const tracking::FrameMeasurements frame{
        cameras->frames, in.depth.hasValue() ? in.depth.get() : nullptr, depth_T_camera_};
    Result<tracking::AcquiringTrackingResult> tracked = tracker_.track(frame, prediction);
    if (!tracked) return tracked.status();
    const tracking::TrackingResult& result = tracked->tracking;
    if (result.status != TrackingStatus::kTracking)
      warn(fmt::format("{}: {}", toString(result.status), result.reason));

    PoseWithCovariance pose;
    pose.pose = result.reference_T_model;  // the prediction when lost
    pose.covariance = result.covariance;
    out.pose.set(std::move(pose));
    mbt::publishStatus(out, result.status);
    // Not yet a track: `cdff eval` and the DFPC's conditions take ACQUIRING as not tracking.
    if (tracked->acquiring) out.track_state.set(TrackState::kAcquiring);
    out.inlier_ratio.set(result.inlier_ratio);
    out.feature_count.set(static_cast<int>(result.inliers + result.depth_points));
    return Status::ok();
  }

 private:
  static tracking::AcquiringEdgeTrackerOptions options(const Parameters& p) {
    tracking::AcquiringEdgeTrackerOptions a;
    tracking::EdgeTrackerOptions& o = a.tracking;
    o.model.cylinder_segments = p.cylinder_segments;
    o.model.circle_segments = p.cylinder_segments;
    o.visibility.near_clipping = p.near_clipping;
    o.visibility.far_clipping = p.far_clipping;
    o.visibility.max_view_angle = p.max_view_angle;
    o.visibility.min_crease_angle = p.min_crease_angle;
    o.visibility.two_sided_faces = p.two_sided_faces;
    o.visibility.min_segment_length = p.min_segment_length;
    o.sampling.step = p.sample_step;
    o.sampling.max_samples = p.max_samples;
    o.search.search_distance = p.search_distance;
    o.search.angular_threshold = p.angular_threshold;
    o.search.min_gradient = p.min_gradient;
    o.search.relative_gradient = p.relative_gradient;
    o.search.noise_sigmas = p.noise_sigmas;
    o.search.min_gradient_floor = p.min_gradient_floor;
    o.search.max_candidates = p.max_candidates;
    o.search.half_width = p.mask_half_width;
    o.solver.max_iterations = p.max_iterations;
    o.solver.convergence_translation = p.convergence_translation;
    o.solver.convergence_rotation = p.convergence_rotation;
    o.solver.divergence_translation = p.divergence_translation;
    o.solver.divergence_rotation = p.divergence_rotation;
    o.solver.tukey_constant = p.tukey_constant;
    o.solver.min_edge_sigma = p.min_edge_sigma;
    o.solver.inlier_threshold = p.inlier_threshold;
    o.solver.depth_weight = p.depth_weight;
    o.solver.min_depth_sigma = p.min_depth_sigma;
    o.depth.step_x = o.depth.step_y = p.depth_step;
    o.depth.max_distance = p.depth_max_distance;
    o.refinement_passes = p.refinement_passes;
    o.refinement_search_distance = p.refinement_search_distance;
    o.min_inlier_ratio = p.min_inlier_ratio;
    o.degraded_inlier_ratio = p.degraded_inlier_ratio;
    o.min_camera_match_ratio = p.min_camera_match_ratio;
    o.visibility_update_translation = p.visibility_update_translation;
    o.visibility_update_rotation = p.visibility_update_rotation;
    a.acquisition.sigmas = p.acquisition_sigmas;
    a.acquisition.max_search_distance = p.acquisition_max_search_distance;
    a.acquisition.lateral_first = p.acquisition_lateral_first;
    a.acquisition.restarts = p.acquisition_restarts;
    a.acquisition.restart_sigmas = p.acquisition_restart_sigmas;
    a.coarse_alignment = p.acquisition_coarse_search;
    a.chamfer.canny_low = p.acquisition_canny_low;
    return a;
  }

  Eigen::Isometry3d depth_T_camera_ = Eigen::Isometry3d::Identity();
  mbt::ModelSource models_;
  tracking::AcquiringEdgeTracker tracker_;
};

CDFF_REGISTER_DFI(ModelBasedTrackingEdgeTracker);

}  // namespace cdff::dfn
