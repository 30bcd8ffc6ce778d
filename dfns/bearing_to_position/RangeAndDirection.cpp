#include <cmath>

#include <fmt/ranges.h>
#include <Eigen/Cholesky>

#include "BearingToPosition.gen.hpp"

namespace cdff::dfn {

class BearingToPositionRangeAndDirection final : public BearingToPositionRangeAndDirectionBase {
 protected:
  Status onConfigure() override {
    if (params_.target_frame.empty())
      return invalidParameter(
          "parameter 'target_frame' is empty; expected the output's child frame (e.g. target)");
    return Status::ok();
  }

  Status onProcess() override {
    const Bearing& b = *in.bearing;
    CDFF_RETURN_IF_ERROR(b.validate().withContext("input 'bearing'"));
    if (b.frame_id.empty())
      return invalidInput("input 'bearing' at t = {} us has no frame_id; expected its frame",
                          b.stamp);
    if (std::isnan(b.range)) {
      warn(fmt::format(
          "bearing at t = {} us has no range (NaN: no radar range fused); no position without "
          "one",
          b.stamp));
      return Status::ok();
    }
    const Eigen::Vector3d d = b.direction.normalized();
    const double r = b.range;
    PoseWithCovariance p;
    p.pose = Transform::identity(b.frame_id, params_.target_frame, b.stamp);
    p.pose.translation = r * d;
    const Eigen::Matrix3d position = r * r * b.covariance + b.range_variance * d * d.transpose();
    p.covariance.setZero();
    p.covariance.topLeftCorner<3, 3>() = 0.5 * (position + position.transpose());
    if (Eigen::LLT<Eigen::Matrix3d>(p.covariance.topLeftCorner<3, 3>()).info() != Eigen::Success)
      return invalidInput(
          "input 'bearing' at t = {} us gives a singular position covariance (range variance "
          "{} m^2, direction covariance diagonal {} rad^2); expected a positive range variance "
          "and a direction covariance of rank 2 across the direction",
          b.stamp, b.range_variance, fmt::join(b.covariance.diagonal(), ", "));
    const double sa = params_.unknown_attitude_sigma;
    p.covariance.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * sa * sa;
    out.position.set(std::move(p));
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(BearingToPositionRangeAndDirection);

}  // namespace cdff::dfn
