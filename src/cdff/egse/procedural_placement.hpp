#pragma once
// Placing the parts of the procedural targets (procedural.cpp, procedural_hexagonal.cpp): a part
// is built about its own origin along +z and moved into the body frame.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace cdff::egse::placement {

/// The pose with translation `t` and rotation `R`.
inline Eigen::Isometry3d at(const Eigen::Vector3d& t,
                            const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity()) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = t;
  pose.linear() = R;
  return pose;
}

/// The rotation taking +z to `axis` (unit).
inline Eigen::Matrix3d zTo(const Eigen::Vector3d& axis) {
  return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis).toRotationMatrix();
}

}  // namespace cdff::egse::placement
