#include <cmath>

#include <fmt/ranges.h>
#include <Eigen/Cholesky>

#include "StateFromPose.gen.hpp"

namespace cdff::dfn {

class StateFromPoseUnknownTwist final : public StateFromPoseUnknownTwistBase {
 protected:
  Status onConfigure() override {
    if ((params_.position_sigma > 0) != (params_.attitude_sigma > 0))
      return invalidParameter(
          "position_sigma = {} and attitude_sigma = {} rad: set both (the covariance of a pose "
          "that comes without one) or neither",
          params_.position_sigma, params_.attitude_sigma);
    return Status::ok();
  }

  Status onProcess() override {
    if (!in.pose.isFresh()) return Status::ok();
    CDFF_RETURN_IF_ERROR(in.pose->validate());
    Matrix6d pose_covariance = in.pose->covariance;
    if (pose_covariance.isZero(0)) {
      if (params_.position_sigma <= 0)
        return invalidInput(
            "input 'pose' ({}_T_{} at {} us) has a zero covariance; expected a positive definite "
            "one, or the parameters position_sigma and attitude_sigma to state it",
            in.pose->pose.parent_frame, in.pose->pose.child_frame, in.pose->pose.stamp);
      pose_covariance.setZero();
      pose_covariance.diagonal() << Eigen::Vector3d::Constant(std::pow(params_.position_sigma, 2)),
          Eigen::Vector3d::Constant(std::pow(params_.attitude_sigma, 2));
    } else if (Eigen::LLT<Matrix6d>(pose_covariance).info() != Eigen::Success) {
      return invalidInput(
          "input 'pose' ({}_T_{} at {} us) has a covariance that is not positive definite "
          "(diagonal {}); expected the uncertainty of every pose component",
          in.pose->pose.parent_frame, in.pose->pose.child_frame, in.pose->pose.stamp,
          fmt::join(pose_covariance.diagonal(), ", "));
    }
    RigidBodyState state;
    state.pose = in.pose->pose;
    state.covariance.topLeftCorner<6, 6>() = pose_covariance;
    state.covariance.block<3, 3>(6, 6).diagonal().setConstant(
        std::pow(params_.linear_velocity_sigma, 2));
    state.covariance.block<3, 3>(9, 9).diagonal().setConstant(
        std::pow(params_.angular_velocity_sigma, 2));
    out.state.set(std::move(state));
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(StateFromPoseUnknownTwist);

}  // namespace cdff::dfn
