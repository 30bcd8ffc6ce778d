#pragma once
// Relative trajectories of the servicer and attitude motion of both spacecraft.
//
// A trajectory gives the servicer's position in lvlh and its first two time derivatives taken in
// the rotating lvlh frame (what the CW equations use); the servicer's control acceleration is
// then r'' minus the natural CW acceleration. Attitude laws give a body's orientation in lvlh;
// angular velocities are relative to the inertial frame (what a gyro measures).

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/egse/orbit.hpp"
#include "cdff/types/status.hpp"

namespace cdff::egse {

struct TranslationState {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      // m, in lvlh
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();      // m/s, d/dt in lvlh
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();  // m/s^2, d2/dt2 in lvlh
};

class Translation {
 public:
  virtual ~Translation() = default;
  virtual TranslationState at(double t) const = 0;
};

/// A fixed point in lvlh.
std::unique_ptr<Translation> holdTranslation(const Eigen::Vector3d& position);
/// A straight line from `start` to `end` between t0 and t1, resting before and after.
/// `smooth`: minimum-jerk profile (zero velocity and acceleration at both ends); otherwise
/// constant velocity (infinite acceleration at the ends: avoid with an IMU).
std::unique_ptr<Translation> lineTranslation(const Eigen::Vector3d& start,
                                             const Eigen::Vector3d& end, double t0, double t1,
                                             bool smooth);
/// A natural cubic spline through (times[i], points[i]) (C2: continuous acceleration), resting
/// at the first and last point outside the time span. Times strictly increasing, >= 2 points.
Result<std::unique_ptr<Translation>> splineTranslation(const std::vector<double>& times,
                                                       const std::vector<Eigen::Vector3d>& points);
/// Minimum-jerk legs from points[i] at times[i] to points[i + 1] at times[i + 1], at rest at each
/// point (a rendezvous's hold points: a repeated point is a hold). Same checks as the spline.
Result<std::unique_ptr<Translation>> legsTranslation(const std::vector<double>& times,
                                                     const std::vector<Eigen::Vector3d>& points);
/// A circle (or spiral) about `centre`: radius(t) = radius + radial_rate * t in the plane
/// normal to `axis`, at `rate` rad/s from `phase` (rad, measured from `reference`, a direction
/// in the plane).
std::unique_ptr<Translation> flyAroundTranslation(const Eigen::Vector3d& centre,
                                                  const Eigen::Vector3d& axis,
                                                  const Eigen::Vector3d& reference, double radius,
                                                  double radial_rate, double rate, double phase);
/// Free drift under CW dynamics from (r0, v0) at t = 0.
std::unique_ptr<Translation> cwTranslation(const Orbit& orbit, const Eigen::Vector3d& r0,
                                           const Eigen::Vector3d& v0);

/// A body's orientation in lvlh with its angular velocity and acceleration relative to eci,
/// expressed in the body frame.
struct AttitudeState {
  Eigen::Quaterniond lvlh_R_body = Eigen::Quaterniond::Identity();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();      // rad/s, body axes
  Eigen::Vector3d angular_acceleration = Eigen::Vector3d::Zero();  // rad/s^2, body axes
};

class Attitude {
 public:
  virtual ~Attitude() = default;
  virtual AttitudeState at(double t) const = 0;
};

/// Fixed in lvlh (rotating with the orbit).
std::unique_ptr<Attitude> lvlhFixedAttitude(const Orbit& orbit,
                                            const Eigen::Quaterniond& lvlh_R_body);
/// Fixed in eci (lvlh_R_body at t = 0 given).
std::unique_ptr<Attitude> inertialAttitude(const Orbit& orbit,
                                           const Eigen::Quaterniond& lvlh_R_body0);
/// Torque-free rotation from lvlh_R_body0 with body angular velocity omega0 (relative to eci,
/// body axes). With `inertia` (principal moments, kg m^2) it follows Euler's equations (so an
/// asymmetric body nutates); without, the body rate stays constant. Integrated with RK4 on a
/// fixed 5 ms grid (deterministic), to `horizon` seconds.
std::unique_ptr<Attitude> tumblingAttitude(const Orbit& orbit,
                                           const Eigen::Quaterniond& lvlh_R_body0,
                                           const Eigen::Vector3d& omega0,
                                           const std::optional<Eigen::Vector3d>& inertia,
                                           double horizon);
/// Body +x towards the point `aim` (another body's origin, given by `aim_at`), body +z as close
/// as possible to `up` (lvlh); optional yaw/pitch offsets (rad) of the boresight.
std::unique_ptr<Attitude> pointingAttitude(const Orbit& orbit, const Translation* self,
                                           const Translation* aim_at, const Eigen::Vector3d& up,
                                           double yaw_offset, double pitch_offset);
/// `base` turned by a pointing jitter (an attitude controller's residual motion): about each
/// body axis a sum of three sinusoids of 0.03-0.5 Hz with phases and frequencies drawn from
/// `seed`, of `rms` radians RMS per axis.
std::unique_ptr<Attitude> jitteredAttitude(const Orbit& orbit, std::unique_ptr<Attitude> base,
                                           double rms, std::uint64_t seed);

}  // namespace cdff::egse
