#pragma once
// The type registry: every CDFF data type, declared once, with everything the framework needs to
// move its values around: its name (in DFN descriptions, graph files, recordings and product
// files), its C++ type, how it is recorded in MCAP (schema and message encoding) and how the
// Data Product Manager saves it. Ports, messages, products, the replay, the synchronisation
// queues and the DFN code generator (through the checked descriptions that `cdff_dfn_describe`
// writes at build time, with each port's C++ type from here) all read this one table.
//
// Adding a type (docs/writing-a-dfn.md has a worked example):
//  1. the struct, under src/cdff/types/;
//  2. one row in CDFF_FOR_EACH_TYPE below;
//  3. its codec, beside the others in src/cdff/types/codec/: encode() and decode() for MCAP, and
//     toJson()/fromJson() when its product form is Inline (toPly()/fromPly() for Ply). A missing
//     function is a compile error that names it; the round-trip test then covers the type once
//     it has a sample value in tests/types/type_registry_test.cpp.

#include <optional>
#include <span>
#include <string_view>
#include <typeindex>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "cdff/types/types.hpp"
#include "cdff/types/value.hpp"

namespace cdff {

namespace codec {
class Encoded;
struct ProductRecord;
}  // namespace codec

using Bytes = std::span<const std::uint8_t>;

/// How a type's MCAP messages are encoded: protobuf (with a FileDescriptorSet schema) or JSON
/// (with a JSON Schema).
enum class MessageEncoding { kProtobuf, kJson };

/// How the Data Product Manager saves a value (docs/dfpc.md): inline JSON in products.json, a
/// PLY file beside it, or the MCAP message itself in a file beside it.
enum class ProductForm { kInline, kPly, kMessage };

// The table. Columns: C++ type, name, MCAP schema, message encoding, product form. The order
// matters only where two types share a schema: the first one is what a channel without CDFF
// metadata decodes to (foxglove.RawImage -> Image, foxglove.PoseInFrame -> PoseWithCovariance).
#define CDFF_FOR_EACH_TYPE(X)                                                                    \
  X(::cdff::Image, "Image", "foxglove.RawImage", Protobuf, Message)                              \
  X(::cdff::DepthMap, "DepthMap", "foxglove.RawImage", Protobuf, Message)                        \
  X(::cdff::StereoImagePair, "StereoImagePair", "cdff.StereoImagePair", Protobuf, Message)       \
  X(::cdff::CompressedImage, "CompressedImage", "foxglove.CompressedImage", Protobuf, Message)   \
  X(::cdff::CameraModel, "CameraModel", "foxglove.CameraCalibration", Protobuf, Message)         \
  X(::cdff::PointCloud, "PointCloud", "foxglove.PointCloud", Protobuf, Ply)                      \
  X(::cdff::Transform, "Transform", "foxglove.FrameTransform", Protobuf, Inline)                 \
  X(::cdff::PoseWithCovariance, "PoseWithCovariance", "foxglove.PoseInFrame", Protobuf, Inline)  \
  X(::cdff::RigidBodyState, "RigidBodyState", "foxglove.PoseInFrame", Protobuf, Inline)          \
  X(::cdff::PoseArray, "PoseArray", "foxglove.PosesInFrame", Protobuf, Message)                  \
  X(::cdff::TriangleMesh, "TriangleMesh", "foxglove.SceneUpdate", Protobuf, Ply)                 \
  X(::cdff::PolygonModel, "PolygonModel", "cdff.PolygonModel", Json, Message)                    \
  X(::cdff::ModelContours, "ModelContours", "cdff.ModelContours", Json, Message)                 \
  X(::cdff::ContourSamples, "ContourSamples", "cdff.ContourSamples", Json, Message)              \
  X(::cdff::Features2D, "Features2D", "cdff.Features2D", Protobuf, Message)                      \
  X(::cdff::Features3D, "Features3D", "cdff.Features3D", Protobuf, Message)                      \
  X(::cdff::Matches, "Matches", "cdff.Matches", Protobuf, Message)                               \
  X(::cdff::Correspondences2D, "Correspondences2D", "cdff.Correspondences2D", Protobuf, Message) \
  X(::cdff::Correspondences3D, "Correspondences3D", "cdff.Correspondences3D", Protobuf, Message) \
  X(::cdff::Correspondences2D3D, "Correspondences2D3D", "cdff.Correspondences2D3D", Protobuf,    \
    Message)                                                                                     \
  X(::cdff::ImuSample, "ImuSample", "cdff.ImuSample", Json, Inline)                              \
  X(::cdff::Wrench, "Wrench", "cdff.Wrench", Json, Inline)                                       \
  X(::cdff::JointState, "JointState", "cdff.JointState", Json, Inline)                           \
  X(::cdff::LidarInfo, "LidarInfo", "cdff.LidarInfo", Json, Inline)                              \
  X(::cdff::Detections, "Detections", "cdff.Detections", Json, Inline)                           \
  X(::cdff::ImageRegion, "ImageRegion", "cdff.ImageRegion", Json, Inline)                        \
  X(::cdff::Bearing, "Bearing", "cdff.Bearing", Json, Inline)                                    \
  X(::nlohmann::json, "Json", "cdff.Record", Json, Inline)                                       \
  X(::cdff::TrackState, "TrackState", "cdff.TrackState", Json, Inline)                           \
  X(double, "Double", "cdff.Double", Json, Inline)                                               \
  X(bool, "Bool", "cdff.Bool", Json, Inline)                                                     \
  X(int, "Int", "cdff.Int", Json, Inline)                                                        \
  X(::cdff::Timestamp, "Timestamp", "cdff.Timestamp", Json, Inline)                              \
  X(::std::string, "String", "cdff.String", Json, Inline)

#define CDFF_DECLARE_TYPE_TRAITS(Type, Name, ...)  \
  template <>                                      \
  struct TypeTraits<Type> {                        \
    static constexpr std::string_view name = Name; \
  };
CDFF_FOR_EACH_TYPE(CDFF_DECLARE_TYPE_TRAITS)
#undef CDFF_DECLARE_TYPE_TRAITS

/// One registered type.
struct TypeInfo {
  std::string_view name;      // "Image"
  std::string_view cpp_name;  // "::cdff::Image", as the generated DFN code spells it
  std::type_index cpp_type = typeid(void);
  std::string_view schema_name;  // "foxglove.RawImage"
  MessageEncoding encoding = MessageEncoding::kProtobuf;
  ProductForm product = ProductForm::kMessage;

  // The type's codec, type-erased (src/cdff/types/codec/codec.hpp has the typed functions).
  /// Appends one MCAP message; `stamp` is used by types without a stamp of their own.
  Status (*encode)(const void* value, Timestamp stamp, codec::Encoded& out) = nullptr;
  /// Decodes one MCAP message; `owner` keeps `data` alive (large arrays may share it).
  Result<Value> (*decode)(Bytes data, const std::shared_ptr<const void>& owner) = nullptr;
  /// The value's own stamp (an image's, a pose's), or none (matches, a camera model, scalars).
  std::optional<Timestamp> (*own_stamp)(const void* value) = nullptr;
  /// The product-file form (see ProductForm).
  Status (*save_product)(const void* value, Timestamp stamp, codec::ProductRecord& out) = nullptr;
  Result<Value> (*load_product)(const codec::ProductRecord& in) = nullptr;

  /// "protobuf" or "jsonschema" (MCAP schema encoding).
  std::string_view schemaEncoding() const;
  /// "protobuf" or "json" (MCAP message encoding).
  std::string_view messageEncoding() const;
  /// The schema's bytes: a FileDescriptorSet or a JSON Schema's text (static storage).
  Bytes schemaData() const;
};

/// Every registered type, in the table's order.
const std::vector<TypeId>& allTypes();
/// The type named `name` ("PoseWithCovariance"); not valid when there is none.
TypeId findType(std::string_view name);
/// The first type recorded with `schema_name` and `encoding` ("protobuf" | "json"); not valid
/// when none.
TypeId findTypeBySchema(std::string_view schema_name, std::string_view message_encoding);
/// "{Image, DepthMap, ...}" for messages that list the accepted names.
std::string typeNames();

}  // namespace cdff
