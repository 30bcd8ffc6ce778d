#pragma once
// The codecs of the CDFF data types: how each is written to and read from an MCAP message, and
// how the Data Product Manager saves it. The type registry (type_registry.hpp) reaches every
// type's functions through these overloads; docs/recording.md documents every schema.
//
// Where Foxglove has a well-known schema it is used, with protobuf encoding, so that Foxglove
// shows the channel without plugins: Image and DepthMap -> foxglove.RawImage, CompressedImage
// -> foxglove.CompressedImage, PointCloud -> foxglove.PointCloud, Transform ->
// foxglove.FrameTransform, PoseWithCovariance and RigidBodyState -> foxglove.PoseInFrame,
// CameraModel -> foxglove.CameraCalibration, TriangleMesh -> foxglove.SceneUpdate, PoseArray ->
// foxglove.PosesInFrame. What Foxglove's schema cannot hold (an image's camera model, a pose's
// covariance and child frame, ...) travels in extra fields numbered from 1000, declared in the
// embedded descriptor, which Foxglove ignores. Features, matches, correspondences and stereo
// pairs use CDFF protobuf schemas (package `cdff`); IMU samples, wrenches, joint states, models,
// contours, LIDAR descriptions, object detections, track states, scalars and free-form records
// use JSON with a JSON Schema.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/types/type_registry.hpp"

namespace cdff::codec {

/// An encoded message: owned bytes with large payloads (pixels, points) referenced in place, so
/// the writer copies them once. parts() is valid while the encoded value is alive.
class Encoded {
 public:
  std::vector<std::uint8_t> bytes;
  /// Appends `data` by reference at the current end of `bytes`.
  void reference(Bytes data) { references_.push_back({bytes.size(), data}); }
  std::vector<Bytes> parts() const;
  std::size_t size() const;
  /// The whole message as one contiguous copy.
  std::vector<std::uint8_t> flatten() const;
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

/// A value as the Data Product Manager saves it (ProductForm): the inline JSON value, or a
/// file's bytes with the metadata that the index keeps beside its name.
struct ProductRecord {
  nlohmann::json json;  // kInline: the value; kPly: metadata (frame_id, data_stamp_us)
  std::string file;     // kPly, kMessage: the file's bytes
};

// ---- MCAP messages ---------------------------------------------------------------------------
// Encoders append the message to `out` (cleared first); `stamp` is the message's time for types
// without a stamp of their own (matches, correspondences, camera models, JSON records, scalars)
// and is ignored by the others. They fail only when the value cannot be represented (an image
// whose buffer is smaller than height * stride, per-point fields of the wrong length, a negative
// time stamp...). Values are stored as they are, NaNs included.
// Decoders: `owner` keeps `data` alive: when given, large arrays (pixels) are shared with it
// instead of copied. Errors say which field is malformed.

#define CDFF_DECLARE_CODEC(Type, ...)                          \
  Status encode(const Type& v, Timestamp stamp, Encoded& out); \
  Status decode(Bytes data, const std::shared_ptr<const void>& owner, Type& out);
CDFF_FOR_EACH_TYPE(CDFF_DECLARE_CODEC)
#undef CDFF_DECLARE_CODEC

/// A camera model with the frame its calibration belongs to (encode() writes an empty frame).
Status encodeCalibration(const CameraModel& v, Timestamp stamp, std::string_view frame_id,
                         Encoded& out);

// ---- Product files ---------------------------------------------------------------------------
// kInline types: their JSON value. NaN is written as null and read back as NaN.

nlohmann::json toJson(const Transform& v);
nlohmann::json toJson(const PoseWithCovariance& v);
nlohmann::json toJson(const RigidBodyState& v);
nlohmann::json toJson(const ImuSample& v);
nlohmann::json toJson(const Wrench& v);
nlohmann::json toJson(const JointState& v);
nlohmann::json toJson(const LidarInfo& v);
nlohmann::json toJson(const Detections& v);
nlohmann::json toJson(const ImageRegion& v);
nlohmann::json toJson(const Bearing& v);
nlohmann::json toJson(const nlohmann::json& v);
nlohmann::json toJson(TrackState v);
nlohmann::json toJson(double v);
nlohmann::json toJson(bool v);
nlohmann::json toJson(int v);
nlohmann::json toJson(std::int64_t v);
nlohmann::json toJson(const std::string& v);

Status fromJson(const nlohmann::json& j, Transform& out);
Status fromJson(const nlohmann::json& j, PoseWithCovariance& out);
Status fromJson(const nlohmann::json& j, RigidBodyState& out);
Status fromJson(const nlohmann::json& j, ImuSample& out);
Status fromJson(const nlohmann::json& j, Wrench& out);
Status fromJson(const nlohmann::json& j, JointState& out);
Status fromJson(const nlohmann::json& j, LidarInfo& out);
Status fromJson(const nlohmann::json& j, Detections& out);
Status fromJson(const nlohmann::json& j, ImageRegion& out);
Status fromJson(const nlohmann::json& j, Bearing& out);
Status fromJson(const nlohmann::json& j, nlohmann::json& out);
Status fromJson(const nlohmann::json& j, TrackState& out);
Status fromJson(const nlohmann::json& j, double& out);
Status fromJson(const nlohmann::json& j, bool& out);
Status fromJson(const nlohmann::json& j, int& out);
Status fromJson(const nlohmann::json& j, std::int64_t& out);
Status fromJson(const nlohmann::json& j, std::string& out);

// kPly types: a binary little-endian PLY file (MeshLab and CloudCompare open it), with the frame
// and stamp in the metadata.
Status toPly(const PointCloud& v, ProductRecord& out);
Status toPly(const TriangleMesh& v, ProductRecord& out);
Status fromPly(const ProductRecord& in, PointCloud& out);
Status fromPly(const ProductRecord& in, TriangleMesh& out);

// ---- Schemas ----------------------------------------------------------------------------------

/// The schema data of `schema_name`: a FileDescriptorSet (protobuf) or a JSON Schema's text;
/// empty when unknown. Static storage.
Bytes schemaData(std::string_view schema_name, MessageEncoding encoding);

}  // namespace cdff::codec
