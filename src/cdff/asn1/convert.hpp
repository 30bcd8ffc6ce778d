#pragma once
// Internal to cdff_asn1: the conversions between CDFF values and the C structures that asn1c
// generates (generated/*.h in the build directory), and the helpers they share. Encoders fill a
// zeroed structure from a value and check every ASN.1 constraint on the way, naming the field;
// decoders read a structure that asn1c decoded from untrusted bytes and check everything again.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "Bearing.h"
#include "CalibrationMatrix.h"
#include "Image32FC1.h"
#include "Image8UC1.h"
#include "Image8UC3.h"
#include "Point.h"
#include "PointCloud.h"
#include "Pose.h"
#include "RigidBodyState.h"
#include "Time.h"
#include "Transform.h"
#include "TransformWithCovariance.h"
#include "cdff/asn1/uper.hpp"

namespace cdff::asn1::detail {

static_assert(sizeof(long) == 8, "asn1c's native integers must hold the CDFF's 64-bit times");

/// An ASN.1 structure being filled: zeroed, its contents freed by asn1c's free on destruction.
/// An OCTET STRING may borrow its bytes from the value (an image's pixels): borrow() records
/// it, and the destructor hands it back before asn1c frees the rest.
template <typename T>
class Filled {
 public:
  explicit Filled(asn_TYPE_descriptor_t& def) : def_(def) { std::memset(&value, 0, sizeof value); }
  ~Filled() {
    for (OCTET_STRING_t* s : borrowed_) {
      s->buf = nullptr;
      s->size = 0;
    }
    ASN_STRUCT_FREE_CONTENTS_ONLY(def_, &value);
  }
  Filled(const Filled&) = delete;
  Filled& operator=(const Filled&) = delete;

  void borrow(OCTET_STRING_t& s, const std::uint8_t* data, std::size_t size) {
    s.buf = const_cast<std::uint8_t*>(data);
    s.size = static_cast<int>(size);
    borrowed_.push_back(&s);
  }

  T value;

 private:
  asn_TYPE_descriptor_t& def_;
  std::vector<OCTET_STRING_t*> borrowed_;
};

/// A structure that asn1c decoded (and allocated): freed by asn1c on destruction.
struct Freer {
  asn_TYPE_descriptor_t* def;
  void operator()(void* p) const { ASN_STRUCT_FREE(*def, p); }
};
template <typename T>
using Decoded = std::unique_ptr<T, Freer>;

/// Checks asn1c's constraints (a backstop: the encoders check them first, with field names) and
/// appends the uPER bytes of `s` to `out` (cleared first).
Status encodeStruct(asn_TYPE_descriptor_t& def, const void* s, std::vector<std::uint8_t>& out);
/// Decodes exactly one value of `def` from `data`; the error says how the bytes are malformed.
Result<void*> decodeStruct(asn_TYPE_descriptor_t& def, std::span<const std::uint8_t> data);

template <typename T>
Result<Decoded<T>> decodeAs(asn_TYPE_descriptor_t& def, std::span<const std::uint8_t> data) {
  Result<void*> raw = decodeStruct(def, data);
  if (!raw) return raw.status();
  return Decoded<T>(static_cast<T*>(*raw), Freer{&def});
}

// ---- fields ------------------------------------------------------------------------------------
// `field` is the path of the field in the ASN.1 value ("TransformWithCovariance.cov"), for the
// messages.

Status checkFinite(double v, std::string_view field);
Status setString(OCTET_STRING_t& out, const std::string& s, std::string_view field);
Result<std::string> getString(const OCTET_STRING_t& s, std::string_view field);
/// A SEQUENCE OF T-Double (asn1c's A_SEQUENCE_OF(double), an anonymous struct per use, viewed
/// as asn_anonymous_sequence_) from `values`, each checked finite; and back, its count checked.
Status setDoubles(asn_anonymous_sequence_& list, std::span<const double> values,
                  std::string_view field);
Status getDoubles(const asn_anonymous_sequence_& list, std::span<double> values,
                  std::string_view field);
template <typename List>
asn_anonymous_sequence_& anonymous(List& list) {
  return *_A_SEQUENCE_FROM_VOID(&list);
}
template <typename List>
const asn_anonymous_sequence_& anonymous(const List& list) {
  return *_A_CSEQUENCE_FROM_VOID(&list);
}
Status setVector(Vector3d_t& out, const Eigen::Vector3d& v, std::string_view field);
Result<Eigen::Vector3d> getVector(const Vector3d_t& v, std::string_view field);
Status setPose(Pose_t& out, const Eigen::Vector3d& translation, const Eigen::Quaterniond& rotation,
               std::string_view field);
Status getPose(const Pose_t& p, Eigen::Vector3d& translation, Eigen::Quaterniond& rotation,
               std::string_view field);

/// A Matrix3d/6d/12d from an Eigen matrix, column by column, and back.
template <typename AsnMatrix, typename Derived>
Status setMatrix(AsnMatrix& out, const Eigen::MatrixBase<Derived>& m, std::string_view field) {
  const Eigen::Matrix<double, Derived::RowsAtCompileTime, Derived::ColsAtCompileTime> dense = m;
  return setDoubles(anonymous(out.data.list), std::span<const double>(dense.data(), dense.size()),
                    field);
}
template <typename AsnMatrix, typename Matrix>
Status getMatrix(const AsnMatrix& in, Matrix& m, std::string_view field) {
  return getDoubles(anonymous(in.data.list), std::span<double>(m.data(), m.size()), field);
}

// ---- the types (convert_geometry.cpp, convert_sensors.cpp)
// ---------------------------------------

Status encodeTimestamp(Timestamp stamp, std::vector<std::uint8_t>& out);
Result<Timestamp> decodeTimestamp(std::span<const std::uint8_t> data);
Status encodeTransform(const Transform& v, std::vector<std::uint8_t>& out);
Result<Transform> decodeTransform(std::span<const std::uint8_t> data);
Status encodePoseWithCovariance(const PoseWithCovariance& v, std::vector<std::uint8_t>& out);
Result<PoseWithCovariance> decodePoseWithCovariance(std::span<const std::uint8_t> data);
Status encodeRigidBodyState(const RigidBodyState& v, std::vector<std::uint8_t>& out);
Result<RigidBodyState> decodeRigidBodyState(std::span<const std::uint8_t> data);
Status encodeBearing(const Bearing& v, std::vector<std::uint8_t>& out);
Result<Bearing> decodeBearing(std::span<const std::uint8_t> data);
Status encodeCameraModel(const CameraModel& v, std::vector<std::uint8_t>& out);
Result<CameraModel> decodeCameraModel(std::span<const std::uint8_t> data);
Status encodeImage(const Image& v, std::vector<std::uint8_t>& out);
Result<Image> decodeImage(Asn1Type type, std::span<const std::uint8_t> data);
Status encodePointCloud(const PointCloud& v, std::vector<std::uint8_t>& out);
Result<PointCloud> decodePointCloud(std::span<const std::uint8_t> data);

}  // namespace cdff::asn1::detail
