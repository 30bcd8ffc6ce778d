// Time, Point, Pose, Transform, TransformWithCovariance, RigidBodyState and Bearing.
#include <cmath>
#include <limits>

#include "cdff/asn1/convert.hpp"

namespace cdff::asn1 {

namespace detail {

namespace {

// The quaternion's norm within this of 1 (Transform::validate()'s tolerance).
Status checkUnit(const Eigen::Quaterniond& q, std::string_view field) {
  if (std::abs(q.norm() - 1.0) <= 1e-6) return Status::ok();
  return invalidInput("{}.orientation has norm {}; expected a unit quaternion (1 within 1e-6)",
                      field, q.norm());
}

// The stamped, framed header that Transform, TransformWithCovariance and RigidBodyState share.
template <typename T>
Status setFrames(T& out, const Transform& pose, std::string_view type) {
  out.time.microseconds = pose.stamp;
  CDFF_RETURN_IF_ERROR(
      setString(out.parent_frame, pose.parent_frame, fmt::format("{}.parent-frame", type)));
  CDFF_RETURN_IF_ERROR(
      setString(out.child_frame, pose.child_frame, fmt::format("{}.child-frame", type)));
  CDFF_RETURN_IF_ERROR(checkUnit(pose.rotation, fmt::format("{}.pose", type)));
  return setPose(out.pose, pose.translation, pose.rotation, fmt::format("{}.pose", type));
}

template <typename T>
Result<Transform> getFrames(const T& in, std::string_view type) {
  Transform pose;
  pose.stamp = in.time.microseconds;
  Result<std::string> parent = getString(in.parent_frame, fmt::format("{}.parent-frame", type));
  if (!parent) return parent.status();
  Result<std::string> child = getString(in.child_frame, fmt::format("{}.child-frame", type));
  if (!child) return child.status();
  pose.parent_frame = std::move(parent).value();
  pose.child_frame = std::move(child).value();
  CDFF_RETURN_IF_ERROR(
      getPose(in.pose, pose.translation, pose.rotation, fmt::format("{}.pose", type)));
  return pose;
}

// A decoded value that its CDFF type refuses is corrupt data, named by its ASN.1 type.
Status checkDecoded(const Status& valid, std::string_view type) {
  if (valid) return valid;
  return corruptData("uPER {}: {}", type, valid.message());
}

}  // namespace

Status encodeTimestamp(Timestamp stamp, std::vector<std::uint8_t>& out) {
  Filled<Time_t> time(asn_DEF_Time);
  time.value.microseconds = stamp;
  return encodeStruct(asn_DEF_Time, &time.value, out);
}

Result<Timestamp> decodeTimestamp(std::span<const std::uint8_t> data) {
  Result<Decoded<Time_t>> time = decodeAs<Time_t>(asn_DEF_Time, data);
  if (!time) return time.status();
  return Timestamp{(*time)->microseconds};
}

Status encodeTransform(const Transform& v, std::vector<std::uint8_t>& out) {
  Filled<Transform_t> t(asn_DEF_Transform);
  CDFF_RETURN_IF_ERROR(setFrames(t.value, v, "Transform"));
  return encodeStruct(asn_DEF_Transform, &t.value, out);
}

Result<Transform> decodeTransform(std::span<const std::uint8_t> data) {
  Result<Decoded<Transform_t>> t = decodeAs<Transform_t>(asn_DEF_Transform, data);
  if (!t) return t.status();
  Result<Transform> v = getFrames(**t, "Transform");
  if (v) CDFF_RETURN_IF_ERROR(checkDecoded(v->validate(), "Transform"));
  return v;
}

Status encodePoseWithCovariance(const PoseWithCovariance& v, std::vector<std::uint8_t>& out) {
  Filled<TransformWithCovariance_t> t(asn_DEF_TransformWithCovariance);
  CDFF_RETURN_IF_ERROR(setFrames(t.value, v.pose, "TransformWithCovariance"));
  CDFF_RETURN_IF_ERROR(setMatrix(t.value.cov, v.covariance, "TransformWithCovariance.cov"));
  return encodeStruct(asn_DEF_TransformWithCovariance, &t.value, out);
}

Result<PoseWithCovariance> decodePoseWithCovariance(std::span<const std::uint8_t> data) {
  Result<Decoded<TransformWithCovariance_t>> t =
      decodeAs<TransformWithCovariance_t>(asn_DEF_TransformWithCovariance, data);
  if (!t) return t.status();
  PoseWithCovariance v;
  Result<Transform> pose = getFrames(**t, "TransformWithCovariance");
  if (!pose) return pose.status();
  v.pose = std::move(pose).value();
  CDFF_RETURN_IF_ERROR(getMatrix((*t)->cov, v.covariance, "TransformWithCovariance.cov"));
  CDFF_RETURN_IF_ERROR(checkDecoded(v.validate(), "TransformWithCovariance"));
  return v;
}

Status encodeRigidBodyState(const RigidBodyState& v, std::vector<std::uint8_t>& out) {
  Filled<RigidBodyState_t> s(asn_DEF_RigidBodyState);
  CDFF_RETURN_IF_ERROR(setFrames(s.value, v.pose, "RigidBodyState"));
  CDFF_RETURN_IF_ERROR(setVector(s.value.velocity, v.twist.linear, "RigidBodyState.velocity"));
  CDFF_RETURN_IF_ERROR(
      setVector(s.value.angular_velocity, v.twist.angular, "RigidBodyState.angular-velocity"));
  CDFF_RETURN_IF_ERROR(setMatrix(s.value.cov, v.covariance, "RigidBodyState.cov"));
  return encodeStruct(asn_DEF_RigidBodyState, &s.value, out);
}

Result<RigidBodyState> decodeRigidBodyState(std::span<const std::uint8_t> data) {
  Result<Decoded<RigidBodyState_t>> s = decodeAs<RigidBodyState_t>(asn_DEF_RigidBodyState, data);
  if (!s) return s.status();
  RigidBodyState v;
  Result<Transform> pose = getFrames(**s, "RigidBodyState");
  if (!pose) return pose.status();
  v.pose = std::move(pose).value();
  Result<Eigen::Vector3d> linear = getVector((*s)->velocity, "RigidBodyState.velocity");
  if (!linear) return linear.status();
  Result<Eigen::Vector3d> angular =
      getVector((*s)->angular_velocity, "RigidBodyState.angular-velocity");
  if (!angular) return angular.status();
  v.twist = {*linear, *angular};
  CDFF_RETURN_IF_ERROR(getMatrix((*s)->cov, v.covariance, "RigidBodyState.cov"));
  CDFF_RETURN_IF_ERROR(checkDecoded(v.validate(), "RigidBodyState"));
  return v;
}

namespace {

// Bearing's range fields: NaN (unknown) is an absent field; an infinite value is an error.
Status setOptional(double v, T_Double_t*& out, std::string_view field) {
  if (std::isnan(v)) return Status::ok();
  CDFF_RETURN_IF_ERROR(checkFinite(v, field));
  out = static_cast<T_Double_t*>(std::malloc(sizeof(T_Double_t)));
  if (!out) return Status(StatusCode::kInternal, fmt::format("{}: out of memory", field));
  *out = v;
  return Status::ok();
}

Result<double> getOptional(const T_Double_t* in, std::string_view field) {
  if (!in) return std::numeric_limits<double>::quiet_NaN();
  if (!std::isfinite(*in))
    return corruptData("{} is {}; T-Double holds finite numbers only", field, *in);
  return *in;
}

}  // namespace

Status encodeBearing(const Bearing& v, std::vector<std::uint8_t>& out) {
  Filled<Bearing_t> b(asn_DEF_Bearing);
  b.value.time.microseconds = v.stamp;
  CDFF_RETURN_IF_ERROR(setString(b.value.frame_id, v.frame_id, "Bearing.frame-id"));
  CDFF_RETURN_IF_ERROR(setVector(b.value.direction, v.direction, "Bearing.direction"));
  CDFF_RETURN_IF_ERROR(setMatrix(b.value.cov, v.covariance, "Bearing.cov"));
  CDFF_RETURN_IF_ERROR(setOptional(v.range, b.value.range, "Bearing.range"));
  CDFF_RETURN_IF_ERROR(
      setOptional(v.range_variance, b.value.range_variance, "Bearing.range-variance"));
  CDFF_RETURN_IF_ERROR(setOptional(v.range_rate, b.value.range_rate, "Bearing.range-rate"));
  CDFF_RETURN_IF_ERROR(setOptional(v.range_rate_variance, b.value.range_rate_variance,
                                   "Bearing.range-rate-variance"));
  CDFF_RETURN_IF_ERROR(setString(b.value.designation, v.designation, "Bearing.designation"));
  return encodeStruct(asn_DEF_Bearing, &b.value, out);
}

Result<Bearing> decodeBearing(std::span<const std::uint8_t> data) {
  Result<Decoded<Bearing_t>> b = decodeAs<Bearing_t>(asn_DEF_Bearing, data);
  if (!b) return b.status();
  const Bearing_t& in = **b;
  Bearing v;
  v.stamp = in.time.microseconds;
  Result<std::string> frame = getString(in.frame_id, "Bearing.frame-id");
  Result<std::string> designation = getString(in.designation, "Bearing.designation");
  Result<Eigen::Vector3d> direction = getVector(in.direction, "Bearing.direction");
  Result<double> range = getOptional(in.range, "Bearing.range");
  Result<double> range_variance = getOptional(in.range_variance, "Bearing.range-variance");
  Result<double> range_rate = getOptional(in.range_rate, "Bearing.range-rate");
  Result<double> rate_variance = getOptional(in.range_rate_variance, "Bearing.range-rate-variance");
  for (const Status* s :
       {&frame.status(), &designation.status(), &direction.status(), &range.status(),
        &range_variance.status(), &range_rate.status(), &rate_variance.status()})
    if (!*s) return *s;
  v.frame_id = std::move(frame).value();
  v.designation = std::move(designation).value();
  v.direction = *direction;
  v.range = *range;
  v.range_variance = *range_variance;
  v.range_rate = *range_rate;
  v.range_rate_variance = *rate_variance;
  CDFF_RETURN_IF_ERROR(getMatrix(in.cov, v.covariance, "Bearing.cov"));
  CDFF_RETURN_IF_ERROR(checkDecoded(v.validate(), "Bearing"));
  return v;
}

}  // namespace detail

Status encodePoint(const Eigen::Vector3d& point, std::vector<std::uint8_t>& out) {
  detail::Filled<Point_t> p(asn_DEF_Point);
  CDFF_RETURN_IF_ERROR(detail::setVector(p.value, point, "Point"));
  return detail::encodeStruct(asn_DEF_Point, &p.value, out);
}

Result<Eigen::Vector3d> decodePoint(std::span<const std::uint8_t> data) {
  Result<detail::Decoded<Point_t>> p = detail::decodeAs<Point_t>(asn_DEF_Point, data);
  if (!p) return p.status();
  return detail::getVector(**p, "Point");
}

Status encodePose(const Eigen::Isometry3d& pose, std::vector<std::uint8_t>& out) {
  detail::Filled<Pose_t> p(asn_DEF_Pose);
  const Eigen::Quaterniond rotation(pose.rotation());
  CDFF_RETURN_IF_ERROR(detail::setPose(p.value, pose.translation(), rotation, "Pose"));
  return detail::encodeStruct(asn_DEF_Pose, &p.value, out);
}

Result<Eigen::Isometry3d> decodePose(std::span<const std::uint8_t> data) {
  Result<detail::Decoded<Pose_t>> p = detail::decodeAs<Pose_t>(asn_DEF_Pose, data);
  if (!p) return p.status();
  Eigen::Vector3d translation;
  Eigen::Quaterniond rotation;
  CDFF_RETURN_IF_ERROR(detail::getPose(**p, translation, rotation, "Pose"));
  if (std::abs(rotation.norm() - 1.0) > 1e-6)
    return corruptData("uPER Pose: orientation has norm {}; expected a unit quaternion",
                       rotation.norm());
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = rotation.toRotationMatrix();
  out.translation() = translation;
  return out;
}

}  // namespace cdff::asn1
