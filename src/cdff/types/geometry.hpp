#pragma once
// Rigid transforms, poses with covariance and rigid-body states.
//
// Naming: a Transform `a_T_b` maps points expressed in frame b into frame a
// (p_a = a_T_b * p_b); `parent_frame` is a and `child_frame` is b.
// Perturbations and twists are expressed in the parent frame a (docs/conventions.md):
//   t = t_hat + dt,   R = exp([dtheta]x) * R_hat,
// and covariances are ordered [dt (3), dtheta (3)] (+ [dv (3), domega (3)] for states).

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix12d = Eigen::Matrix<double, 12, 12>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

struct Transform {
  Timestamp stamp = 0;
  std::string parent_frame;                                      // a in a_T_b
  std::string child_frame;                                       // b in a_T_b
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();         // m, origin of b expressed in a
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // unit, rotates b into a

  static Transform identity(std::string parent, std::string child, Timestamp stamp = 0);
  static Transform fromIsometry(const Eigen::Isometry3d& a_T_b, std::string parent,
                                std::string child, Timestamp stamp = 0);

  Eigen::Isometry3d isometry() const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p_b) const {
    return translation + rotation * p_b;
  }
  /// b_T_a, with the frame names swapped.
  Transform inverse() const;
  /// a_T_c = a_T_b * b_T_c; checks that the inner frame names agree when both are set.
  Result<Transform> compose(const Transform& b_T_c) const;

  /// Ok when translation and rotation are finite and the quaternion has unit norm (1e-6).
  Status validate() const;
};

struct PoseWithCovariance {
  Transform pose;
  Matrix6d covariance = Matrix6d::Zero();  // [dt, dtheta], parent frame, m^2 / rad^2

  /// Ok when the pose is valid and the covariance is finite, symmetric and has a
  /// non-negative diagonal.
  Status validate() const;
};

/// Velocity of frame b relative to frame a, expressed in frame a.
struct Twist {
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();   // m/s
  Eigen::Vector3d angular = Eigen::Vector3d::Zero();  // rad/s
};

/// Pose and twist of frame b (child) in frame a (parent) with their joint covariance.
struct RigidBodyState {
  Transform pose;
  Twist twist;
  Matrix12d covariance = Matrix12d::Zero();  // [dt, dtheta, dv, domega]

  PoseWithCovariance poseWithCovariance() const;
  Status validate() const;
};

/// Angle of the rotation between two unit quaternions, in [0, pi] rad.
double angularDistance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

/// Rotation vector (axis * angle) <-> quaternion: the SO(3) exponential and logarithm.
Eigen::Quaterniond expSO3(const Eigen::Vector3d& rotation_vector);
Eigen::Vector3d logSO3(const Eigen::Quaterniond& rotation);

/// The cross-product matrix: skew(a) * b = a x b.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);
/// Left Jacobian of SO(3) at rotation vector phi: exp(phi + d) ~ exp(J_l(phi) d) exp(phi) for a
/// small d. Used to propagate attitude covariances through a rotation by phi.
Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& phi);
/// Its inverse, e.g. to map a rotation residual log(R_a R_b^T) back to a perturbation.
Eigen::Matrix3d inverseLeftJacobianSO3(const Eigen::Vector3d& phi);

/// Ok when every entry of `m` is finite; the message names `what` and the first bad entry.
template <typename Derived>
Status checkFinite(const Eigen::MatrixBase<Derived>& m, const char* what) {
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      if (!std::isfinite(static_cast<double>(m(r, c))))
        return invalidInput("{} has a non-finite entry ({}) at ({}, {}); expected finite values",
                            what, static_cast<double>(m(r, c)), r, c);
  return Status::ok();
}

/// Poses in one frame (a trajectory, candidate poses), shown by Foxglove as arrows.
struct PoseArray {
  Timestamp stamp = 0;
  std::string frame_id;
  std::vector<Eigen::Isometry3d> poses;
};

}  // namespace cdff
