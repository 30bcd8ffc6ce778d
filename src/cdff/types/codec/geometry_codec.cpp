// MCAP codecs and product JSON of the geometry types: Transform, PoseWithCovariance,
// RigidBodyState and PoseArray.
#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory
using F = pb::FieldType;

Status encode(const Transform& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("transform", v.stamp);
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.parent_frame);
  w.string(3, v.child_frame);
  putXyz(w, 4, v.translation.x(), v.translation.y(), v.translation.z());
  putQuaternion(w, 5, v.rotation);
  return Status::ok();
}

namespace {

template <int N>
void putRowMajor(pb::Writer& w, std::uint32_t f, const Eigen::Matrix<double, N, N>& m) {
  double values[N * N];
  for (int r = 0; r < N; ++r)
    for (int c = 0; c < N; ++c) values[r * N + c] = m(r, c);
  w.packed<double>(f, std::span<const double>(values, N * N));
}

void putPoseInFrame(pb::Writer& w, const Transform& pose) {
  putTimestamp(w, 1, pose.stamp);
  w.string(2, pose.parent_frame);
  putPose(w, 3, pose.translation, pose.rotation);
  w.string(1000, pose.child_frame);
}

}  // namespace

Status encode(const PoseWithCovariance& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.pose.stamp < 0) return negativeStamp("pose", v.pose.stamp);
  pb::Writer w(out.bytes);
  putPoseInFrame(w, v.pose);
  putRowMajor<6>(w, 1001, v.covariance);
  return Status::ok();
}

Status encode(const RigidBodyState& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.pose.stamp < 0) return negativeStamp("rigid body state", v.pose.stamp);
  pb::Writer w(out.bytes);
  putPoseInFrame(w, v.pose);
  putRowMajor<12>(w, 1001, v.covariance);
  putXyz(w, 1002, v.twist.linear.x(), v.twist.linear.y(), v.twist.linear.z());
  putXyz(w, 1003, v.twist.angular.x(), v.twist.angular.y(), v.twist.angular.z());
  return Status::ok();
}

Status encode(const PoseArray& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("pose array", v.stamp);
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  for (const Eigen::Isometry3d& p : v.poses)
    putPose(w, 3, p.translation(), Eigen::Quaterniond(p.rotation()));
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, Transform& out) {
  out = Transform{};
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.FrameTransform", [&](pb::Reader& r) {
    if (!isLen(r)) return true;
    switch (r.field()) {
      case 1:
        inner = readTimestamp(r.bytes(), out.stamp);
        break;
      case 2:
        out.parent_frame = r.string();
        break;
      case 3:
        out.child_frame = r.string();
        break;
      case 4:
        inner = readXyz(r.bytes(), out.translation);
        break;
      case 5:
        inner = readQuaternion(r.bytes(), out.rotation);
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  return inner;
}

namespace {

struct PoseFields {
  Transform pose;
  std::vector<double> covariance;
  Eigen::Vector3d linear = Eigen::Vector3d::Zero(), angular = Eigen::Vector3d::Zero();
};

Status readPoseInFrame(Bytes data, PoseFields& out) {
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.PoseInFrame", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r)) inner = readTimestamp(r.bytes(), out.pose.stamp);
        break;
      case 2:
        if (isLen(r)) out.pose.parent_frame = r.string();
        break;
      case 3:
        if (isLen(r)) inner = readPose(r.bytes(), out.pose.translation, out.pose.rotation);
        break;
      case 1000:
        if (isLen(r)) out.pose.child_frame = r.string();
        break;
      case 1001:
        return appendRepeated(r, out.covariance);
      case 1002:
        if (isLen(r)) inner = readXyz(r.bytes(), out.linear);
        break;
      case 1003:
        if (isLen(r)) inner = readXyz(r.bytes(), out.angular);
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  return inner;
}

// Fills the leading block of `m` from a row-major n x n matrix (n = 6 or 12).
template <int N>
Status fillCovariance(const std::vector<double>& values, Eigen::Matrix<double, N, N>& m) {
  m.setZero();
  if (values.empty()) return Status::ok();
  int n = 0;
  if (values.size() == 36) n = 6;
  if (values.size() == 144) n = 12;
  if (n == 0)
    return corruptMessage(
        "foxglove.PoseInFrame",
        fmt::format("cdff_covariance has {} entries; expected 36 or 144", values.size()));
  const int k = std::min(n, N);
  for (int r = 0; r < k; ++r)
    for (int c = 0; c < k; ++c) m(r, c) = values[static_cast<std::size_t>(r * n + c)];
  return Status::ok();
}

}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>&, PoseWithCovariance& out) {
  out = PoseWithCovariance{};
  PoseFields f;
  CDFF_RETURN_IF_ERROR(readPoseInFrame(data, f));
  out.pose = std::move(f.pose);
  return fillCovariance<6>(f.covariance, out.covariance);
}

Status decode(Bytes data, const std::shared_ptr<const void>&, RigidBodyState& out) {
  out = RigidBodyState{};
  PoseFields f;
  CDFF_RETURN_IF_ERROR(readPoseInFrame(data, f));
  out.pose = std::move(f.pose);
  out.twist.linear = f.linear;
  out.twist.angular = f.angular;
  return fillCovariance<12>(f.covariance, out.covariance);
}

Status decode(Bytes data, const std::shared_ptr<const void>&, PoseArray& out) {
  out = PoseArray{};
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.PosesInFrame", [&](pb::Reader& r) {
    if (!isLen(r)) return true;
    if (r.field() == 1) inner = readTimestamp(r.bytes(), out.stamp);
    if (r.field() == 2) out.frame_id = r.string();
    if (r.field() == 3) {
      Eigen::Vector3d t;
      Eigen::Quaterniond q;
      inner = readPose(r.bytes(), t, q);
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.linear() = q.normalized().toRotationMatrix();
      pose.translation() = t;
      out.poses.push_back(pose);
    }
    return inner.isOk();
  }));
  return inner;
}

// ---- product JSON -----------------------------------------------------------------------------

namespace {

json vec(const Eigen::Vector3d& v) {
  return {v.x(), v.y(), v.z()};
}

template <typename Matrix>
json matrix(const Matrix& m) {
  json out = json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) out.push_back(m(r, c));
  return out;
}

// JSON numbers cannot be NaN: nlohmann writes null, read back as NaN.
double readNumber(const json& j) {
  return j.is_null() ? std::nan("") : j.get<double>();
}

Eigen::Vector3d readVec(const json& j) {
  if (!j.is_array() || j.size() != 3) throw std::runtime_error("expected [x, y, z]");
  return {readNumber(j[0]), readNumber(j[1]), readNumber(j[2])};
}

template <typename Matrix>
void readMatrix(const json& j, Matrix& m) {
  if (!j.is_array() || j.size() != static_cast<std::size_t>(m.size()))
    throw std::runtime_error(
        fmt::format("expected {} numbers (row-major {}x{})", m.size(), m.rows(), m.cols()));
  std::size_t i = 0;
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) m(r, c) = readNumber(j[i++]);
}

Transform readTransform(const json& j) {
  Transform t;
  t.stamp = j.at("stamp_us").get<Timestamp>();
  t.parent_frame = j.at("parent_frame").get<std::string>();
  t.child_frame = j.at("child_frame").get<std::string>();
  t.translation = readVec(j.at("translation"));
  const json& q = j.at("rotation_wxyz");
  if (!q.is_array() || q.size() != 4)
    throw std::runtime_error("expected rotation_wxyz [w, x, y, z]");
  t.rotation =
      Eigen::Quaterniond(readNumber(q[0]), readNumber(q[1]), readNumber(q[2]), readNumber(q[3]));
  return t;
}

}  // namespace

json toJson(const Transform& t) {
  return {{"stamp_us", t.stamp},
          {"parent_frame", t.parent_frame},
          {"child_frame", t.child_frame},
          {"translation", vec(t.translation)},
          {"rotation_wxyz", {t.rotation.w(), t.rotation.x(), t.rotation.y(), t.rotation.z()}}};
}

json toJson(const PoseWithCovariance& p) {
  return json{{"pose", toJson(p.pose)}, {"covariance", matrix(p.covariance)}};
}

json toJson(const RigidBodyState& s) {
  return json{{"pose", toJson(s.pose)},
              {"twist", {{"linear", vec(s.twist.linear)}, {"angular", vec(s.twist.angular)}}},
              {"covariance", matrix(s.covariance)}};
}

Status fromJson(const json& j, Transform& out) {
  return readJsonValue("Transform", [&] { out = readTransform(j); });
}

Status fromJson(const json& j, PoseWithCovariance& out) {
  return readJsonValue("PoseWithCovariance", [&] {
    PoseWithCovariance p;
    p.pose = readTransform(j.at("pose"));
    readMatrix(j.at("covariance"), p.covariance);
    out = std::move(p);
  });
}

Status fromJson(const json& j, RigidBodyState& out) {
  return readJsonValue("RigidBodyState", [&] {
    RigidBodyState s;
    s.pose = readTransform(j.at("pose"));
    s.twist.linear = readVec(j.at("twist").at("linear"));
    s.twist.angular = readVec(j.at("twist").at("angular"));
    readMatrix(j.at("covariance"), s.covariance);
    out = std::move(s);
  });
}

}  // namespace cdff::codec
