// BearingPrediction/ClohessyWiltshire: the filter's state propagated to the image's time and
// projected into it.
#include <cmath>

#include "BearingPrediction.gen.hpp"
#include "cdff/tracking/imu_thrust.hpp"
#include "cdff/tracking/relative_motion.hpp"

namespace cdff::dfn {

class BearingPredictionClohessyWiltshire final : public BearingPredictionClohessyWiltshireBase {
 protected:
  Status onConfigure() override {
    attitudes_ = {};
    imu_ = {};
    return Status::ok();
  }

  Status onProcess() override {
    if (in.attitude.isFresh()) CDFF_RETURN_IF_ERROR(attitudes_.add(*in.attitude));
    if (in.imu.isFresh() && params_.use_imu)
      CDFF_RETURN_IF_ERROR(imu_.add(*in.imu, in.imu_mount.get()));
    if (!in.image.isFresh()) return Status::ok();  // an attitude or IMU sample, kept for later
    for (const auto& [set, name] : {std::pair{in.state.get() != nullptr, "state"},
                                    std::pair{in.camera_mount.get() != nullptr, "camera_mount"}})
      if (!set) return invalidInput("input '{}' is not set; expected it with every image", name);
    const Image& image = *in.image;
    if (!image.camera)
      return invalidInput(
          "input 'image' at t = {} us has no camera model; expected a calibrated "
          "image",
          image.stamp);
    CDFF_RETURN_IF_ERROR(image.camera->validate().withContext("input 'image' camera model"));
    Result<tracking::RelativeState> state = tracking::fromRigidBodyState(*in.state);
    if (!state) return state.status().withContext("input 'state'");
    const Transform& mount = *in.camera_mount;
    CDFF_RETURN_IF_ERROR(mount.validate().withContext("input 'camera_mount'"));
    if (mount.child_frame != image.frame_id)
      return invalidInput("input 'camera_mount' is {}_T_{}; expected the mounting of '{}'",
                          mount.parent_frame, mount.child_frame, image.frame_id);
    const tracking::RelativeState last = *state;
    if (image.stamp < last.stamp)
      return invalidInput("input 'image' at t = {} us is older than the state (t = {} us)",
                          image.stamp, last.stamp);
    const tracking::MeasuredThrust thrust = imu_.between(
        last.stamp, image.stamp, attitudes_, params_.attitude_tolerance,
        {params_.accel_noise_density, params_.accel_bias_sigma, params_.accel_bias_random_walk});
    if (thrust.samples_without_attitude > 0)
      warn(fmt::format("{} IMU samples before t = {} us left out: no servicer attitude within {} s",
                       thrust.samples_without_attitude, image.stamp, params_.attitude_tolerance));
    CDFF_RETURN_IF_ERROR(tracking::propagate(*state, image.stamp,
                                             tracking::meanMotion(params_.orbit_altitude),
                                             params_.acceleration_psd, thrust));
    auto attitude = attitudes_.at(image.stamp, params_.attitude_tolerance);
    if (!attitude) {
      warn(attitude.status().message());
      return Status::ok();
    }
    tracking::BearingGeometry g{*image.camera, mount.rotation.toRotationMatrix(),
                                attitude->first.toRotationMatrix(), mount.translation};
    const Eigen::Vector3d p = state->x.head<3>();
    const std::optional<Eigen::Vector2d> centre = g.pixelOf(p);
    if (!centre) {
      warn("the predicted target is behind the camera");
      return Status::ok();
    }
    const Eigen::Matrix<double, 2, 3> jp = g.positionJacobian(p), ja = g.attitudeJacobian(p);
    ImageRegion prediction = ImageRegion::box(centre->x(), centre->y(), 1, 1);
    if (in.reference.get()) {
      // The last match moved to the predicted centre and scaled about it by the range change.
      const ImageRegion& ref = *in.reference;
      const double ratio = last.x.head<3>().norm() / p.norm();
      const Eigen::Vector2d c = ref.centre();
      Eigen::Matrix3d move = Eigen::Matrix3d::Identity();
      move(0, 0) = move(1, 1) = ratio;
      move.topRightCorner<2, 1>() = *centre - ratio * c;
      prediction = ref;
      prediction.homography = move * ref.homography;
    }
    prediction.stamp = image.stamp;
    prediction.frame_id = image.frame_id;
    prediction.score = std::numeric_limits<double>::quiet_NaN();
    prediction.source = "prediction";
    prediction.covariance = jp * state->covariance.topLeftCorner<3, 3>() * jp.transpose() +
                            ja * attitude->second * ja.transpose();
    prediction.covariance =
        0.5 * (prediction.covariance + prediction.covariance.transpose()).eval();
    out.prediction.set(std::move(prediction));
    return Status::ok();
  }

 private:
  tracking::AttitudeHistory attitudes_;
  tracking::ImuHistory imu_;
};
CDFF_REGISTER_DFI(BearingPredictionClohessyWiltshire);

}  // namespace cdff::dfn
