#pragma once
// The seed's ESROCOS-style ASN.1 types (seed §4.3, docs/asn1.md) in unaligned PER (uPER), the
// encoding that the autonomy (OG2) and the sensor suite (OG4) read: CDFF values to and from the
// bytes of the modules in src/cdff/asn1/asn/, through the C codecs asn1c generates from them.
//
//   CDFF type            ASN.1 type                       loss
//   Timestamp            Time                             none
//   Eigen::Vector3d      Point                            none
//   Eigen::Isometry3d    Pose                             the rotation matrix as its quaternion
//                                                         (back within 1e-15)
//   Transform            Transform                        none
//   PoseWithCovariance   TransformWithCovariance          none
//   RigidBodyState       RigidBodyState                   none
//   Bearing              Bearing                          none (NaN: an absent range field)
//   CameraModel          CalibrationMatrix                none
//   Image                Image8UC1 | Image8UC3 | Image32FC1  the row padding (rows are packed);
//                        (by its format: Gray8, Bgr8,      Gray16 images have no ASN.1 type
//                         Float32)
//   PointCloud           PointCloud                       the points' padding float (1)
//
//   Result<std::vector<std::uint8_t>> bytes = asn1::encode(Value::of(pose));
//   Result<Value> back = asn1::decode(asn1::Asn1Type::kTransformWithCovariance, *bytes);
//
// Encoding checks the value against the ASN.1 constraints first and says which field, which
// value and which bound: a string over 255 bytes, an image over its type's bytes, a cloud over
// 2097152 points, a NaN or infinite number (T-Double holds finite numbers only). Decoding never
// trusts the bytes: a truncated buffer, trailing bytes, a length past a bound, a value that the
// CDFF type refuses (validate()) are errors that name the type and the field.

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>

#include "cdff/types/type_registry.hpp"
#include "cdff/types/types.hpp"

namespace cdff::asn1 {

/// The top-level ASN.1 types (the PDUs) that the CDFF encodes.
enum class Asn1Type {
  kTime,
  kPoint,
  kPose,
  kTransform,
  kTransformWithCovariance,
  kRigidBodyState,
  kBearing,
  kCalibrationMatrix,
  kImage8UC1,
  kImage8UC3,
  kImage32FC1,
  kPointCloud,
};

/// Every Asn1Type, in the enum's order.
const std::vector<Asn1Type>& allAsn1Types();
/// The ASN.1 type's name: "TransformWithCovariance", "Image8UC1"...
std::string_view asn1Name(Asn1Type type);
/// The type named `name`; none when there is none.
std::optional<Asn1Type> asn1TypeNamed(std::string_view name);
/// The CDFF type that an ASN.1 type decodes to (not valid for Point and Pose, which are not
/// registered CDFF types: use the typed functions below).
TypeId cdffTypeOf(Asn1Type type);
/// Whether values of a CDFF type have an ASN.1 type (an Image may still not: Gray16).
bool hasAsn1Type(TypeId type);
/// The ASN.1 type that carries `value`; an error for a type without one (it lists those with
/// one) or an image format without one.
Result<Asn1Type> asn1TypeOf(const Value& value);

// The size bounds of the ASN.1 types (the SIZE constraints of the modules).
inline constexpr std::size_t kMaxStringBytes = 255;
inline constexpr int kMaxImageSide = 4096;
inline constexpr std::size_t kMaxImage8UC1Bytes = 4194304;    // 2048 x 2048
inline constexpr std::size_t kMaxImage8UC3Bytes = 12582912;   // 2048 x 2048 x 3
inline constexpr std::size_t kMaxImage32FC1Bytes = 16777216;  // 2048 x 2048 x 4
inline constexpr std::size_t kMaxCloudPoints = 2097152;
inline constexpr std::size_t kMaxDistortionCoefficients = 8;

/// The uPER bytes of `value` as its asn1TypeOf() type. `out` is replaced (its capacity kept).
Status encode(const Value& value, std::vector<std::uint8_t>& out);
Result<std::vector<std::uint8_t>> encode(const Value& value);
/// The CDFF value of uPER bytes of ASN.1 type `type` (cdffTypeOf(type)); the bytes must hold
/// exactly one value.
Result<Value> decode(Asn1Type type, std::span<const std::uint8_t> data);

// The types with no CDFF type of their own.
Status encodePoint(const Eigen::Vector3d& point, std::vector<std::uint8_t>& out);
Result<Eigen::Vector3d> decodePoint(std::span<const std::uint8_t> data);
Status encodePose(const Eigen::Isometry3d& pose, std::vector<std::uint8_t>& out);
Result<Eigen::Isometry3d> decodePose(std::span<const std::uint8_t> data);

}  // namespace cdff::asn1
