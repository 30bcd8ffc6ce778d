#pragma once
// Far-range relative navigation (seed §4.1.1): the target's position and velocity relative to
// the servicer in the target's orbital frame (LVLH: x radial, y along-track, z orbit normal),
// propagated with the Clohessy-Wiltshire equations, and the camera geometry that turns it into
// an image position. Shared by BearingPrediction and BearingFilter, so that the prediction the
// matcher searches around and the filter's own prediction are the same.

#include <optional>
#include <utility>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/status.hpp"

namespace cdff::tracking {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix9d = Eigen::Matrix<double, 9, 9>;

/// The state: x = [p, v, b], p the target's centre minus the servicer's (m, LVLH axes), v its
/// rate, b the bias of the servicer's accelerometer (m/s^2, servicer axes) when an IMU's thrust
/// drives the model (imu_thrust.hpp). Without an IMU, b and its covariance block stay zero and
/// the filter is the 6-state one.
struct RelativeState {
  Timestamp stamp = 0;
  Vector9d x = Vector9d::Zero();
  Matrix9d covariance = Matrix9d::Zero();

  Eigen::Vector3d position() const { return x.head<3>(); }
  Eigen::Vector3d velocity() const { return x.segment<3>(3); }
  /// Whether the bias states are in use (their covariance is set).
  bool hasBias() const { return covariance.bottomRightCorner<3, 3>().trace() > 0; }
};

/// The mean motion (rad/s) of a circular orbit `altitude` metres above the Earth's equatorial
/// radius; 0 for altitude 0 (free space).
double meanMotion(double altitude);
/// The closed-form Clohessy-Wiltshire transition over dt seconds at mean motion n (rad/s; 0:
/// free space, straight lines). The difference of two free-flying positions obeys the same
/// linear equations, so it applies to the target relative to the servicer.
Matrix6d cwTransition(double n, double dt);
/// The covariance a white acceleration of `psd` (m^2/s^3 per axis) adds over dt seconds.
Matrix6d whiteAccelerationNoise(double psd, double dt);
/// Propagates `s` to `stamp` (forward only; an earlier stamp is an error) with no measured
/// thrust: the bias states, if any, keep their value (their covariance grows by `bias_walk_psd`
/// per second, (m/s^2)^2/s).
Status propagate(RelativeState& s, Timestamp stamp, double mean_motion, double psd,
                 double bias_walk_psd = 0.0);

/// The servicer's attitude lvlh_R_servicer and its covariance (rad^2), where known.
using ServicerAttitude = std::optional<std::pair<Eigen::Quaterniond, Eigen::Matrix3d>>;

/// As a RigidBodyState: lvlh_T_servicer, the servicer in the target's orbital frame (origin at
/// the target's centre: the simulator's /truth/tf/servicer), so translation -p and twist.linear
/// -v with their covariances; the rotation the servicer's attitude with its covariance where
/// `attitude` gives it, else identity with a zero block. twist.angular is not an angular
/// velocity: it carries the accelerometer bias b (zero without an IMU) and the covariance's
/// omega rows and columns b's (with its cross-covariance), so that BearingPrediction propagates
/// the filter's model; `with_bias` false leaves them zero (a state for users).
RigidBodyState toRigidBodyState(const RelativeState& s, const ServicerAttitude& attitude = {},
                                bool with_bias = true);
/// The inverse; the error names the field that is not a far-range state.
Result<RelativeState> fromRigidBodyState(const RigidBodyState& state);

/// Where an LVLH direction lands in the camera at one instant: the camera's intrinsics, its
/// mounting on the servicer and the servicer's attitude in LVLH.
struct BearingGeometry {
  CameraModel camera;
  Eigen::Matrix3d servicer_R_camera = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d lvlh_R_servicer = Eigen::Matrix3d::Identity();
  /// The camera's position on the servicer (m, servicer frame): the state is the target relative
  /// to the servicer's origin, the camera sees it from here (0.05 m off is 3 px at 100 m).
  Eigen::Vector3d servicer_t_camera = Eigen::Vector3d::Zero();

  /// The pixel of an LVLH vector (distorted as the camera is); nullopt behind the camera.
  std::optional<Eigen::Vector2d> pixelOf(const Eigen::Vector3d& p_lvlh) const;
  /// The unit ray of a pixel in the camera frame (undistorted).
  Eigen::Vector3d rayOf(const Eigen::Vector2d& pixel) const;
  /// d pixel / d p_lvlh and d pixel / d theta for an attitude error theta of the servicer
  /// (lvlh_R_servicer exp(theta)), by central differences.
  Eigen::Matrix<double, 2, 3> positionJacobian(const Eigen::Vector3d& p_lvlh) const;
  Eigen::Matrix<double, 2, 3> attitudeJacobian(const Eigen::Vector3d& p_lvlh) const;
};

/// The servicer's attitude at `stamp` from a short history of samples lvlh_T_servicer: slerp
/// between the two that bracket it, or the nearest within `tolerance` seconds; the attitude
/// covariance block (rad^2) of the nearer sample.
class AttitudeHistory {
 public:
  Status add(const PoseWithCovariance& lvlh_T_servicer);
  Result<std::pair<Eigen::Quaterniond, Eigen::Matrix3d>> at(Timestamp stamp,
                                                            double tolerance) const;
  bool empty() const { return samples_.empty(); }

 private:
  std::vector<PoseWithCovariance> samples_;  // by stamp, the last 64
};

}  // namespace cdff::tracking
