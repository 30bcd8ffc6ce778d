// uPER encoding and decoding through asn1c's runtime, the field helpers of the conversions, and
// the dispatch from CDFF values to ASN.1 types.
#include <array>
#include <cmath>
#include <cstring>

#include "cdff/asn1/convert.hpp"
#include "per_decoder.h"
#include "per_encoder.h"

namespace cdff::asn1 {

namespace detail {

namespace {

int appendBytes(const void* buffer, size_t size, void* key) {
  auto* out = static_cast<std::vector<std::uint8_t>*>(key);
  const auto* bytes = static_cast<const std::uint8_t*>(buffer);
  out->insert(out->end(), bytes, bytes + size);
  return 0;
}

const char* decodeCode(asn_dec_rval_code_e code) {
  switch (code) {
    case RC_OK:
      return "ok";
    case RC_WMORE:
      return "truncated: the bytes end inside the value";
    case RC_FAIL:
      return "malformed";
  }
  return "malformed";
}

}  // namespace

Status encodeStruct(asn_TYPE_descriptor_t& def, const void* s, std::vector<std::uint8_t>& out) {
  std::array<char, 256> why{};
  std::size_t why_size = why.size();
  if (asn_check_constraints(&def, s, why.data(), &why_size) != 0)
    return invalidInput("{}: outside its ASN.1 constraints: {}", def.name, why.data());
  out.clear();
  const asn_enc_rval_t r = uper_encode(&def, const_cast<void*>(s), appendBytes, &out);
  if (r.encoded < 0)
    return Status(StatusCode::kInternal,
                  fmt::format("asn1c could not encode {} (at {}) although its constraints hold",
                              def.name, r.failed_type ? r.failed_type->name : def.name));
  return Status::ok();
}

Result<void*> decodeStruct(asn_TYPE_descriptor_t& def, std::span<const std::uint8_t> data) {
  void* s = nullptr;
  const asn_dec_rval_t r = uper_decode_complete(nullptr, &def, &s, data.data(), data.size());
  if (r.code != RC_OK) {
    ASN_STRUCT_FREE(def, s);
    return corruptData("uPER {} of {} bytes: {}", def.name, data.size(), decodeCode(r.code));
  }
  if (r.consumed != data.size()) {
    ASN_STRUCT_FREE(def, s);
    return corruptData("uPER {} of {} bytes: the value ends at byte {}; expected no trailing bytes",
                       def.name, data.size(), r.consumed);
  }
  // The decoder reads lengths up to the bits they take, not up to the SIZE bounds.
  std::array<char, 256> why{};
  std::size_t why_size = why.size();
  if (asn_check_constraints(&def, s, why.data(), &why_size) != 0) {
    ASN_STRUCT_FREE(def, s);
    return corruptData("uPER {}: outside its ASN.1 constraints: {}", def.name, why.data());
  }
  return s;
}

Status checkFinite(double v, std::string_view field) {
  if (std::isfinite(v)) return Status::ok();
  return invalidInput("{} is {}; T-Double holds finite numbers only", field, v);
}

Status setString(OCTET_STRING_t& out, const std::string& s, std::string_view field) {
  if (s.size() > kMaxStringBytes)
    return invalidInput("{} '{}...' has {} bytes; the bound of T-String is {} bytes", field,
                        s.substr(0, 32), s.size(), kMaxStringBytes);
  if (OCTET_STRING_fromBuf(&out, s.data(), static_cast<int>(s.size())) != 0)
    return Status(StatusCode::kInternal, fmt::format("{}: out of memory", field));
  return Status::ok();
}

Result<std::string> getString(const OCTET_STRING_t& s, std::string_view field) {
  if (s.size < 0 || static_cast<std::size_t>(s.size) > kMaxStringBytes || (!s.buf && s.size))
    return corruptData("{} has {} bytes; expected at most {}", field, s.size, kMaxStringBytes);
  return std::string(reinterpret_cast<const char*>(s.buf), static_cast<std::size_t>(s.size));
}

Status setDoubles(asn_anonymous_sequence_& list, std::span<const double> values,
                  std::string_view field) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i]))
      return invalidInput("{}[{}] is {}; T-Double holds finite numbers only", field, i, values[i]);
    auto* d = static_cast<double*>(std::malloc(sizeof(double)));
    if (!d) return Status(StatusCode::kInternal, fmt::format("{}: out of memory", field));
    *d = values[i];
    if (ASN_SEQUENCE_ADD(&list, d) != 0) {
      std::free(d);
      return Status(StatusCode::kInternal, fmt::format("{}: out of memory", field));
    }
  }
  return Status::ok();
}

Status getDoubles(const asn_anonymous_sequence_& list, std::span<double> values,
                  std::string_view field) {
  if (list.count < 0 || static_cast<std::size_t>(list.count) != values.size())
    return corruptData("{} has {} numbers; expected {}", field, list.count, values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double v = *static_cast<const double*>(list.array[i]);
    if (!std::isfinite(v))
      return corruptData("{}[{}] is {}; T-Double holds finite numbers only", field, i, v);
    values[i] = v;
  }
  return Status::ok();
}

Status setVector(Vector3d_t& out, const Eigen::Vector3d& v, std::string_view field) {
  return setDoubles(anonymous(out.data.list), std::span<const double>(v.data(), 3), field);
}

Result<Eigen::Vector3d> getVector(const Vector3d_t& v, std::string_view field) {
  Eigen::Vector3d out;
  CDFF_RETURN_IF_ERROR(getDoubles(anonymous(v.data.list), std::span<double>(out.data(), 3), field));
  return out;
}

Status setPose(Pose_t& out, const Eigen::Vector3d& translation, const Eigen::Quaterniond& rotation,
               std::string_view field) {
  CDFF_RETURN_IF_ERROR(setVector(out.position, translation, fmt::format("{}.position", field)));
  const Eigen::Vector3d im = rotation.vec();
  CDFF_RETURN_IF_ERROR(setDoubles(anonymous(out.orientation.im.list),
                                  std::span<const double>(im.data(), 3),
                                  fmt::format("{}.orientation.im", field)));
  out.orientation.re = rotation.w();
  return checkFinite(out.orientation.re, fmt::format("{}.orientation.re", field));
}

Status getPose(const Pose_t& p, Eigen::Vector3d& translation, Eigen::Quaterniond& rotation,
               std::string_view field) {
  Result<Eigen::Vector3d> t = getVector(p.position, fmt::format("{}.position", field));
  if (!t) return t.status();
  Eigen::Vector3d im;
  CDFF_RETURN_IF_ERROR(getDoubles(anonymous(p.orientation.im.list), std::span<double>(im.data(), 3),
                                  fmt::format("{}.orientation.im", field)));
  if (!std::isfinite(p.orientation.re))
    return corruptData("{}.orientation.re is {}; T-Double holds finite numbers only", field,
                       p.orientation.re);
  translation = *t;
  rotation = Eigen::Quaterniond(p.orientation.re, im.x(), im.y(), im.z());
  return Status::ok();
}

}  // namespace detail

// ---- the table ---------------------------------------------------------------------------------

namespace {

struct Entry {
  Asn1Type type;
  std::string_view name;
  TypeId cdff;
};

const std::vector<Entry>& entries() {
  static const std::vector<Entry> table = {
      {Asn1Type::kTime, "Time", TypeId::of<Timestamp>()},
      {Asn1Type::kPoint, "Point", TypeId()},
      {Asn1Type::kPose, "Pose", TypeId()},
      {Asn1Type::kTransform, "Transform", TypeId::of<Transform>()},
      {Asn1Type::kTransformWithCovariance, "TransformWithCovariance",
       TypeId::of<PoseWithCovariance>()},
      {Asn1Type::kRigidBodyState, "RigidBodyState", TypeId::of<RigidBodyState>()},
      {Asn1Type::kBearing, "Bearing", TypeId::of<Bearing>()},
      {Asn1Type::kCalibrationMatrix, "CalibrationMatrix", TypeId::of<CameraModel>()},
      {Asn1Type::kImage8UC1, "Image8UC1", TypeId::of<Image>()},
      {Asn1Type::kImage8UC3, "Image8UC3", TypeId::of<Image>()},
      {Asn1Type::kImage32FC1, "Image32FC1", TypeId::of<Image>()},
      {Asn1Type::kPointCloud, "PointCloud", TypeId::of<PointCloud>()},
  };
  return table;
}

const Entry& entry(Asn1Type type) {
  return entries()[static_cast<std::size_t>(type)];
}

}  // namespace

const std::vector<Asn1Type>& allAsn1Types() {
  static const std::vector<Asn1Type> all = [] {
    std::vector<Asn1Type> v;
    for (const Entry& e : entries()) v.push_back(e.type);
    return v;
  }();
  return all;
}

std::string_view asn1Name(Asn1Type type) {
  return entry(type).name;
}

std::optional<Asn1Type> asn1TypeNamed(std::string_view name) {
  for (const Entry& e : entries())
    if (e.name == name) return e.type;
  return std::nullopt;
}

TypeId cdffTypeOf(Asn1Type type) {
  return entry(type).cdff;
}

bool hasAsn1Type(TypeId type) {
  if (!type) return false;
  for (const Entry& e : entries())
    if (e.cdff == type) return true;
  return false;
}

Result<Asn1Type> asn1TypeOf(const Value& value) {
  if (const Image* image = value.get<Image>()) {
    switch (image->format) {
      case PixelFormat::kGray8:
        return Asn1Type::kImage8UC1;
      case PixelFormat::kBgr8:
        return Asn1Type::kImage8UC3;
      case PixelFormat::kFloat32:
        return Asn1Type::kImage32FC1;
      default:
        return invalidInput(
            "an image of format {} has no ASN.1 type; expected mono8 (Image8UC1), "
            "bgr8 (Image8UC3) or 32FC1 (Image32FC1)",
            toString(image->format));
    }
  }
  for (const Entry& e : entries())
    if (e.cdff && e.cdff == value.type() && e.cdff != TypeId::of<Image>()) return e.type;
  return invalidInput(
      "a {} has no ASN.1 type; expected Timestamp, Transform, PoseWithCovariance, "
      "RigidBodyState, Bearing, CameraModel, Image or PointCloud",
      value.type().name());
}

Status encode(const Value& value, std::vector<std::uint8_t>& out) {
  Result<Asn1Type> type = asn1TypeOf(value);
  if (!type) return type.status();
  switch (*type) {
    case Asn1Type::kTime:
      return detail::encodeTimestamp(*value.get<Timestamp>(), out);
    case Asn1Type::kTransform:
      return detail::encodeTransform(*value.get<Transform>(), out);
    case Asn1Type::kTransformWithCovariance:
      return detail::encodePoseWithCovariance(*value.get<PoseWithCovariance>(), out);
    case Asn1Type::kRigidBodyState:
      return detail::encodeRigidBodyState(*value.get<RigidBodyState>(), out);
    case Asn1Type::kBearing:
      return detail::encodeBearing(*value.get<Bearing>(), out);
    case Asn1Type::kCalibrationMatrix:
      return detail::encodeCameraModel(*value.get<CameraModel>(), out);
    case Asn1Type::kImage8UC1:
    case Asn1Type::kImage8UC3:
    case Asn1Type::kImage32FC1:
      return detail::encodeImage(*value.get<Image>(), out);
    case Asn1Type::kPointCloud:
      return detail::encodePointCloud(*value.get<PointCloud>(), out);
    case Asn1Type::kPoint:
    case Asn1Type::kPose:
      break;
  }
  return Status(StatusCode::kInternal, "asn1::encode: no encoder for this value");
}

Result<std::vector<std::uint8_t>> encode(const Value& value) {
  std::vector<std::uint8_t> out;
  CDFF_RETURN_IF_ERROR(encode(value, out));
  return out;
}

namespace {

template <typename T>
Result<Value> wrap(Result<T> r) {
  if (!r) return r.status();
  return Value::of<T>(std::move(r).value());
}

}  // namespace

Result<Value> decode(Asn1Type type, std::span<const std::uint8_t> data) {
  switch (type) {
    case Asn1Type::kTime:
      return wrap(detail::decodeTimestamp(data));
    case Asn1Type::kTransform:
      return wrap(detail::decodeTransform(data));
    case Asn1Type::kTransformWithCovariance:
      return wrap(detail::decodePoseWithCovariance(data));
    case Asn1Type::kRigidBodyState:
      return wrap(detail::decodeRigidBodyState(data));
    case Asn1Type::kBearing:
      return wrap(detail::decodeBearing(data));
    case Asn1Type::kCalibrationMatrix:
      return wrap(detail::decodeCameraModel(data));
    case Asn1Type::kImage8UC1:
    case Asn1Type::kImage8UC3:
    case Asn1Type::kImage32FC1:
      return wrap(detail::decodeImage(type, data));
    case Asn1Type::kPointCloud:
      return wrap(detail::decodePointCloud(data));
    case Asn1Type::kPoint:
    case Asn1Type::kPose:
      break;
  }
  return invalidInput("asn1::decode: {} is not a CDFF type; use decodePoint() or decodePose()",
                      asn1Name(type));
}

}  // namespace cdff::asn1
