#pragma once
// The orbit the relative motion happens on, and Clohessy-Wiltshire relative dynamics.
//
// Frames (docs/simulator.md):
//   eci   an inertial frame centred on the Earth; the target's circular orbit lies in its x-y
//         plane, starting on the x axis at t = 0 (argument of latitude u = n t).
//   lvlh  the target's local-vertical local-horizontal (Hill) frame: origin at the target's
//         centre of mass, x radial (away from the Earth), y along the orbital velocity, z along
//         the orbit normal. It rotates about z at the mean motion n relative to eci.
// Clohessy-Wiltshire equations of a chaser relative to the target, in lvlh, with the control
// (non-gravitational) acceleration f:
//   x'' - 2 n y' - 3 n^2 x = f_x,   y'' + 2 n x' = f_y,   z'' + n^2 z = f_z.
// Without an orbit ("free space", as on a ground test bench) n = 0, lvlh is inertial and the
// relative motion is plain kinematics.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace cdff::egse {

constexpr double kEarthMu = 3.986004418e14;  // m^3/s^2
constexpr double kEarthRadius = 6378137.0;   // m (equatorial)
constexpr double kSunMagnitude = -26.74;     // apparent visual magnitude at 1 AU

struct Orbit {
  bool enabled = true;      // false: free space, no Earth, n = 0
  double altitude = 500e3;  // m above kEarthRadius (circular orbit)

  double semiMajorAxis() const { return kEarthRadius + altitude; }
  /// Mean motion n (rad/s); 0 in free space.
  double meanMotion() const;
  /// eci_R_lvlh at time t.
  Eigen::Matrix3d eciRotationLvlh(double t) const;
  /// The target's position in eci at time t.
  Eigen::Vector3d targetPositionEci(double t) const;
  /// The Earth's centre in lvlh (constant: -a along x).
  Eigen::Vector3d earthCentreLvlh() const { return {-semiMajorAxis(), 0.0, 0.0}; }
  /// The acceleration CW dynamics give a free-flying chaser at (r, v) in lvlh: r'' = this + f.
  Eigen::Vector3d naturalAcceleration(const Eigen::Vector3d& r, const Eigen::Vector3d& v) const;
  /// Free-drift CW propagation (closed form) of (r0, v0) by t seconds.
  void propagate(const Eigen::Vector3d& r0, const Eigen::Vector3d& v0, double t, Eigen::Vector3d& r,
                 Eigen::Vector3d& v) const;
};

}  // namespace cdff::egse
