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
    const bool pose = in.pose.isFresh(), transform = in.transform.isFresh();
    if (!pose && !transform) return Status::ok();  // only a calibration arrived
    if (!extrinsic_)
      return invalidInput(
          "no extrinsic with child frame '{}' yet (the last one received was {}_T_{}); expected "
          "the calibration (e.g. /chaser/tf/lidar) before the first pose",
          params_.frame, in.extrinsic->parent_frame, in.extrinsic->child_frame);
    const Transform map = params_.inverse ? extrinsic_->inverse() : *extrinsic_;
    if (pose) {
      CDFF_RETURN_IF_ERROR(in.pose->validate());
      Result<Transform> moved = reexpress(in.pose->pose, map, "input 'pose'");
      if (!moved) return moved.status();
      PoseWithCovariance out_pose{std::move(moved).value(), in.pose->covariance};
      const Eigen::Matrix3d r = map.rotation.toRotationMatrix();
      Matrix6d rotate = Matrix6d::Zero();
      rotate.topLeftCorner<3, 3>() = r;
      rotate.bottomRightCorner<3, 3>() = r;
      out_pose.covariance = rotate * in.pose->covariance * rotate.transpose();
      out.pose.set(std::move(out_pose));
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
