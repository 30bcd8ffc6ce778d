#include "cdff/egse/orbit.hpp"

#include <cmath>

namespace cdff::egse {

double Orbit::meanMotion() const {
  if (!enabled) return 0.0;
  const double a = semiMajorAxis();
  return std::sqrt(kEarthMu / (a * a * a));
}

Eigen::Matrix3d Orbit::eciRotationLvlh(double t) const {
  return Eigen::AngleAxisd(meanMotion() * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Eigen::Vector3d Orbit::targetPositionEci(double t) const {
  if (!enabled) return Eigen::Vector3d::Zero();
  const double u = meanMotion() * t;
  return semiMajorAxis() * Eigen::Vector3d(std::cos(u), std::sin(u), 0.0);
}

Eigen::Vector3d Orbit::naturalAcceleration(const Eigen::Vector3d& r,
                                           const Eigen::Vector3d& v) const {
  const double n = meanMotion();
  return {2 * n * v.y() + 3 * n * n * r.x(), -2 * n * v.x(), -n * n * r.z()};
}

void Orbit::propagate(const Eigen::Vector3d& r0, const Eigen::Vector3d& v0, double t,
                      Eigen::Vector3d& r, Eigen::Vector3d& v) const {
  const double n = meanMotion();
  if (n == 0.0) {
    r = r0 + v0 * t;
    v = v0;
    return;
  }
  const double s = std::sin(n * t), c = std::cos(n * t);
  const double x0 = r0.x(), y0 = r0.y(), z0 = r0.z();
  const double vx = v0.x(), vy = v0.y(), vz = v0.z();
  // The CW state transition (x radial, y along-track, z normal).
  r.x() = (4 - 3 * c) * x0 + s / n * vx + 2 / n * (1 - c) * vy;
  r.y() = 6 * (s - n * t) * x0 + y0 - 2 / n * (1 - c) * vx + (4 * s - 3 * n * t) / n * vy;
  r.z() = c * z0 + s / n * vz;
  v.x() = 3 * n * s * x0 + c * vx + 2 * s * vy;
  v.y() = 6 * n * (c - 1) * x0 - 2 * s * vx + (4 * c - 3) * vy;
  v.z() = -n * s * z0 + c * vz;
}

}  // namespace cdff::egse
