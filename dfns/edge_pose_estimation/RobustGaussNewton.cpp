#include "EdgePoseEstimation.gen.hpp"
#include "cdff/tracking/edge_tracker.hpp"
#include "cdff/tracking/pose_solver.hpp"

namespace cdff::dfn {

class EdgePoseEstimationRobustGaussNewton final : public EdgePoseEstimationRobustGaussNewtonBase {
 protected:
  Status onConfigure() override {
    Result<Eigen::Isometry3d> extrinsics =
        tracking::isometryFromVector(params_.depth_extrinsics, "parameter 'depth_extrinsics'");
    if (!extrinsics) return extrinsics.status();
    depth_T_reference_ = *extrinsics;
    return Status::ok();
  }

  Status onProcess() override {
    std::vector<const ContourSamples*> inputs = {in.matches.get()};
    if (in.matches_secondary.hasValue()) inputs.push_back(in.matches_secondary.get());
    Result<Eigen::Isometry3d> predicted_pose = commonPrediction(inputs);
    if (!predicted_pose) return predicted_pose.status();
    const Eigen::Isometry3d prediction = *predicted_pose;
    const ModelContours& first = *in.matches->contours;
    const Transform predicted =
        Transform::fromIsometry(prediction, first.camera_T_reference.child_frame,
                                first.camera_T_model.child_frame, first.stamp);

    std::vector<tracking::EdgeView> views;
    std::size_t failed = 0;
    for (const ContourSamples* samples : inputs) {
      const double ratio = samples->samples.empty()
                               ? 0.0
                               : static_cast<double>(samples->matchedCount()) /
                                     static_cast<double>(samples->samples.size());
      if (ratio < params_.min_camera_match_ratio) {
        ++failed;
        continue;
      }
      views.push_back({samples});
    }

    tracking::DepthPoints depth_points;
    if (in.depth.hasValue()) {
      tracking::DepthAssociationOptions options;
      options.step_x = options.step_y = params_.depth_step;
      options.max_distance = params_.depth_max_distance;
      Result<tracking::DepthPoints> associated =
          tracking::associateDepth(*in.depth, depth_T_reference_, first.faces, prediction, options);
      if (!associated) return associated.status().withContext("input 'depth'");
      depth_points = std::move(associated).value();
    }

    const tracking::PoseSolverOptions options = solverOptions();
    PoseWithCovariance pose;
    pose.pose = predicted;
    pose.covariance = tracking::noInformationCovariance();
    TrackingStatus status = TrackingStatus::kLost;
    double inlier_ratio = 0, rms = 0;
    std::string reason;
    if (views.empty() && depth_points.points.empty()) {
      reason = "no camera matched enough samples to image edges";
    } else {
      Result<tracking::PoseSolution> solution = tracking::solvePose(
          prediction, views, in.depth.hasValue() ? &depth_points : nullptr, options);
      if (!solution) {
        if (solution.status().code() != StatusCode::kNumericalFailure) return solution.status();
        reason = solution.status().message();
      } else if (solution->diverged) {
        reason = fmt::format(
            "the estimate diverged from the prediction (more than {} m or {:.6g} deg)",
            options.divergence_translation, options.divergence_rotation / kRadiansPerDegree);
      } else {
        status =
            tracking::assessTracking(*solution, inputs.size(), failed, params_.min_inlier_ratio,
                                     params_.degraded_inlier_ratio, reason);
        inlier_ratio = solution->inlierRatio();
        rms = solution->edge_rms;
        if (status != TrackingStatus::kLost) {
          pose.pose = Transform::fromIsometry(solution->reference_T_model, predicted.parent_frame,
                                              predicted.child_frame, predicted.stamp);
          pose.covariance = solution->covariance;
        }
      }
    }
    if (status != TrackingStatus::kTracking) warn(fmt::format("{}: {}", toString(status), reason));
    out.pose.set(std::move(pose));
    out.status.set(static_cast<int>(status));
    out.inlier_ratio.set(inlier_ratio);
    out.residual_rms.set(rms);
    return Status::ok();
  }

 private:
  // The model's predicted pose in the rig (reference_T_model), which the inputs' contours must
  // share; each input must be a matched one.
  static Result<Eigen::Isometry3d> commonPrediction(
      const std::vector<const ContourSamples*>& inputs) {
    const char* names[] = {"input 'matches'", "input 'matches_secondary'"};
    Eigen::Isometry3d prediction = Eigen::Isometry3d::Identity();
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      CDFF_RETURN_IF_ERROR(inputs[i]->validate(names[i]));
      if (!inputs[i]->matched)
        return invalidInput(
            "{} holds samples that were never matched; expected the output of "
            "EdgeMatching",
            names[i]);
      const ModelContours& c = *inputs[i]->contours;
      const Eigen::Isometry3d r_T_m =
          c.camera_T_reference.isometry().inverse() * c.camera_T_model.isometry();
      if (i == 0) {
        prediction = r_T_m;
      } else if ((r_T_m.translation() - prediction.translation()).norm() > 1e-6 ||
                 Eigen::AngleAxisd(r_T_m.linear().transpose() * prediction.linear()).angle() >
                     1e-6) {
        return invalidInput(
            "the two cameras' contours were computed for different poses of the "
            "model in the rig; expected the same prediction for both");
      }
    }
    return prediction;
  }

  tracking::PoseSolverOptions solverOptions() const {
    tracking::PoseSolverOptions options;
    options.max_iterations = params_.max_iterations;
    options.convergence_translation = params_.convergence_translation;
    options.convergence_rotation = params_.convergence_rotation;
    options.divergence_translation = params_.divergence_translation;
    options.divergence_rotation = params_.divergence_rotation;
    options.tukey_constant = params_.tukey_constant;
    options.min_edge_sigma = params_.min_edge_sigma;
    options.inlier_threshold = params_.inlier_threshold;
    options.min_measurements = params_.min_measurements;
    options.depth_weight = params_.depth_weight;
    options.min_depth_sigma = params_.min_depth_sigma;
    return options;
  }

  Eigen::Isometry3d depth_T_reference_ = Eigen::Isometry3d::Identity();
};

CDFF_REGISTER_DFI(EdgePoseEstimationRobustGaussNewton);

}  // namespace cdff::dfn
