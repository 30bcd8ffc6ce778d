#include "cdff/types/geometry.hpp"

#include <cmath>

namespace cdff {

Transform Transform::identity(std::string parent, std::string child, Timestamp stamp) {
  Transform t;
  t.stamp = stamp;
  t.parent_frame = std::move(parent);
  t.child_frame = std::move(child);
  return t;
}

Transform Transform::fromIsometry(const Eigen::Isometry3d& a_T_b, std::string parent,
                                  std::string child, Timestamp stamp) {
  Transform t;
  t.stamp = stamp;
  t.parent_frame = std::move(parent);
  t.child_frame = std::move(child);
  t.translation = a_T_b.translation();
  t.rotation = Eigen::Quaterniond(a_T_b.linear()).normalized();
  return t;
}

Eigen::Isometry3d Transform::isometry() const {
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() = rotation.toRotationMatrix();
  iso.translation() = translation;
  return iso;
}

Transform Transform::inverse() const {
  Transform inv;
  inv.stamp = stamp;
  inv.parent_frame = child_frame;
  inv.child_frame = parent_frame;
  inv.rotation = rotation.conjugate();
  inv.translation = -(inv.rotation * translation);
  return inv;
}

Result<Transform> Transform::compose(const Transform& b_T_c) const {
  if (!child_frame.empty() && !b_T_c.parent_frame.empty() && child_frame != b_T_c.parent_frame) {
    return invalidInput(
        "cannot compose {}_T_{} with {}_T_{}: inner frames '{}' and '{}' differ; expected a_T_b * "
        "b_T_c",
        parent_frame, child_frame, b_T_c.parent_frame, b_T_c.child_frame, child_frame,
        b_T_c.parent_frame);
  }
  Transform a_T_c;
  a_T_c.stamp = std::max(stamp, b_T_c.stamp);
  a_T_c.parent_frame = parent_frame;
  a_T_c.child_frame = b_T_c.child_frame;
  a_T_c.rotation = (rotation * b_T_c.rotation).normalized();
  a_T_c.translation = translation + rotation * b_T_c.translation;
  return a_T_c;
}

Status Transform::validate() const {
  const std::string name = fmt::format("transform {}_T_{}", parent_frame, child_frame);
  CDFF_RETURN_IF_ERROR(checkFinite(translation, (name + " translation").c_str()));
  CDFF_RETURN_IF_ERROR(checkFinite(rotation.coeffs(), (name + " rotation").c_str()));
  const double norm = rotation.norm();
  if (std::abs(norm - 1.0) > 1e-6) {
    return invalidInput("{} rotation quaternion has norm {:.9g}; expected a unit quaternion", name,
                        norm);
  }
  return Status::ok();
}

namespace {
template <int N>
Status validateCovariance(const Eigen::Matrix<double, N, N>& covariance, const std::string& name) {
  CDFF_RETURN_IF_ERROR(checkFinite(covariance, name.c_str()));
  for (int i = 0; i < N; ++i) {
    if (covariance(i, i) < 0.0)
      return invalidInput("{} has a negative variance {} at ({}, {}); expected >= 0", name,
                          covariance(i, i), i, i);
  }
  const double asymmetry = (covariance - covariance.transpose()).cwiseAbs().maxCoeff();
  const double scale = std::max(1.0, covariance.cwiseAbs().maxCoeff());
  if (asymmetry > 1e-9 * scale)
    return invalidInput("{} is not symmetric (max |C - C^T| = {:.3g}); expected a symmetric matrix",
                        name, asymmetry);
  return Status::ok();
}
}  // namespace

Status PoseWithCovariance::validate() const {
  CDFF_RETURN_IF_ERROR(pose.validate());
  return validateCovariance<6>(covariance, "pose covariance");
}

PoseWithCovariance RigidBodyState::poseWithCovariance() const {
  PoseWithCovariance p;
  p.pose = pose;
  p.covariance = covariance.topLeftCorner<6, 6>();
  return p;
}

Status RigidBodyState::validate() const {
  CDFF_RETURN_IF_ERROR(pose.validate());
  CDFF_RETURN_IF_ERROR(checkFinite(twist.linear, "linear velocity"));
  CDFF_RETURN_IF_ERROR(checkFinite(twist.angular, "angular velocity"));
  return validateCovariance<12>(covariance, "state covariance");
}

double angularDistance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

Eigen::Quaterniond expSO3(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle < 1e-12) {
    // First-order expansion keeps the map smooth at zero.
    Eigen::Quaterniond q(1.0, 0.5 * rotation_vector.x(), 0.5 * rotation_vector.y(),
                         0.5 * rotation_vector.z());
    return q.normalized();
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, rotation_vector / angle));
}

Eigen::Vector3d logSO3(const Eigen::Quaterniond& rotation) {
  Eigen::Quaterniond q = rotation.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();  // shortest rotation
  const double sin_half = q.vec().norm();
  if (sin_half < 1e-12) return 2.0 * q.vec();
  const double angle = 2.0 * std::atan2(sin_half, q.w());
  return q.vec() / sin_half * angle;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  const Eigen::Matrix3d k = skew(phi);
  if (angle < 1e-6) return Eigen::Matrix3d::Identity() + 0.5 * k + k * k / 6.0;
  const double a2 = angle * angle;
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(angle)) / a2 * k +
         (angle - std::sin(angle)) / (a2 * angle) * k * k;
}

Eigen::Matrix3d inverseLeftJacobianSO3(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  const Eigen::Matrix3d k = skew(phi);
  if (angle < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * k + k * k / 12.0;
  const double half = 0.5 * angle;
  const double coefficient = (1.0 - half * std::cos(half) / std::sin(half)) / (angle * angle);
  return Eigen::Matrix3d::Identity() - 0.5 * k + coefficient * k * k;
}

}  // namespace cdff
