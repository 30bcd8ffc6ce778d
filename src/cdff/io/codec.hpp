#pragma once
// How every CDFF core type is stored in MCAP: its schema (name, encoding, schema data) and the
// encoding and decoding of its values. docs/recording.md documents every schema.
//
// Where Foxglove has a well-known schema it is used, with protobuf encoding, so that Foxglove
// shows the channel without plugins: Image and DepthMap -> foxglove.RawImage, CompressedImage
// -> foxglove.CompressedImage, PointCloud -> foxglove.PointCloud, Transform ->
// foxglove.FrameTransform, PoseWithCovariance and RigidBodyState -> foxglove.PoseInFrame,
// CameraModel -> foxglove.CameraCalibration, TriangleMesh -> foxglove.SceneUpdate, PoseArray ->
// foxglove.PosesInFrame. What Foxglove's schema cannot hold (an image's camera model, a pose's
// covariance and child frame, ...) travels in extra fields numbered from 1000, declared in the
// embedded descriptor, which Foxglove ignores. Features, matches, correspondences and stereo
// pairs use CDFF protobuf schemas (package `cdff`); IMU samples, wrenches, joint states, events
// and free-form records use JSON with a JSON Schema.

#include <concepts>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <typeindex>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "cdff/io/mcap.hpp"
#include "cdff/types/types.hpp"

namespace cdff::io {

/// A compressed image (JPEG, PNG, WebP) as it was produced; CDFF stores it without decoding it.
struct CompressedImage {
  Timestamp stamp = 0;
  std::string frame_id;
  std::string format;  // "jpeg", "png", "webp"
  Buffer<std::uint8_t> data;
};

/// Poses in one frame (a trajectory, candidate poses), shown by Foxglove as arrows.
struct PoseArray {
  Timestamp stamp = 0;
  std::string frame_id;
  std::vector<Eigen::Isometry3d> poses;
};

/// The CDFF name of each recordable type: the names the DFN layer gives port types.
template <typename T>
struct TypeName;
#define CDFF_IO_TYPE_NAME(Type, Name)               \
  template <>                                       \
  struct TypeName<Type> {                           \
    static constexpr std::string_view value = Name; \
  }
CDFF_IO_TYPE_NAME(Image, "Image");
CDFF_IO_TYPE_NAME(StereoImagePair, "StereoImagePair");
CDFF_IO_TYPE_NAME(DepthMap, "DepthMap");
CDFF_IO_TYPE_NAME(CameraModel, "CameraModel");
CDFF_IO_TYPE_NAME(PointCloud, "PointCloud");
CDFF_IO_TYPE_NAME(Transform, "Transform");
CDFF_IO_TYPE_NAME(PoseWithCovariance, "PoseWithCovariance");
CDFF_IO_TYPE_NAME(RigidBodyState, "RigidBodyState");
CDFF_IO_TYPE_NAME(ImuSample, "ImuSample");
CDFF_IO_TYPE_NAME(Wrench, "Wrench");
CDFF_IO_TYPE_NAME(JointState, "JointState");
CDFF_IO_TYPE_NAME(Features2D, "Features2D");
CDFF_IO_TYPE_NAME(Features3D, "Features3D");
CDFF_IO_TYPE_NAME(Matches, "Matches");
CDFF_IO_TYPE_NAME(Correspondences2D, "Correspondences2D");
CDFF_IO_TYPE_NAME(Correspondences3D, "Correspondences3D");
CDFF_IO_TYPE_NAME(Correspondences2D3D, "Correspondences2D3D");
CDFF_IO_TYPE_NAME(TriangleMesh, "TriangleMesh");
CDFF_IO_TYPE_NAME(CompressedImage, "CompressedImage");
CDFF_IO_TYPE_NAME(PoseArray, "PoseArray");
CDFF_IO_TYPE_NAME(nlohmann::json, "Json");
// Scalars: DFN outputs such as a tracker's status or an innovation statistic.
CDFF_IO_TYPE_NAME(double, "Double");
CDFF_IO_TYPE_NAME(bool, "Bool");
CDFF_IO_TYPE_NAME(int, "Int");
CDFF_IO_TYPE_NAME(std::int64_t, "Timestamp");
CDFF_IO_TYPE_NAME(std::string, "String");
#undef CDFF_IO_TYPE_NAME

/// How values of one CDFF type are recorded.
struct TypeFormat {
  std::string_view cdff_type;         // "Image"
  std::string_view schema_name;       // "foxglove.RawImage"
  std::string_view schema_encoding;   // "protobuf" or "jsonschema"
  std::string_view message_encoding;  // "protobuf" or "json"
  Bytes schema_data;                  // FileDescriptorSet or JSON Schema text (static storage)
};

/// Every recordable type, and one by CDFF name (null if unknown).
const std::vector<TypeFormat>& allFormats();
const TypeFormat* formatOf(std::string_view cdff_type);

/// The channel metadata key that names a channel's CDFF type.
inline constexpr std::string_view kTypeMetadataKey = "cdff.type";

/// The CDFF type of a channel: its "cdff.type" metadata, else what its schema implies
/// (foxglove.RawImage -> Image, ...); "" when it is none of ours (e.g. a ROS 2 message).
std::string_view cdffTypeOf(const Channel& channel, const Schema* schema);

/// An encoded message: owned bytes with large payloads (pixels, points) referenced in place, so
/// the writer copies them once. parts() is valid while the encoded value is alive.
class Encoded {
 public:
  std::vector<std::uint8_t> bytes;
  /// Appends `data` by reference at the current end of `bytes`.
  void reference(Bytes data) { references_.push_back({bytes.size(), data}); }
  std::vector<Bytes> parts() const;
  std::size_t size() const;
  void clear() {
    bytes.clear();
    references_.clear();
  }

 private:
  struct Reference {
    std::size_t at;
    Bytes data;
  };
  std::vector<Reference> references_;
};

// Encoders: append the message to `out` (cleared first). They fail only when the value cannot be
// represented (an image whose buffer is smaller than height * stride, per-point fields of the
// wrong length, a negative time stamp...). Values are stored as they are, NaNs included.
Status encode(const Image& v, Encoded& out);
Status encode(const DepthMap& v, Encoded& out);
Status encode(const StereoImagePair& v, Encoded& out);
Status encode(const CompressedImage& v, Encoded& out);
Status encode(const CameraModel& v, Timestamp stamp, std::string_view frame_id, Encoded& out);
Status encode(const PointCloud& v, Encoded& out);
Status encode(const Transform& v, Encoded& out);
Status encode(const PoseWithCovariance& v, Encoded& out);
Status encode(const RigidBodyState& v, Encoded& out);
Status encode(const PoseArray& v, Encoded& out);
Status encode(const TriangleMesh& v, Encoded& out);
Status encode(const Features2D& v, Encoded& out);
Status encode(const Features3D& v, Encoded& out);
Status encode(const Matches& v, Timestamp stamp, Encoded& out);
Status encode(const Correspondences2D& v, Timestamp stamp, Encoded& out);
Status encode(const Correspondences3D& v, Timestamp stamp, Encoded& out);
Status encode(const Correspondences2D3D& v, Timestamp stamp, Encoded& out);
Status encode(const ImuSample& v, Encoded& out);
Status encode(const Wrench& v, Encoded& out);
Status encode(const JointState& v, Encoded& out);
/// A JSON record; its time stamp is written as "timestamp": {"sec", "nsec"} unless present.
Status encode(const nlohmann::json& v, Timestamp stamp, Encoded& out);
/// Scalars are JSON objects {"timestamp", "value"} (schema cdff.Double, cdff.String...); a NaN
/// double is null.
template <typename T>
requires std::same_as<T, double> || std::same_as<T, bool> || std::same_as<T, int> ||
    std::same_as<T, std::int64_t> || std::same_as<T, std::string>
        Status encodeScalar(const T& v, Timestamp stamp, Encoded& out);

// Decoders. `owner` keeps `data` alive: when given, large arrays (pixels) are shared with it
// instead of copied. Errors say which field is malformed, at which byte of the message.
Status decode(Bytes data, const std::shared_ptr<const void>& owner, Image& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, DepthMap& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, StereoImagePair& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, CompressedImage& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, CameraModel& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, PointCloud& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, Transform& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, PoseWithCovariance& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, RigidBodyState& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, PoseArray& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, TriangleMesh& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, Features2D& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, Features3D& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, Matches& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, Correspondences2D& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, Correspondences3D& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, Correspondences2D3D& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, ImuSample& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, Wrench& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, JointState& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, nlohmann::json& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, double& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, bool& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, int& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, std::int64_t& out);
Status decode(Bytes data, const std::shared_ptr<const void>& owner, std::string& out);

/// A decoded value of a type known only at run time, as the DFPC layer feeds ports:
/// `port.setAny(v.value, dfn::PortType{v.type, v.type_name})`.
struct AnyValue {
  std::shared_ptr<const void> value;
  std::string_view type_name;  // "Image", "PointCloud", ...
  std::type_index type = typeid(void);

  template <typename T>
  std::shared_ptr<const T> as() const {
    if (type != std::type_index(typeid(T))) return nullptr;
    return std::static_pointer_cast<const T>(value);
  }
};

/// Decodes a message of CDFF type `cdff_type` (see cdffTypeOf()).
Result<AnyValue> decodeAny(std::string_view cdff_type, Bytes data,
                           const std::shared_ptr<const void>& owner);

}  // namespace cdff::io
