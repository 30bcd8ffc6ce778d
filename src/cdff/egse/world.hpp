#pragma once
// The simulated world: the orbit, both spacecraft's motion, the sun, and the ground truth that
// follows from them (relative pose and twist, control acceleration, eclipse).

#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/egse/trajectory.hpp"
#include "cdff/types/geometry.hpp"

namespace cdff::egse {

/// A body's full kinematic state at time t.
struct BodyState {
  Eigen::Isometry3d lvlh_T_body = Eigen::Isometry3d::Identity();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();      // m/s, d/dt in lvlh
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();  // m/s^2, d2/dt2 in lvlh
  /// Non-gravitational acceleration (thrust), in lvlh axes: what an accelerometer at the
  /// body's centre of mass measures (as specific force).
  Eigen::Vector3d control_acceleration = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();      // rad/s rel. to eci, body axes
  Eigen::Vector3d angular_acceleration = Eigen::Vector3d::Zero();  // rad/s^2, body axes
};

struct Sun {
  Eigen::Vector3d direction = Eigen::Vector3d(0, -1, 0);  // unit, towards the sun
  bool inertial = false;  // direction fixed in eci (else fixed in lvlh, e.g. for a lighting study)
  double irradiance = 1.0;  // relative to the solar constant at 1 AU
};

class World {
 public:
  World(const Orbit& orbit, std::unique_ptr<Translation> servicer_translation,
        std::unique_ptr<Attitude> servicer_attitude, std::unique_ptr<Attitude> target_attitude,
        const Sun& sun);

  const Orbit& orbit() const { return orbit_; }
  const Sun& sun() const { return sun_; }
  BodyState servicer(double t) const;
  /// The target: its centre of mass is the lvlh origin.
  BodyState target(double t) const;
  Eigen::Isometry3d servicerTtarget(double t) const;
  /// Velocity of the target relative to the servicer, expressed in the servicer frame: linear =
  /// d/dt of servicer_T_target's translation (as seen from the servicer), angular = the target's
  /// angular velocity relative to the servicer (central differences, h = 1e-4 s).
  Twist targetTwistInServicer(double t) const;
  /// Unit vector towards the sun, in lvlh.
  Eigen::Vector3d sunDirection(double t) const;
  /// True when the target is in the Earth's (cylindrical) shadow.
  bool inEclipse(double t) const;

  // The laws, for the attitude pointing at the target and for tests.
  const Translation& servicerTranslation() const { return *servicer_translation_; }

 private:
  Orbit orbit_;
  std::unique_ptr<Translation> servicer_translation_;
  std::unique_ptr<Attitude> servicer_attitude_;
  std::unique_ptr<Attitude> target_attitude_;
  Sun sun_;
};

}  // namespace cdff::egse
