#include <optional>

#include "FrameTransformation.gen.hpp"

namespace cdff::dfn {

class FrameTransformationRigid final : public FrameTransformationRigidBase {
 protected:
  Status onConfigure() override {
    if (params_.frame.empty())
      return invalidParameter("parameter 'frame' is empty; expected the extrinsic's child frame");
    extrinsic_.reset();
    return Status::ok();
  }

  Status onProcess() override {
    if (in.extrinsic.isFresh() && in.extrinsic->child_frame == params_.frame) {
      CDFF_RETURN_IF_ERROR(in.extrinsic->validate());
      extrinsic_ = *in.extrinsic;
    }
    const bool pose = in.pose.isFresh(), transform = in.transform.isFresh(),
               state = in.state.isFresh();
    if (!pose && !transform && !state) return Status::ok();  // only a calibration arrived
    if (!extrinsic_)
      return invalidInput(
          "no extrinsic with child frame '{}' yet (the last one received was {}_T_{}); expected "
          "the calibration (e.g. /chaser/tf/lidar) before the first pose",
          params_.frame, in.extrinsic->parent_frame, in.extrinsic->child_frame);
    const Transform map = params_.inverse ? extrinsic_->inverse() : *extrinsic_;
    const Eigen::Matrix3d r = map.rotation.toRotationMatrix();
    if (pose) {
      CDFF_RETURN_IF_ERROR(in.pose->validate());
      Result<Transform> moved = reexpress(in.pose->pose, map, "input 'pose'");
      if (!moved) return moved.status();
      PoseWithCovariance out_pose{std::move(moved).value(), in.pose->covariance};
      Matrix6d rotate = Matrix6d::Zero();
      rotate.topLeftCorner<3, 3>() = r;
      rotate.bottomRightCorner<3, 3>() = r;
      out_pose.covariance = rotate * in.pose->covariance * rotate.transpose();
      out.pose.set(std::move(out_pose));
    }
    if (state) {
      CDFF_RETURN_IF_ERROR(in.state->validate());
      Result<Transform> moved = reexpress(in.state->pose, map, "input 'state'");
      if (!moved) return moved.status();
      RigidBodyState out_state;
      out_state.pose = std::move(moved).value();
      // The mounting is rigid: a_T_c(t) = a_T_b * b_T_c(t), so d/dt of the origin and the
      // angular rate are b's, turned by a_R_b; every perturbation block turns the same way.
      out_state.twist.linear = r * in.state->twist.linear;
      out_state.twist.angular = r * in.state->twist.angular;
      Matrix12d rotate = Matrix12d::Zero();
      for (int block = 0; block < 4; ++block) rotate.block<3, 3>(3 * block, 3 * block) = r;
      out_state.covariance = rotate * in.state->covariance * rotate.transpose();
      out.state.set(std::move(out_state));
    }
    if (transform) {
      CDFF_RETURN_IF_ERROR(in.transform->validate());
      Result<Transform> moved = reexpress(*in.transform, map, "input 'transform'");
      if (!moved) return moved.status();
      out.transform.set(std::move(moved).value());
    }
    return Status::ok();
  }

 private:
  static Result<Transform> reexpress(const Transform& input, const Transform& map,
                                     const char* what) {
    if (input.parent_frame != map.child_frame)
      return invalidInput(
          "{} is {}_T_{}; expected a pose in frame '{}' (the extrinsic maps {} to {})", what,
          input.parent_frame, input.child_frame, map.child_frame, map.child_frame,
          map.parent_frame);
    Result<Transform> moved = map.compose(input);
    if (!moved) return moved.status();
    moved->stamp = input.stamp;
    return moved;
  }

  std::optional<Transform> extrinsic_;
};

CDFF_REGISTER_DFI(FrameTransformationRigid);

}  // namespace cdff::dfn
