// Schemas and codecs of the CDFF core types (docs/recording.md lists them).
#include "cdff/io/codec.hpp"

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>

#include <nlohmann/json.hpp>

#include "cdff/io/protobuf.hpp"

namespace cdff::io {

using pb::WireType;
using F = pb::FieldType;

// ---- schemas -------------------------------------------------------------------------------

namespace {

pb::FieldDef field(std::string name, int number, F type, std::string type_name = {},
                   bool repeated = false) {
  return {std::move(name), number, type, repeated, std::move(type_name)};
}
pb::FieldDef repeated(std::string name, int number, F type, std::string type_name = {}) {
  return field(std::move(name), number, type, std::move(type_name), true);
}

pb::MessageDef message(std::string full_name, std::vector<pb::FieldDef> fields,
                       std::vector<pb::EnumDef> enums = {}) {
  std::string file = full_name;
  for (char& c : file)
    if (c == '.') c = '/';
  return {std::move(full_name), file + ".proto", std::move(fields), std::move(enums)};
}

// Field numbers are those of the published Foxglove schemas (github.com/foxglove/foxglove-sdk,
// schemas/proto/foxglove/*.proto); CDFF's additions are numbered from 1000.
pb::DescriptorPool buildPool() {
  pb::DescriptorPool p;
  const std::string ts = "google.protobuf.Timestamp";
  p.add({"google.protobuf.Timestamp",
         "google/protobuf/timestamp.proto",
         {field("seconds", 1, F::kInt64), field("nanos", 2, F::kInt32)},
         {}});
  p.add({"google.protobuf.Duration",
         "google/protobuf/duration.proto",
         {field("seconds", 1, F::kInt64), field("nanos", 2, F::kInt32)},
         {}});
  p.add(message("foxglove.Vector3",
                {field("x", 1, F::kDouble), field("y", 2, F::kDouble), field("z", 3, F::kDouble)}));
  p.add(message("foxglove.Point3",
                {field("x", 1, F::kDouble), field("y", 2, F::kDouble), field("z", 3, F::kDouble)}));
  p.add(message("foxglove.Quaternion", {field("x", 1, F::kDouble), field("y", 2, F::kDouble),
                                        field("z", 3, F::kDouble), field("w", 4, F::kDouble)}));
  p.add(message("foxglove.Color", {field("r", 1, F::kDouble), field("g", 2, F::kDouble),
                                   field("b", 3, F::kDouble), field("a", 4, F::kDouble)}));
  p.add(message("foxglove.Pose", {field("position", 1, F::kMessage, "foxglove.Vector3"),
                                  field("orientation", 2, F::kMessage, "foxglove.Quaternion")}));
  p.add(message("foxglove.KeyValuePair",
                {field("key", 1, F::kString), field("value", 2, F::kString)}));
  p.add(message(
      "foxglove.CameraCalibration",
      {field("timestamp", 1, F::kMessage, ts), field("frame_id", 9, F::kString),
       field("width", 2, F::kFixed32), field("height", 3, F::kFixed32),
       field("distortion_model", 4, F::kString), repeated("D", 5, F::kDouble),
       repeated("K", 6, F::kDouble), repeated("R", 7, F::kDouble), repeated("P", 8, F::kDouble)}));
  p.add(message(
      "foxglove.RawImage",
      {field("timestamp", 1, F::kMessage, ts), field("frame_id", 7, F::kString),
       field("width", 2, F::kFixed32), field("height", 3, F::kFixed32),
       field("encoding", 4, F::kString), field("step", 5, F::kFixed32), field("data", 6, F::kBytes),
       field("cdff_camera", 1000, F::kMessage, "foxglove.CameraCalibration"),
       field("cdff_meters_per_unit", 1001, F::kDouble)}));
  p.add(message("foxglove.CompressedImage",
                {field("timestamp", 1, F::kMessage, ts), field("frame_id", 4, F::kString),
                 field("data", 2, F::kBytes), field("format", 3, F::kString)}));
  p.add(message("foxglove.PackedElementField",
                {field("name", 1, F::kString), field("offset", 2, F::kFixed32),
                 field("type", 3, F::kEnum, "foxglove.PackedElementField.NumericType")},
                {{"foxglove.PackedElementField.NumericType",
                  {{"UNKNOWN", 0},
                   {"UINT8", 1},
                   {"INT8", 2},
                   {"UINT16", 3},
                   {"INT16", 4},
                   {"UINT32", 5},
                   {"INT32", 6},
                   {"FLOAT32", 7},
                   {"FLOAT64", 8}}}}));
  p.add(message(
      "foxglove.PointCloud",
      {field("timestamp", 1, F::kMessage, ts), field("frame_id", 2, F::kString),
       field("pose", 3, F::kMessage, "foxglove.Pose"), field("point_stride", 4, F::kFixed32),
       repeated("fields", 5, F::kMessage, "foxglove.PackedElementField"),
       field("data", 6, F::kBytes)}));
  p.add(message("foxglove.FrameTransform",
                {field("timestamp", 1, F::kMessage, ts), field("parent_frame_id", 2, F::kString),
                 field("child_frame_id", 3, F::kString),
                 field("translation", 4, F::kMessage, "foxglove.Vector3"),
                 field("rotation", 5, F::kMessage, "foxglove.Quaternion")}));
  p.add(message("foxglove.PoseInFrame",
                {field("timestamp", 1, F::kMessage, ts), field("frame_id", 2, F::kString),
                 field("pose", 3, F::kMessage, "foxglove.Pose"),
                 field("cdff_child_frame_id", 1000, F::kString),
                 repeated("cdff_covariance", 1001, F::kDouble),
                 field("cdff_linear_velocity", 1002, F::kMessage, "foxglove.Vector3"),
                 field("cdff_angular_velocity", 1003, F::kMessage, "foxglove.Vector3")}));
  p.add(message("foxglove.PosesInFrame",
                {field("timestamp", 1, F::kMessage, ts), field("frame_id", 2, F::kString),
                 repeated("poses", 3, F::kMessage, "foxglove.Pose")}));
  // The scene primitives: a SceneEntity refers to all of them.
  p.add(message(
      "foxglove.ArrowPrimitive",
      {field("pose", 1, F::kMessage, "foxglove.Pose"), field("shaft_length", 2, F::kDouble),
       field("shaft_diameter", 3, F::kDouble), field("head_length", 4, F::kDouble),
       field("head_diameter", 5, F::kDouble), field("color", 6, F::kMessage, "foxglove.Color")}));
  p.add(message("foxglove.CubePrimitive", {field("pose", 1, F::kMessage, "foxglove.Pose"),
                                           field("size", 2, F::kMessage, "foxglove.Vector3"),
                                           field("color", 3, F::kMessage, "foxglove.Color")}));
  p.add(message("foxglove.SpherePrimitive", {field("pose", 1, F::kMessage, "foxglove.Pose"),
                                             field("size", 2, F::kMessage, "foxglove.Vector3"),
                                             field("color", 3, F::kMessage, "foxglove.Color")}));
  p.add(message(
      "foxglove.CylinderPrimitive",
      {field("pose", 1, F::kMessage, "foxglove.Pose"),
       field("size", 2, F::kMessage, "foxglove.Vector3"), field("bottom_scale", 3, F::kDouble),
       field("top_scale", 4, F::kDouble), field("color", 5, F::kMessage, "foxglove.Color")}));
  p.add(message(
      "foxglove.LinePrimitive",
      {field("type", 1, F::kEnum, "foxglove.LinePrimitive.Type"),
       field("pose", 2, F::kMessage, "foxglove.Pose"), field("thickness", 3, F::kDouble),
       field("scale_invariant", 4, F::kBool), repeated("points", 5, F::kMessage, "foxglove.Point3"),
       field("color", 6, F::kMessage, "foxglove.Color"),
       repeated("colors", 7, F::kMessage, "foxglove.Color"), repeated("indices", 8, F::kFixed32)},
      {{"foxglove.LinePrimitive.Type", {{"LINE_STRIP", 0}, {"LINE_LOOP", 1}, {"LINE_LIST", 2}}}}));
  p.add(message("foxglove.TriangleListPrimitive",
                {field("pose", 1, F::kMessage, "foxglove.Pose"),
                 repeated("points", 2, F::kMessage, "foxglove.Point3"),
                 field("color", 3, F::kMessage, "foxglove.Color"),
                 repeated("colors", 4, F::kMessage, "foxglove.Color"),
                 repeated("indices", 5, F::kFixed32), repeated("cdff_normals", 1000, F::kFloat)}));
  p.add(message("foxglove.TextPrimitive",
                {field("pose", 1, F::kMessage, "foxglove.Pose"), field("billboard", 2, F::kBool),
                 field("font_size", 3, F::kDouble), field("scale_invariant", 4, F::kBool),
                 field("color", 5, F::kMessage, "foxglove.Color"), field("text", 6, F::kString)}));
  p.add(message("foxglove.ModelPrimitive",
                {field("pose", 1, F::kMessage, "foxglove.Pose"),
                 field("scale", 2, F::kMessage, "foxglove.Vector3"),
                 field("color", 3, F::kMessage, "foxglove.Color"),
                 field("override_color", 4, F::kBool), field("url", 5, F::kString),
                 field("media_type", 6, F::kString), field("data", 7, F::kBytes)}));
  p.add(message(
      "foxglove.SceneEntity",
      {field("timestamp", 1, F::kMessage, ts), field("frame_id", 2, F::kString),
       field("id", 3, F::kString), field("lifetime", 4, F::kMessage, "google.protobuf.Duration"),
       field("frame_locked", 5, F::kBool),
       repeated("metadata", 6, F::kMessage, "foxglove.KeyValuePair"),
       repeated("arrows", 7, F::kMessage, "foxglove.ArrowPrimitive"),
       repeated("cubes", 8, F::kMessage, "foxglove.CubePrimitive"),
       repeated("spheres", 9, F::kMessage, "foxglove.SpherePrimitive"),
       repeated("cylinders", 10, F::kMessage, "foxglove.CylinderPrimitive"),
       repeated("lines", 11, F::kMessage, "foxglove.LinePrimitive"),
       repeated("triangles", 12, F::kMessage, "foxglove.TriangleListPrimitive"),
       repeated("texts", 13, F::kMessage, "foxglove.TextPrimitive"),
       repeated("models", 14, F::kMessage, "foxglove.ModelPrimitive")}));
  p.add(message(
      "foxglove.SceneEntityDeletion",
      {field("timestamp", 1, F::kMessage, ts),
       field("type", 2, F::kEnum, "foxglove.SceneEntityDeletion.Type"), field("id", 3, F::kString)},
      {{"foxglove.SceneEntityDeletion.Type", {{"MATCHING_ID", 0}, {"ALL", 1}}}}));
  p.add(message("foxglove.SceneUpdate",
                {repeated("deletions", 1, F::kMessage, "foxglove.SceneEntityDeletion"),
                 repeated("entities", 2, F::kMessage, "foxglove.SceneEntity")}));

  // CDFF's own schemas.
  p.add(message(
      "cdff.DescriptorMatrix",
      {field("element", 1, F::kEnum, "cdff.DescriptorMatrix.Element"),
       field("distance", 2, F::kEnum, "cdff.DescriptorMatrix.Distance"),
       field("rows", 3, F::kUint32), field("cols", 4, F::kUint32), field("data", 5, F::kBytes)},
      {{"cdff.DescriptorMatrix.Element", {{"UINT8", 0}, {"FLOAT32", 1}}},
       {"cdff.DescriptorMatrix.Distance", {{"HAMMING", 0}, {"HAMMING2", 1}, {"L2", 2}}}}));
  p.add(message("cdff.Features2D",
                {field("timestamp", 1, F::kMessage, ts), field("frame_id", 2, F::kString),
                 repeated("x", 3, F::kFloat), repeated("y", 4, F::kFloat),
                 repeated("size", 5, F::kFloat), repeated("angle", 6, F::kFloat),
                 repeated("response", 7, F::kFloat), repeated("octave", 8, F::kInt32),
                 field("descriptors", 9, F::kMessage, "cdff.DescriptorMatrix")}));
  p.add(message("cdff.Features3D",
                {field("timestamp", 1, F::kMessage, ts), field("frame_id", 2, F::kString),
                 repeated("positions", 3, F::kFloat), repeated("normals", 4, F::kFloat),
                 field("descriptors", 5, F::kMessage, "cdff.DescriptorMatrix")}));
  p.add(message("cdff.Matches",
                {field("timestamp", 1, F::kMessage, ts), repeated("query", 2, F::kInt32),
                 repeated("train", 3, F::kInt32), repeated("distance", 4, F::kFloat)}));
  p.add(message("cdff.Correspondences2D",
                {field("timestamp", 1, F::kMessage, ts), repeated("first", 2, F::kDouble),
                 repeated("second", 3, F::kDouble)}));
  p.add(message("cdff.Correspondences3D",
                {field("timestamp", 1, F::kMessage, ts), repeated("first", 2, F::kDouble),
                 repeated("second", 3, F::kDouble)}));
  p.add(message("cdff.Correspondences2D3D",
                {field("timestamp", 1, F::kMessage, ts), repeated("points", 2, F::kDouble),
                 repeated("pixels", 3, F::kDouble)}));
  p.add(message("cdff.StereoImagePair",
                {field("left", 1, F::kMessage, "foxglove.RawImage"),
                 field("right", 2, F::kMessage, "foxglove.RawImage"),
                 field("right_T_left", 3, F::kMessage, "foxglove.FrameTransform")}));
  return p;
}

const pb::DescriptorPool& pool() {
  static const pb::DescriptorPool p = buildPool();
  return p;
}

// JSON Schemas of the JSON-encoded types.
constexpr std::string_view kTimeSchema =
    R"({"type":"object","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}})";
constexpr std::string_view kVectorSchema =
    R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}})";

std::string jsonSchema(std::string_view title, std::string_view description,
                       std::string_view properties) {
  return fmt::format(R"({{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"{}",)"
                     R"("description":"{}","type":"object","properties":{{{}}}}})",
                     title, description, properties);
}

std::string imuSchema() {
  return jsonSchema(
      "cdff.ImuSample",
      "IMU sample: angular velocity (rad/s) and specific force (m/s^2) in frame_id; "
      "covariances row-major 3x3",
      fmt::format(R"("timestamp":{0},"frame_id":{{"type":"string"}},"angular_velocity":{1},)"
                  R"("linear_acceleration":{1},"angular_velocity_covariance":{{"type":"array",)"
                  R"("items":{{"type":["number","null"]}},"minItems":9,"maxItems":9}},)"
                  R"("linear_acceleration_covariance":{{"type":"array","items":{{"type":)"
                  R"(["number","null"]}},"minItems":9,"maxItems":9}})",
                  kTimeSchema, kVectorSchema));
}

std::string wrenchSchema() {
  return jsonSchema("cdff.Wrench",
                    "Force (N) and torque (N m) at the origin of frame_id, expressed in frame_id",
                    fmt::format(R"("timestamp":{0},"frame_id":{{"type":"string"}},)"
                                R"("force":{1},"torque":{1})",
                                kTimeSchema, kVectorSchema));
}

std::string jointSchema() {
  return jsonSchema(
      "cdff.JointState",
      "Joint positions (rad or m), velocities and efforts; velocity and effort may be empty",
      fmt::format(R"("timestamp":{0},"name":{{"type":"array","items":{{"type":"string"}}}},)"
                  R"("position":{{"type":"array","items":{{"type":["number","null"]}}}},)"
                  R"("velocity":{{"type":"array","items":{{"type":["number","null"]}}}},)"
                  R"("effort":{{"type":"array","items":{{"type":["number","null"]}}}})",
                  kTimeSchema));
}

std::string recordSchema() {
  return jsonSchema("cdff.Record",
                    "A free-form JSON record (events, DFN timings, reports); see "
                    "docs/recording.md for the conventions of /cdff/events and "
                    "/cdff/<dfpc>/timing",
                    fmt::format(R"("timestamp":{})", kTimeSchema));
}

std::string scalarSchema(std::string_view title, std::string_view value_type,
                         std::string_view description) {
  return jsonSchema(
      title, description,
      fmt::format(R"("timestamp":{},"value":{{"type":{}}})", kTimeSchema, value_type));
}

struct FormatStore {
  std::vector<std::vector<std::uint8_t>> data;  // owns the schema bytes
  std::vector<TypeFormat> formats;
};

const FormatStore& formatStore() {
  static const FormatStore store = [] {
    FormatStore s;
    struct Spec {
      std::string_view type, schema;
      bool json;
      std::string json_schema;
    };
    const std::vector<Spec> specs = {
        {"Image", "foxglove.RawImage", false, {}},
        {"DepthMap", "foxglove.RawImage", false, {}},
        {"StereoImagePair", "cdff.StereoImagePair", false, {}},
        {"CompressedImage", "foxglove.CompressedImage", false, {}},
        {"CameraModel", "foxglove.CameraCalibration", false, {}},
        {"PointCloud", "foxglove.PointCloud", false, {}},
        {"Transform", "foxglove.FrameTransform", false, {}},
        {"PoseWithCovariance", "foxglove.PoseInFrame", false, {}},
        {"RigidBodyState", "foxglove.PoseInFrame", false, {}},
        {"PoseArray", "foxglove.PosesInFrame", false, {}},
        {"TriangleMesh", "foxglove.SceneUpdate", false, {}},
        {"Features2D", "cdff.Features2D", false, {}},
        {"Features3D", "cdff.Features3D", false, {}},
        {"Matches", "cdff.Matches", false, {}},
        {"Correspondences2D", "cdff.Correspondences2D", false, {}},
        {"Correspondences3D", "cdff.Correspondences3D", false, {}},
        {"Correspondences2D3D", "cdff.Correspondences2D3D", false, {}},
        {"ImuSample", "cdff.ImuSample", true, imuSchema()},
        {"Wrench", "cdff.Wrench", true, wrenchSchema()},
        {"JointState", "cdff.JointState", true, jointSchema()},
        {"Json", "cdff.Record", true, recordSchema()},
        {"Double", "cdff.Double", true,
         scalarSchema("cdff.Double", R"(["number","null"])", "A real value; null is NaN")},
        {"Bool", "cdff.Bool", true, scalarSchema("cdff.Bool", R"("boolean")", "A flag")},
        {"Int", "cdff.Int", true, scalarSchema("cdff.Int", R"("integer")", "An integer")},
        {"Timestamp", "cdff.Timestamp", true,
         scalarSchema("cdff.Timestamp", R"("integer")", "A time in microseconds")},
        {"String", "cdff.String", true,
         scalarSchema("cdff.String", R"("string")", "A text, e.g. a tracker status")},
    };
    s.data.reserve(specs.size());
    for (const Spec& spec : specs) {
      if (spec.json) {
        s.data.emplace_back(spec.json_schema.begin(), spec.json_schema.end());
      } else {
        auto set = pool().fileDescriptorSet(spec.schema);
        s.data.push_back(set.isOk() ? std::move(set).value() : std::vector<std::uint8_t>{});
      }
      s.formats.push_back({spec.type, spec.schema, spec.json ? "jsonschema" : "protobuf",
                           spec.json ? "json" : "protobuf", Bytes(s.data.back())});
    }
    return s;
  }();
  return store;
}

}  // namespace

const std::vector<TypeFormat>& allFormats() {
  return formatStore().formats;
}

const TypeFormat* formatOf(std::string_view cdff_type) {
  for (const TypeFormat& f : allFormats())
    if (f.cdff_type == cdff_type) return &f;
  return nullptr;
}

std::string_view cdffTypeOf(const Channel& channel, const Schema* schema) {
  if (auto it = channel.metadata.find(std::string(kTypeMetadataKey)); it != channel.metadata.end())
    if (const TypeFormat* f = formatOf(it->second)) return f->cdff_type;
  if (!schema) return channel.message_encoding == "json" ? "Json" : "";
  for (const TypeFormat& f : allFormats())
    if (f.schema_name == schema->name && f.message_encoding == channel.message_encoding)
      return f.cdff_type;  // the first type of a shared schema: Image, PoseWithCovariance
  if (channel.message_encoding == "json") return "Json";
  return "";
}

std::vector<Bytes> Encoded::parts() const {
  std::vector<Bytes> parts;
  std::size_t previous = 0;
  for (const Reference& r : references_) {
    if (r.at > previous) parts.emplace_back(bytes.data() + previous, r.at - previous);
    if (!r.data.empty()) parts.push_back(r.data);
    previous = r.at;
  }
  if (bytes.size() > previous) parts.emplace_back(bytes.data() + previous, bytes.size() - previous);
  return parts;
}

std::size_t Encoded::size() const {
  std::size_t n = bytes.size();
  for (const Reference& r : references_) n += r.data.size();
  return n;
}

// ---- encoding helpers ----------------------------------------------------------------------

namespace {

Status negativeStamp(std::string_view what, Timestamp stamp) {
  return invalidInput("{} stamp is {} us; MCAP times are unsigned, expected a stamp >= 0", what,
                      stamp);
}

void putTimestamp(pb::Writer& w, std::uint32_t f, Timestamp us) {
  std::int64_t sec = us / kMicrosecondsPerSecond;
  std::int64_t rem = us % kMicrosecondsPerSecond;
  if (rem < 0) {
    rem += kMicrosecondsPerSecond;
    --sec;
  }
  const std::size_t s = w.begin(f);
  w.int64(1, sec);
  w.int32(2, static_cast<std::int32_t>(rem * 1000));
  w.end(s);
}

void putXyz(pb::Writer& w, std::uint32_t f, double x, double y, double z) {
  const std::size_t s = w.begin(f);
  w.float64(1, x);
  w.float64(2, y);
  w.float64(3, z);
  w.end(s);
}

void putQuaternion(pb::Writer& w, std::uint32_t f, const Eigen::Quaterniond& q) {
  const std::size_t s = w.begin(f);
  w.float64(1, q.x());
  w.float64(2, q.y());
  w.float64(3, q.z());
  w.float64(4, q.w());
  w.end(s);
}

void putPose(pb::Writer& w, std::uint32_t f, const Eigen::Vector3d& t,
             const Eigen::Quaterniond& q) {
  const std::size_t s = w.begin(f);
  putXyz(w, 1, t.x(), t.y(), t.z());
  putQuaternion(w, 2, q);
  w.end(s);
}

const char* distortionName(const CameraModel& c) {
  switch (c.distortion_model) {
    case DistortionModel::kNone:
      return "";
    case DistortionModel::kRadialTangential:
      return c.distortion.size() == 8 ? "rational_polynomial" : "plumb_bob";
    case DistortionModel::kEquidistant:
      return "kannala_brandt";
  }
  return "";
}

// The body of a foxglove.CameraCalibration.
void putCalibrationBody(pb::Writer& w, const CameraModel& c, Timestamp stamp,
                        std::string_view frame_id) {
  putTimestamp(w, 1, stamp);
  w.string(9, frame_id);
  w.fixed32(2, static_cast<std::uint32_t>(std::max(c.width, 0)));
  w.fixed32(3, static_cast<std::uint32_t>(std::max(c.height, 0)));
  w.string(4, distortionName(c));
  w.packed<double>(5, c.distortion);
  const double k[9] = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  const double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double p[12] = {c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0};
  w.packed<double>(6, k);
  w.packed<double>(7, r);
  w.packed<double>(8, p);
}

const char* imageEncoding(PixelFormat f) {
  switch (f) {
    case PixelFormat::kGray8:
      return "mono8";
    case PixelFormat::kBgr8:
      return "bgr8";
    case PixelFormat::kGray16:
      return "mono16";
    case PixelFormat::kFloat32:
      return "32FC1";
  }
  return "";
}

Status checkImageBuffer(const Image& im, std::string_view what) {
  if (im.width < 0 || im.height < 0)
    return invalidInput("{} is {}x{}; expected non-negative dimensions", what, im.width, im.height);
  const std::size_t row = static_cast<std::size_t>(im.width) * bytesPerPixel(im.format);
  if (im.height > 0 && im.stride_bytes < row)
    return invalidInput("{} stride is {} bytes; expected at least width x bytes per pixel = {}",
                        what, im.stride_bytes, row);
  const std::size_t need = static_cast<std::size_t>(im.height) * im.stride_bytes;
  if (im.pixels.size() < need)
    return invalidInput("{} holds {} bytes of pixels; expected height x stride = {}", what,
                        im.pixels.size(), need);
  if (im.stamp < 0) return negativeStamp(what, im.stamp);
  return Status::ok();
}

// The fields of a foxglove.RawImage except `data`, which the caller appends last.
void putRawImageHead(pb::Writer& w, const Image& im, const double* meters_per_unit) {
  putTimestamp(w, 1, im.stamp);
  w.string(7, im.frame_id);
  w.fixed32(2, static_cast<std::uint32_t>(im.width));
  w.fixed32(3, static_cast<std::uint32_t>(im.height));
  w.string(4, imageEncoding(im.format));
  w.fixed32(5, static_cast<std::uint32_t>(im.stride_bytes));
  if (im.camera) {
    const std::size_t s = w.begin(1000);
    putCalibrationBody(w, *im.camera, im.stamp, im.frame_id);
    w.end(s);
  }
  if (meters_per_unit) w.float64(1001, *meters_per_unit);
}

// Appends a whole RawImage with its pixels referenced, as the value of field `f` (0: as the
// top-level message).
void putRawImage(Encoded& out, std::uint32_t f, const Image& im, const double* meters_per_unit) {
  const std::size_t n = static_cast<std::size_t>(im.height) * im.stride_bytes;
  if (f == 0) {
    pb::Writer w(out.bytes);
    putRawImageHead(w, im, meters_per_unit);
    w.lengthPrefix(6, n);
  } else {
    std::vector<std::uint8_t> head;
    pb::Writer h(head);
    putRawImageHead(h, im, meters_per_unit);
    h.lengthPrefix(6, n);
    pb::Writer w(out.bytes);
    w.lengthPrefix(f, head.size() + n);
    w.raw(head.data(), head.size());
  }
  out.reference(Bytes(im.pixels.data(), n));
}

}  // namespace

Status encode(const Image& v, Encoded& out) {
  out.clear();
  CDFF_RETURN_IF_ERROR(checkImageBuffer(v, "image"));
  putRawImage(out, 0, v, nullptr);
  return Status::ok();
}

Status encode(const DepthMap& v, Encoded& out) {
  out.clear();
  CDFF_RETURN_IF_ERROR(checkImageBuffer(v.image, "depth map"));
  putRawImage(out, 0, v.image, &v.meters_per_unit);
  return Status::ok();
}

Status encode(const StereoImagePair& v, Encoded& out) {
  out.clear();
  CDFF_RETURN_IF_ERROR(checkImageBuffer(v.left, "stereo pair left image"));
  CDFF_RETURN_IF_ERROR(checkImageBuffer(v.right, "stereo pair right image"));
  putRawImage(out, 1, v.left, nullptr);
  putRawImage(out, 2, v.right, nullptr);
  pb::Writer w(out.bytes);
  const std::size_t s = w.begin(3);  // no reference() inside: begin/end may move bytes
  const Transform& t = v.right_T_left;
  putTimestamp(w, 1, t.stamp);
  w.string(2, t.parent_frame);
  w.string(3, t.child_frame);
  putXyz(w, 4, t.translation.x(), t.translation.y(), t.translation.z());
  putQuaternion(w, 5, t.rotation);
  w.end(s);
  return Status::ok();
}

Status encode(const CompressedImage& v, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("compressed image", v.stamp);
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(4, v.frame_id);
  w.string(3, v.format);
  w.lengthPrefix(2, v.data.size());
  out.reference(v.data.span());
  return Status::ok();
}

Status encode(const CameraModel& v, Timestamp stamp, std::string_view frame_id, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp("camera model", stamp);
  pb::Writer w(out.bytes);
  putCalibrationBody(w, v, stamp, frame_id);
  return Status::ok();
}

namespace {

enum NumericType : std::int32_t {
  kUint8 = 1,
  kInt8 = 2,
  kUint16 = 3,
  kInt16 = 4,
  kUint32 = 5,
  kInt32 = 6,
  kFloat32 = 7,
  kFloat64 = 8
};

int numericSize(std::int64_t t) {
  switch (t) {
    case kUint8:
    case kInt8:
      return 1;
    case kUint16:
    case kInt16:
      return 2;
    case kUint32:
    case kInt32:
    case kFloat32:
      return 4;
    case kFloat64:
      return 8;
    default:
      return 0;
  }
}

void putPackedField(pb::Writer& w, std::string_view name, std::uint32_t offset, NumericType type) {
  const std::size_t s = w.begin(5);
  w.string(1, name);
  w.fixed32(2, offset);
  w.int32(3, type);
  w.end(s);
}

}  // namespace

Status encode(const PointCloud& v, Encoded& out) {
  out.clear();
  const std::size_t n = v.points.size();
  auto check = [&](std::size_t size, const char* what) -> Status {
    if (size != 0 && size != n)
      return invalidInput(
          "point cloud has {} points but {} {} values; expected one per point or "
          "none",
          n, size, what);
    return Status::ok();
  };
  CDFF_RETURN_IF_ERROR(check(v.normals.size(), "normal"));
  CDFF_RETURN_IF_ERROR(check(v.intensity.size(), "intensity"));
  CDFF_RETURN_IF_ERROR(check(v.ring.size(), "ring"));
  CDFF_RETURN_IF_ERROR(check(v.time_offset_us.size(), "time offset"));
  if (v.stamp < 0) return negativeStamp("point cloud", v.stamp);

  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  putPose(w, 3, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  const bool plain =
      v.normals.empty() && v.intensity.empty() && v.ring.empty() && v.time_offset_us.empty();
  if (plain) {
    // The points as they are in memory: x y z and the (undeclared) homogeneous padding.
    w.fixed32(4, sizeof(Point4f));
    putPackedField(w, "x", 0, kFloat32);
    putPackedField(w, "y", 4, kFloat32);
    putPackedField(w, "z", 8, kFloat32);
    w.lengthPrefix(6, n * sizeof(Point4f));
    out.reference(
        Bytes(reinterpret_cast<const std::uint8_t*>(v.points.data()), n * sizeof(Point4f)));
    return Status::ok();
  }
  std::uint32_t stride = 12;
  const std::uint32_t normal_at = stride;
  if (!v.normals.empty()) stride += 12;
  const std::uint32_t intensity_at = stride;
  if (!v.intensity.empty()) stride += 4;
  const std::uint32_t time_at = stride;
  if (!v.time_offset_us.empty()) stride += 4;
  const std::uint32_t ring_at = stride;
  if (!v.ring.empty()) stride += 2;
  stride = (stride + 3) / 4 * 4;
  w.fixed32(4, stride);
  putPackedField(w, "x", 0, kFloat32);
  putPackedField(w, "y", 4, kFloat32);
  putPackedField(w, "z", 8, kFloat32);
  if (!v.normals.empty()) {
    putPackedField(w, "normal_x", normal_at, kFloat32);
    putPackedField(w, "normal_y", normal_at + 4, kFloat32);
    putPackedField(w, "normal_z", normal_at + 8, kFloat32);
  }
  if (!v.intensity.empty()) putPackedField(w, "intensity", intensity_at, kFloat32);
  if (!v.time_offset_us.empty()) putPackedField(w, "time_offset_us", time_at, kInt32);
  if (!v.ring.empty()) putPackedField(w, "ring", ring_at, kUint16);
  w.lengthPrefix(6, n * stride);
  const std::size_t at = out.bytes.size();
  out.bytes.resize(at + n * stride, 0);
  std::uint8_t* p = out.bytes.data() + at;
  for (std::size_t i = 0; i < n; ++i, p += stride) {
    std::memcpy(p, &v.points[i], 12);
    if (!v.normals.empty()) std::memcpy(p + normal_at, &v.normals[i], 12);
    if (!v.intensity.empty()) std::memcpy(p + intensity_at, &v.intensity[i], 4);
    if (!v.time_offset_us.empty()) std::memcpy(p + time_at, &v.time_offset_us[i], 4);
    if (!v.ring.empty()) std::memcpy(p + ring_at, &v.ring[i], 2);
  }
  return Status::ok();
}

Status encode(const Transform& v, Encoded& out) {
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

Status encode(const PoseWithCovariance& v, Encoded& out) {
  out.clear();
  if (v.pose.stamp < 0) return negativeStamp("pose", v.pose.stamp);
  pb::Writer w(out.bytes);
  putPoseInFrame(w, v.pose);
  putRowMajor<6>(w, 1001, v.covariance);
  return Status::ok();
}

Status encode(const RigidBodyState& v, Encoded& out) {
  out.clear();
  if (v.pose.stamp < 0) return negativeStamp("rigid body state", v.pose.stamp);
  pb::Writer w(out.bytes);
  putPoseInFrame(w, v.pose);
  putRowMajor<12>(w, 1001, v.covariance);
  putXyz(w, 1002, v.twist.linear.x(), v.twist.linear.y(), v.twist.linear.z());
  putXyz(w, 1003, v.twist.angular.x(), v.twist.angular.y(), v.twist.angular.z());
  return Status::ok();
}

Status encode(const PoseArray& v, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("pose array", v.stamp);
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  for (const Eigen::Isometry3d& p : v.poses)
    putPose(w, 3, p.translation(), Eigen::Quaterniond(p.rotation()));
  return Status::ok();
}

Status encode(const TriangleMesh& v, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("mesh", v.stamp);
  if (!v.vertex_normals.empty() && v.vertex_normals.size() != v.vertices.size())
    return invalidInput("mesh has {} vertices but {} normals; expected one per vertex or none",
                        v.vertices.size(), v.vertex_normals.size());
  pb::Writer w(out.bytes);
  const std::size_t entity = w.begin(2);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  w.string(3, "mesh");
  w.boolean(5, true);
  const std::size_t list = w.begin(12);
  putPose(w, 1, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  for (const Eigen::Vector3f& p : v.vertices) {
    w.lengthPrefix(2, 27);  // three tagged doubles
    w.float64(1, p.x());
    w.float64(2, p.y());
    w.float64(3, p.z());
  }
  {
    const std::size_t c = w.begin(3);
    w.float64(1, 0.75);
    w.float64(2, 0.75);
    w.float64(3, 0.78);
    w.float64(4, 1.0);
    w.end(c);
  }
  w.packed<std::uint32_t>(
      5, std::span<const std::uint32_t>(reinterpret_cast<const std::uint32_t*>(v.triangles.data()),
                                        v.triangles.size() * 3));
  if (!v.vertex_normals.empty())
    w.packed<float>(1000,
                    std::span<const float>(reinterpret_cast<const float*>(v.vertex_normals.data()),
                                           v.vertex_normals.size() * 3));
  w.end(list);
  w.end(entity);
  return Status::ok();
}

namespace {

void putDescriptors(pb::Writer& w, std::uint32_t f, const DescriptorMatrix& d) {
  const std::size_t s = w.begin(f);
  w.int32(1, d.element == DescriptorMatrix::Element::kUint8 ? 0 : 1);
  w.int32(2, static_cast<std::int32_t>(d.distance));
  w.uint64(3, static_cast<std::uint64_t>(std::max(d.rows, 0)));
  w.uint64(4, static_cast<std::uint64_t>(std::max(d.cols, 0)));
  w.bytes(5, d.data.span());
  w.end(s);
}

Status checkDescriptors(const DescriptorMatrix& d, std::size_t features) {
  if (d.rows < 0 || d.cols < 0)
    return invalidInput("descriptors are {}x{}; expected non-negative dimensions", d.rows, d.cols);
  const std::size_t need = static_cast<std::size_t>(d.rows) * d.cols * d.elementSize();
  if (d.data.size() != need)
    return invalidInput("descriptors hold {} bytes; expected rows x cols x element size = {}",
                        d.data.size(), need);
  if (d.rows != 0 && static_cast<std::size_t>(d.rows) != features)
    return invalidInput("{} descriptors for {} features; expected one per feature or none", d.rows,
                        features);
  return Status::ok();
}

template <typename T, typename Get>
void putPackedFloats(pb::Writer& w, std::uint32_t f, const std::vector<T>& items, Get get) {
  std::vector<float> values;
  values.reserve(items.size());
  for (const T& item : items) values.push_back(get(item));
  w.packed<float>(f, values);
}

template <typename Vec>
void putPackedVectors(pb::Writer& w, std::uint32_t f, const std::vector<Vec>& items) {
  using Scalar = typename Vec::Scalar;
  std::vector<Scalar> values;
  values.reserve(items.size() * Vec::RowsAtCompileTime);
  for (const Vec& v : items)
    for (int i = 0; i < Vec::RowsAtCompileTime; ++i) values.push_back(v[i]);
  w.packed<Scalar>(f, values);
}

}  // namespace

Status encode(const Features2D& v, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("features", v.stamp);
  CDFF_RETURN_IF_ERROR(checkDescriptors(v.descriptors, v.keypoints.size()));
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  const auto& k = v.keypoints;
  putPackedFloats(w, 3, k, [](const Keypoint2D& p) { return p.position.x(); });
  putPackedFloats(w, 4, k, [](const Keypoint2D& p) { return p.position.y(); });
  putPackedFloats(w, 5, k, [](const Keypoint2D& p) { return p.size; });
  putPackedFloats(w, 6, k, [](const Keypoint2D& p) { return p.angle; });
  putPackedFloats(w, 7, k, [](const Keypoint2D& p) { return p.response; });
  std::vector<std::int32_t> octaves;
  for (const Keypoint2D& p : k) octaves.push_back(p.octave);
  w.packedInt32(8, octaves);
  putDescriptors(w, 9, v.descriptors);
  return Status::ok();
}

Status encode(const Features3D& v, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("features", v.stamp);
  CDFF_RETURN_IF_ERROR(checkDescriptors(v.descriptors, v.keypoints.size()));
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  std::vector<Eigen::Vector3f> positions, normals;
  for (const Keypoint3D& p : v.keypoints) {
    positions.push_back(p.position);
    normals.push_back(p.normal);
  }
  putPackedVectors(w, 3, positions);
  putPackedVectors(w, 4, normals);
  putDescriptors(w, 5, v.descriptors);
  return Status::ok();
}

Status encode(const Matches& v, Timestamp stamp, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp("matches", stamp);
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, stamp);
  std::vector<std::int32_t> query, train;
  std::vector<float> distance;
  for (const Match& m : v.matches) {
    query.push_back(m.query);
    train.push_back(m.train);
    distance.push_back(m.distance);
  }
  w.packedInt32(2, query);
  w.packedInt32(3, train);
  w.packed<float>(4, distance);
  return Status::ok();
}

namespace {

template <typename A, typename B>
Status encodePairs(const std::vector<A>& a, const std::vector<B>& b, Timestamp stamp,
                   std::string_view what, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp(what, stamp);
  if (a.size() != b.size())
    return invalidInput("{} have {} and {} entries; expected as many of each", what, a.size(),
                        b.size());
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, stamp);
  putPackedVectors(w, 2, a);
  putPackedVectors(w, 3, b);
  return Status::ok();
}

}  // namespace

Status encode(const Correspondences2D& v, Timestamp stamp, Encoded& out) {
  return encodePairs(v.first, v.second, stamp, "2D correspondences", out);
}
Status encode(const Correspondences3D& v, Timestamp stamp, Encoded& out) {
  return encodePairs(v.first, v.second, stamp, "3D correspondences", out);
}
Status encode(const Correspondences2D3D& v, Timestamp stamp, Encoded& out) {
  return encodePairs(v.points, v.pixels, stamp, "2D-3D correspondences", out);
}

// ---- JSON types ----------------------------------------------------------------------------

namespace {

using nlohmann::json;

json timeJson(Timestamp us) {
  std::int64_t sec = us / kMicrosecondsPerSecond;
  std::int64_t rem = us % kMicrosecondsPerSecond;
  if (rem < 0) {
    rem += kMicrosecondsPerSecond;
    --sec;
  }
  return {{"sec", sec}, {"nsec", rem * 1000}};
}

// NaN and infinities become null (JSON has no such numbers); decoding turns null into NaN.
json number(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

json xyz(const Eigen::Vector3d& v) {
  return {{"x", number(v.x())}, {"y", number(v.y())}, {"z", number(v.z())}};
}

json rowMajor3(const Eigen::Matrix3d& m) {
  json a = json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a.push_back(number(m(r, c)));
  return a;
}

json numbers(const std::vector<double>& v) {
  json a = json::array();
  for (double x : v) a.push_back(number(x));
  return a;
}

void dumpTo(const json& j, Encoded& out) {
  const std::string text = j.dump(-1, ' ', false, json::error_handler_t::replace);
  out.bytes.assign(text.begin(), text.end());
}

}  // namespace

Status encode(const ImuSample& v, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("IMU sample", v.stamp);
  dumpTo({{"timestamp", timeJson(v.stamp)},
          {"frame_id", v.frame_id},
          {"angular_velocity", xyz(v.angular_velocity)},
          {"linear_acceleration", xyz(v.linear_acceleration)},
          {"angular_velocity_covariance", rowMajor3(v.angular_velocity_covariance)},
          {"linear_acceleration_covariance", rowMajor3(v.linear_acceleration_covariance)}},
         out);
  return Status::ok();
}

Status encode(const Wrench& v, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("wrench", v.stamp);
  dumpTo({{"timestamp", timeJson(v.stamp)},
          {"frame_id", v.frame_id},
          {"force", xyz(v.force)},
          {"torque", xyz(v.torque)}},
         out);
  return Status::ok();
}

Status encode(const JointState& v, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("joint state", v.stamp);
  dumpTo({{"timestamp", timeJson(v.stamp)},
          {"name", v.names},
          {"position", numbers(v.position)},
          {"velocity", numbers(v.velocity)},
          {"effort", numbers(v.effort)}},
         out);
  return Status::ok();
}

Status encode(const nlohmann::json& v, Timestamp stamp, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp("record", stamp);
  if (!v.is_object())
    return invalidInput("a JSON record must be an object; got a {}", v.type_name());
  if (v.contains("timestamp")) {
    dumpTo(v, out);
  } else {
    json copy = v;
    copy["timestamp"] = timeJson(stamp);
    dumpTo(copy, out);
  }
  return Status::ok();
}

template <typename T>
requires std::same_as<T, double> || std::same_as<T, bool> || std::same_as<T, int> ||
    std::same_as<T, std::int64_t> || std::same_as<T, std::string>
        Status encodeScalar(const T& v, Timestamp stamp, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp("scalar", stamp);
  json value = v;
  if constexpr (std::is_same_v<T, double>)
    if (!std::isfinite(v)) value = std::isnan(v) ? json(nullptr) : json(v > 0 ? 1e308 : -1e308);
  dumpTo({{"timestamp", timeJson(stamp)}, {"value", value}}, out);
  return Status::ok();
}
template Status encodeScalar(const double&, Timestamp, Encoded&);
template Status encodeScalar(const bool&, Timestamp, Encoded&);
template Status encodeScalar(const int&, Timestamp, Encoded&);
template Status encodeScalar(const std::int64_t&, Timestamp, Encoded&);
template Status encodeScalar(const std::string&, Timestamp, Encoded&);

// ---- decoding ------------------------------------------------------------------------------

namespace {

Status corruptMessage(std::string_view schema, const std::string& what) {
  return {StatusCode::kCorruptData, fmt::format("{} message: {}", schema, what)};
}

// Runs `on_field` on every field of `data`; fails with the reader's error.
template <typename OnField>
Status forFields(Bytes data, std::string_view schema, OnField&& on_field) {
  pb::Reader r(data);
  while (r.next())
    if (!on_field(r)) break;
  if (!r.ok()) return corruptMessage(schema, r.error());
  return Status::ok();
}

bool isLen(const pb::Reader& r) {
  return r.type() == WireType::kLen;
}

Status readTimestamp(Bytes data, Timestamp& out) {
  std::int64_t sec = 0, nsec = 0;
  CDFF_RETURN_IF_ERROR(forFields(data, "google.protobuf.Timestamp", [&](pb::Reader& r) {
    if (r.field() == 1 && r.type() == WireType::kVarint) sec = r.i64();
    if (r.field() == 2 && r.type() == WireType::kVarint) nsec = r.i32();
    return true;
  }));
  out = sec * kMicrosecondsPerSecond + nsec / 1000;
  return Status::ok();
}

double fixed64Double(const pb::Reader& r) {
  return r.type() == WireType::kFixed64 ? r.f64() : 0.0;
}

Status readXyz(Bytes data, Eigen::Vector3d& v) {
  v.setZero();
  return forFields(data, "foxglove.Vector3", [&](pb::Reader& r) {
    if (r.field() >= 1 && r.field() <= 3) v[r.field() - 1] = fixed64Double(r);
    return true;
  });
}

Status readQuaternion(Bytes data, Eigen::Quaterniond& q) {
  double c[4] = {0, 0, 0, 0};
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.Quaternion", [&](pb::Reader& r) {
    if (r.field() >= 1 && r.field() <= 4) c[r.field() - 1] = fixed64Double(r);
    return true;
  }));
  // An absent orientation (all fields zero) is the identity, as Foxglove reads it.
  q = (c[0] == 0 && c[1] == 0 && c[2] == 0 && c[3] == 0)
          ? Eigen::Quaterniond::Identity()
          : Eigen::Quaterniond(c[3], c[0], c[1], c[2]);
  return Status::ok();
}

Status readPose(Bytes data, Eigen::Vector3d& t, Eigen::Quaterniond& q) {
  t.setZero();
  q = Eigen::Quaterniond::Identity();
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.Pose", [&](pb::Reader& r) {
    if (r.field() == 1 && isLen(r)) inner = readXyz(r.bytes(), t);
    if (r.field() == 2 && isLen(r)) inner = readQuaternion(r.bytes(), q);
    return inner.isOk();
  }));
  return inner;
}

template <typename T>
bool appendRepeated(pb::Reader& r, std::vector<T>& out) {
  return r.appendFixed(out);
}

Status readCalibration(Bytes data, CameraModel& c, Timestamp* stamp, std::string* frame_id) {
  c = CameraModel{};
  std::string model;
  std::vector<double> k;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.CameraCalibration", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r) && stamp) inner = readTimestamp(r.bytes(), *stamp);
        break;
      case 9:
        if (isLen(r) && frame_id) *frame_id = r.string();
        break;
      case 2:
        c.width = static_cast<int>(r.u64());
        break;
      case 3:
        c.height = static_cast<int>(r.u64());
        break;
      case 4:
        if (isLen(r)) model = r.string();
        break;
      case 5:
        return appendRepeated(r, c.distortion);
      case 6:
        return appendRepeated(r, k);
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  if (k.size() != 9 && !k.empty())
    return corruptMessage("foxglove.CameraCalibration",
                          fmt::format("K has {} entries; expected 9", k.size()));
  if (k.size() == 9) {
    c.fx = k[0];
    c.cx = k[2];
    c.fy = k[4];
    c.cy = k[5];
  }
  if (model.empty() || model == "none") {
    c.distortion_model = DistortionModel::kNone;
  } else if (model == "plumb_bob" || model == "rational_polynomial" ||
             model == "radial_tangential") {
    c.distortion_model = DistortionModel::kRadialTangential;
  } else if (model == "kannala_brandt" || model == "equidistant" || model == "fisheye") {
    c.distortion_model = DistortionModel::kEquidistant;
  } else {
    return corruptMessage("foxglove.CameraCalibration",
                          fmt::format("distortion model '{}' is not supported; expected "
                                      "plumb_bob, rational_polynomial or kannala_brandt",
                                      model));
  }
  return Status::ok();
}

// Pixels from a message: shared with the chunk when aligned for the pixel type, else copied.
Buffer<std::uint8_t> sharePixels(Bytes data, const std::shared_ptr<const void>& owner,
                                 std::size_t alignment) {
  const bool aligned = reinterpret_cast<std::uintptr_t>(data.data()) % alignment == 0;
  if (owner && aligned) return Buffer<std::uint8_t>::view(owner, data.data(), data.size());
  return Buffer<std::uint8_t>::copyOf(data);
}

Status readRawImage(Bytes data, const std::shared_ptr<const void>& owner, Image& im,
                    double* meters_per_unit) {
  im = Image{};
  std::string encoding;
  Bytes pixels;
  std::uint32_t width = 0, height = 0, step = 0;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.RawImage", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r)) inner = readTimestamp(r.bytes(), im.stamp);
        break;
      case 7:
        if (isLen(r)) im.frame_id = r.string();
        break;
      case 2:
        width = static_cast<std::uint32_t>(r.u64());
        break;
      case 3:
        height = static_cast<std::uint32_t>(r.u64());
        break;
      case 4:
        if (isLen(r)) encoding = r.string();
        break;
      case 5:
        step = static_cast<std::uint32_t>(r.u64());
        break;
      case 6:
        if (isLen(r)) pixels = r.bytes();
        break;
      case 1000:
        if (isLen(r)) {
          CameraModel camera;
          inner = readCalibration(r.bytes(), camera, nullptr, nullptr);
          im.camera = std::move(camera);
        }
        break;
      case 1001:
        if (meters_per_unit && r.type() == WireType::kFixed64) *meters_per_unit = r.f64();
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  bool swap_rgb = false;
  if (encoding == "mono8" || encoding == "8UC1") {
    im.format = PixelFormat::kGray8;
  } else if (encoding == "bgr8" || encoding == "8UC3") {
    im.format = PixelFormat::kBgr8;
  } else if (encoding == "rgb8") {
    im.format = PixelFormat::kBgr8;
    swap_rgb = true;
  } else if (encoding == "mono16" || encoding == "16UC1") {
    im.format = PixelFormat::kGray16;
  } else if (encoding == "32FC1") {
    im.format = PixelFormat::kFloat32;
  } else {
    return corruptMessage("foxglove.RawImage",
                          fmt::format("encoding '{}' is not supported; expected mono8, bgr8, "
                                      "rgb8, mono16 or 32FC1",
                                      encoding));
  }
  const std::uint64_t row = static_cast<std::uint64_t>(width) * bytesPerPixel(im.format);
  if (height > 0 && step < row)
    return corruptMessage("foxglove.RawImage",
                          fmt::format("step {} is shorter than a {}-pixel {} row ({} bytes)", step,
                                      width, encoding, row));
  const std::uint64_t need = static_cast<std::uint64_t>(height) * step;
  if (pixels.size() < need)
    return corruptMessage("foxglove.RawImage",
                          fmt::format("data holds {} bytes; expected height {} x step {} = {}",
                                      pixels.size(), height, step, need));
  im.width = static_cast<int>(width);
  im.height = static_cast<int>(height);
  im.stride_bytes = step;
  pixels = pixels.first(static_cast<std::size_t>(need));
  if (swap_rgb) {
    std::vector<std::uint8_t> bgr(pixels.begin(), pixels.end());
    for (std::uint32_t y = 0; y < height; ++y)
      for (std::uint32_t x = 0; x < width; ++x)
        std::swap(bgr[y * step + 3 * x], bgr[y * step + 3 * x + 2]);
    im.pixels = Buffer<std::uint8_t>::fromVector(std::move(bgr));
  } else {
    im.pixels = sharePixels(
        pixels, owner,
        static_cast<std::size_t>(bytesPerPixel(im.format) == 3 ? 1 : bytesPerPixel(im.format)));
  }
  return Status::ok();
}

}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>& owner, Image& out) {
  return readRawImage(data, owner, out, nullptr);
}

Status decode(Bytes data, const std::shared_ptr<const void>& owner, DepthMap& out) {
  out = DepthMap{};
  return readRawImage(data, owner, out.image, &out.meters_per_unit);
}

Status decode(Bytes data, const std::shared_ptr<const void>& owner, StereoImagePair& out) {
  out = StereoImagePair{};
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.StereoImagePair", [&](pb::Reader& r) {
    if (!isLen(r)) return true;
    if (r.field() == 1) inner = readRawImage(r.bytes(), owner, out.left, nullptr);
    if (r.field() == 2) inner = readRawImage(r.bytes(), owner, out.right, nullptr);
    if (r.field() == 3) inner = decode(r.bytes(), owner, out.right_T_left);
    return inner.isOk();
  }));
  return inner;
}

Status decode(Bytes data, const std::shared_ptr<const void>& owner, CompressedImage& out) {
  out = CompressedImage{};
  Bytes bytes;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.CompressedImage", [&](pb::Reader& r) {
    if (!isLen(r)) return true;
    if (r.field() == 1) inner = readTimestamp(r.bytes(), out.stamp);
    if (r.field() == 4) out.frame_id = r.string();
    if (r.field() == 3) out.format = r.string();
    if (r.field() == 2) bytes = r.bytes();
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  out.data = sharePixels(bytes, owner, 1);
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, CameraModel& out) {
  return readCalibration(data, out, nullptr, nullptr);
}

namespace {

float readAsFloat(const std::uint8_t* p, std::int64_t type) {
  switch (type) {
    case kUint8:
      return *p;
    case kInt8:
      return static_cast<float>(static_cast<std::int8_t>(*p));
    case kUint16: {
      std::uint16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case kInt16: {
      std::int16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case kUint32: {
      std::uint32_t v;
      std::memcpy(&v, p, 4);
      return static_cast<float>(v);
    }
    case kInt32: {
      std::int32_t v;
      std::memcpy(&v, p, 4);
      return static_cast<float>(v);
    }
    case kFloat32: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case kFloat64: {
      double v;
      std::memcpy(&v, p, 8);
      return static_cast<float>(v);
    }
    default:
      return 0;
  }
}

double readAsDouble(const std::uint8_t* p, std::int64_t type) {
  if (type == kFloat64) {
    double v;
    std::memcpy(&v, p, 8);
    return v;
  }
  if (type == kInt32) {
    std::int32_t v;
    std::memcpy(&v, p, 4);
    return v;
  }
  if (type == kUint32) {
    std::uint32_t v;
    std::memcpy(&v, p, 4);
    return v;
  }
  return readAsFloat(p, type);
}

struct PackedField {
  std::uint32_t offset = 0;
  std::int64_t type = 0;
};

}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>& owner, PointCloud& out) {
  out = PointCloud{};
  std::map<std::string, PackedField> fields;
  std::uint32_t stride = 0;
  Bytes points;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.PointCloud", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r)) inner = readTimestamp(r.bytes(), out.stamp);
        break;
      case 2:
        if (isLen(r)) out.frame_id = r.string();
        break;
      case 3:
        if (isLen(r)) inner = readPose(r.bytes(), origin, orientation);
        break;
      case 4:
        stride = static_cast<std::uint32_t>(r.u64());
        break;
      case 5:
        if (isLen(r)) {
          std::string name;
          PackedField f;
          inner = forFields(r.bytes(), "foxglove.PackedElementField", [&](pb::Reader& fr) {
            if (fr.field() == 1 && isLen(fr)) name = fr.string();
            if (fr.field() == 2) f.offset = static_cast<std::uint32_t>(fr.u64());
            if (fr.field() == 3) f.type = fr.i64();
            return true;
          });
          fields[name] = f;
        }
        break;
      case 6:
        if (isLen(r)) points = r.bytes();
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  const char* schema = "foxglove.PointCloud";
  for (const char* axis : {"x", "y", "z"})
    if (!fields.count(axis))
      return corruptMessage(schema, fmt::format("has no '{}' field; expected x, y and z", axis));
  for (const auto& [name, f] : fields) {
    const int size = numericSize(f.type);
    if (size == 0)
      return corruptMessage(schema,
                            fmt::format("field '{}' has unknown numeric type {}", name, f.type));
    if (static_cast<std::uint64_t>(f.offset) + size > stride)
      return corruptMessage(schema, fmt::format("field '{}' at offset {} ({} bytes) overruns the "
                                                "point stride {}",
                                                name, f.offset, size, stride));
  }
  if (points.size() % stride != 0)
    return corruptMessage(schema, fmt::format("data holds {} bytes, not a multiple of the point "
                                              "stride {}",
                                              points.size(), stride));
  const std::size_t n = points.size() / stride;
  const bool identity_pose =
      origin.isZero() && orientation.coeffs() == Eigen::Quaterniond::Identity().coeffs();
  const auto& fx = fields["x"];
  const auto& fy = fields["y"];
  const auto& fz = fields["z"];
  const bool plain = stride == sizeof(Point4f) && fields.size() == 3 && fx.offset == 0 &&
                     fy.offset == 4 && fz.offset == 8 && fx.type == kFloat32 &&
                     fy.type == kFloat32 && fz.type == kFloat32 && identity_pose;
  if (plain) {
    bool padded_with_one = true;
    for (std::size_t i = 0; i < n && padded_with_one; ++i) {
      float pad;
      std::memcpy(&pad, points.data() + i * 16 + 12, 4);
      padded_with_one = pad == 1.0f;
    }
    const bool aligned = reinterpret_cast<std::uintptr_t>(points.data()) % alignof(Point4f) == 0;
    if (owner && aligned && padded_with_one) {
      out.points = Buffer<Point4f>::view(owner, reinterpret_cast<const Point4f*>(points.data()), n);
      return Status::ok();
    }
  }
  std::vector<Point4f> xyz(n);
  const Eigen::Matrix3d rotation = orientation.normalized().toRotationMatrix();
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* p = points.data() + i * stride;
    Eigen::Vector3d v(readAsDouble(p + fx.offset, fx.type), readAsDouble(p + fy.offset, fy.type),
                      readAsDouble(p + fz.offset, fz.type));
    if (!identity_pose) v = rotation * v + origin;
    xyz[i] =
        Point4f(static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
  }
  out.points = Buffer<Point4f>::fromVector(std::move(xyz));
  if (fields.count("normal_x") && fields.count("normal_y") && fields.count("normal_z")) {
    const auto nx = fields["normal_x"], ny = fields["normal_y"], nz = fields["normal_z"];
    std::vector<Point4f> normals(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint8_t* p = points.data() + i * stride;
      Eigen::Vector3d v(readAsDouble(p + nx.offset, nx.type), readAsDouble(p + ny.offset, ny.type),
                        readAsDouble(p + nz.offset, nz.type));
      if (!identity_pose) v = rotation * v;
      normals[i] =
          Point4f(static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
    }
    out.normals = Buffer<Point4f>::fromVector(std::move(normals));
  }
  if (auto it = fields.find("intensity"); it != fields.end()) {
    std::vector<float> values(n);
    for (std::size_t i = 0; i < n; ++i)
      values[i] = readAsFloat(points.data() + i * stride + it->second.offset, it->second.type);
    out.intensity = Buffer<float>::fromVector(std::move(values));
  }
  if (auto it = fields.find("ring"); it != fields.end()) {
    std::vector<std::uint16_t> values(n);
    for (std::size_t i = 0; i < n; ++i)
      values[i] = static_cast<std::uint16_t>(
          readAsDouble(points.data() + i * stride + it->second.offset, it->second.type));
    out.ring = Buffer<std::uint16_t>::fromVector(std::move(values));
  }
  if (auto it = fields.find("time_offset_us"); it != fields.end()) {
    std::vector<std::int32_t> values(n);
    for (std::size_t i = 0; i < n; ++i)
      values[i] = static_cast<std::int32_t>(
          readAsDouble(points.data() + i * stride + it->second.offset, it->second.type));
    out.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(values));
  }
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

Status decode(Bytes data, const std::shared_ptr<const void>&, TriangleMesh& out) {
  out = TriangleMesh{};
  std::vector<Eigen::Vector3f> vertices, normals;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  bool have_entity = false;
  Status inner;
  auto read_list = [&](Bytes list) -> Status {
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();
    Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
    std::vector<Eigen::Vector3d> points;
    std::vector<std::uint32_t> indices;
    std::vector<float> list_normals;
    Status s;
    CDFF_RETURN_IF_ERROR(forFields(list, "foxglove.TriangleListPrimitive", [&](pb::Reader& r) {
      if (r.field() == 1 && isLen(r)) s = readPose(r.bytes(), origin, orientation);
      if (r.field() == 2 && isLen(r)) {
        Eigen::Vector3d p = Eigen::Vector3d::Zero();
        s = forFields(r.bytes(), "foxglove.Point3", [&](pb::Reader& pr) {
          if (pr.field() >= 1 && pr.field() <= 3) p[pr.field() - 1] = fixed64Double(pr);
          return true;
        });
        points.push_back(p);
      }
      if (r.field() == 5) return appendRepeated(r, indices);
      if (r.field() == 1000) return appendRepeated(r, list_normals);
      return s.isOk();
    }));
    CDFF_RETURN_IF_ERROR(s);
    const auto base = static_cast<std::uint32_t>(vertices.size());
    const Eigen::Matrix3d rotation = orientation.normalized().toRotationMatrix();
    for (const Eigen::Vector3d& p : points)
      vertices.push_back((rotation * p + origin).cast<float>());
    if (list_normals.size() == points.size() * 3) {
      for (std::size_t i = 0; i < points.size(); ++i)
        normals.push_back((rotation * Eigen::Vector3d(list_normals[3 * i], list_normals[3 * i + 1],
                                                      list_normals[3 * i + 2]))
                              .cast<float>());
    }
    if (indices.empty())
      for (std::uint32_t i = 0; i < points.size(); ++i) indices.push_back(i);
    if (indices.size() % 3 != 0)
      return corruptMessage("foxglove.TriangleListPrimitive",
                            fmt::format("{} indices, not a multiple of 3", indices.size()));
    for (std::size_t i = 0; i < indices.size(); i += 3) {
      for (int k = 0; k < 3; ++k)
        if (indices[i + k] >= points.size())
          return corruptMessage(
              "foxglove.TriangleListPrimitive",
              fmt::format("index {} is out of range ({} points)", indices[i + k], points.size()));
      triangles.push_back({base + indices[i], base + indices[i + 1], base + indices[i + 2]});
    }
    return Status::ok();
  };
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.SceneUpdate", [&](pb::Reader& r) {
    if (r.field() != 2 || !isLen(r) || have_entity) return true;
    have_entity = true;  // the first entity is the mesh
    inner = forFields(r.bytes(), "foxglove.SceneEntity", [&](pb::Reader& er) {
      Status s;
      if (er.field() == 1 && isLen(er)) s = readTimestamp(er.bytes(), out.stamp);
      if (er.field() == 2 && isLen(er)) out.frame_id = er.string();
      if (er.field() == 12 && isLen(er)) s = read_list(er.bytes());
      if (!s.isOk()) inner = s;
      return s.isOk();
    });
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  if (!normals.empty() && normals.size() != vertices.size()) normals.clear();
  out.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  out.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
  out.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
  return Status::ok();
}

namespace {

Status readDescriptors(Bytes data, DescriptorMatrix& d) {
  d = DescriptorMatrix{};
  Bytes bytes;
  std::uint64_t rows = 0, cols = 0;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.DescriptorMatrix", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        d.element =
            r.u64() == 1 ? DescriptorMatrix::Element::kFloat32 : DescriptorMatrix::Element::kUint8;
        break;
      case 2:
        d.distance = static_cast<DescriptorMatrix::Distance>(std::min<std::uint64_t>(r.u64(), 2));
        break;
      case 3:
        rows = r.u64();
        break;
      case 4:
        cols = r.u64();
        break;
      case 5:
        if (isLen(r)) bytes = r.bytes();
        break;
      default:
        break;
    }
    return true;
  }));
  if (rows > (1u << 30) || cols > (1u << 20) || rows * cols * d.elementSize() != bytes.size())
    return corruptMessage(
        "cdff.DescriptorMatrix",
        fmt::format("{} x {} descriptors of {} bytes need {} bytes; the data "
                    "holds {}",
                    rows, cols, d.elementSize(), rows * cols * d.elementSize(), bytes.size()));
  d.rows = static_cast<int>(rows);
  d.cols = static_cast<int>(cols);
  d.data = Buffer<std::uint8_t>::copyOf(bytes);
  return Status::ok();
}

Status sameSizes(std::string_view schema, std::initializer_list<std::size_t> sizes,
                 std::size_t expected) {
  for (std::size_t s : sizes)
    if (s != expected)
      return corruptMessage(schema, fmt::format("per-feature arrays have {} and {} entries; "
                                                "expected the same count",
                                                s, expected));
  return Status::ok();
}

template <typename Vec>
Status toVectors(std::string_view schema, const std::vector<typename Vec::Scalar>& values,
                 std::vector<Vec>& out) {
  constexpr int n = Vec::RowsAtCompileTime;
  if (values.size() % n != 0)
    return corruptMessage(schema,
                          fmt::format("{} coordinates, not a multiple of {}", values.size(), n));
  out.resize(values.size() / n);
  for (std::size_t i = 0; i < out.size(); ++i)
    for (int k = 0; k < n; ++k) out[i][k] = values[i * n + k];
  return Status::ok();
}

}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>&, Features2D& out) {
  out = Features2D{};
  std::vector<float> x, y, size, angle, response;
  std::vector<std::int64_t> octave;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.Features2D", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r)) inner = readTimestamp(r.bytes(), out.stamp);
        break;
      case 2:
        if (isLen(r)) out.frame_id = r.string();
        break;
      case 3:
        return appendRepeated(r, x);
      case 4:
        return appendRepeated(r, y);
      case 5:
        return appendRepeated(r, size);
      case 6:
        return appendRepeated(r, angle);
      case 7:
        return appendRepeated(r, response);
      case 8:
        return r.appendVarint(octave);
      case 9:
        if (isLen(r)) inner = readDescriptors(r.bytes(), out.descriptors);
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  CDFF_RETURN_IF_ERROR(
      sameSizes("cdff.Features2D",
                {y.size(), size.size(), angle.size(), response.size(), octave.size()}, x.size()));
  out.keypoints.resize(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    Keypoint2D& k = out.keypoints[i];
    k.position = {x[i], y[i]};
    k.size = size[i];
    k.angle = angle[i];
    k.response = response[i];
    k.octave = static_cast<int>(octave[i]);
  }
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, Features3D& out) {
  out = Features3D{};
  std::vector<float> positions, normals;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.Features3D", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r)) inner = readTimestamp(r.bytes(), out.stamp);
        break;
      case 2:
        if (isLen(r)) out.frame_id = r.string();
        break;
      case 3:
        return appendRepeated(r, positions);
      case 4:
        return appendRepeated(r, normals);
      case 5:
        if (isLen(r)) inner = readDescriptors(r.bytes(), out.descriptors);
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  std::vector<Eigen::Vector3f> p, n;
  CDFF_RETURN_IF_ERROR(toVectors("cdff.Features3D", positions, p));
  CDFF_RETURN_IF_ERROR(toVectors("cdff.Features3D", normals, n));
  if (!n.empty()) CDFF_RETURN_IF_ERROR(sameSizes("cdff.Features3D", {n.size()}, p.size()));
  out.keypoints.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    out.keypoints[i].position = p[i];
    if (!n.empty()) out.keypoints[i].normal = n[i];
  }
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, Matches& out) {
  out = Matches{};
  std::vector<std::int64_t> query, train;
  std::vector<float> distance;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.Matches", [&](pb::Reader& r) {
    if (r.field() == 2) return r.appendVarint(query);
    if (r.field() == 3) return r.appendVarint(train);
    if (r.field() == 4) return appendRepeated(r, distance);
    return true;
  }));
  CDFF_RETURN_IF_ERROR(sameSizes("cdff.Matches", {train.size(), distance.size()}, query.size()));
  out.matches.resize(query.size());
  for (std::size_t i = 0; i < query.size(); ++i)
    out.matches[i] = {static_cast<int>(query[i]), static_cast<int>(train[i]), distance[i]};
  return Status::ok();
}

namespace {

template <typename A, typename B>
Status decodePairs(Bytes data, std::string_view schema, std::vector<A>& a, std::vector<B>& b) {
  std::vector<double> first, second;
  CDFF_RETURN_IF_ERROR(forFields(data, schema, [&](pb::Reader& r) {
    if (r.field() == 2) return appendRepeated(r, first);
    if (r.field() == 3) return appendRepeated(r, second);
    return true;
  }));
  CDFF_RETURN_IF_ERROR(toVectors(schema, first, a));
  CDFF_RETURN_IF_ERROR(toVectors(schema, second, b));
  return sameSizes(schema, {b.size()}, a.size());
}

}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>&, Correspondences2D& out) {
  out = Correspondences2D{};
  return decodePairs(data, "cdff.Correspondences2D", out.first, out.second);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, Correspondences3D& out) {
  out = Correspondences3D{};
  return decodePairs(data, "cdff.Correspondences3D", out.first, out.second);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, Correspondences2D3D& out) {
  out = Correspondences2D3D{};
  return decodePairs(data, "cdff.Correspondences2D3D", out.points, out.pixels);
}

namespace {

Status parseJson(Bytes data, std::string_view schema, json& out) {
  out = json::parse(data.begin(), data.end(), nullptr, false);
  if (out.is_discarded()) return corruptMessage(schema, "is not valid JSON");
  if (!out.is_object()) return corruptMessage(schema, "is not a JSON object");
  return Status::ok();
}

double jsonNumber(const json& j) {
  return j.is_number() ? j.get<double>() : std::nan("");
}

Timestamp jsonTime(const json& j) {
  const json& t = j.at("timestamp");
  return t.at("sec").get<std::int64_t>() * kMicrosecondsPerSecond +
         t.at("nsec").get<std::int64_t>() / 1000;
}

Eigen::Vector3d jsonXyz(const json& j) {
  return {jsonNumber(j.at("x")), jsonNumber(j.at("y")), jsonNumber(j.at("z"))};
}

Eigen::Matrix3d jsonMatrix3(const json& j) {
  Eigen::Matrix3d m;
  if (j.size() != 9) throw std::out_of_range("expected 9 entries");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = jsonNumber(j.at(static_cast<std::size_t>(r * 3 + c)));
  return m;
}

std::vector<double> jsonNumbers(const json& j) {
  std::vector<double> v;
  for (const json& x : j) v.push_back(jsonNumber(x));
  return v;
}

// nlohmann throws on a missing key or a wrong type; turn that into a Status.
template <typename Fill>
Status fromJson(Bytes data, std::string_view schema, Fill&& fill) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, schema, j));
  try {
    fill(j);
  } catch (const std::exception& e) {
    return corruptMessage(schema, fmt::format("missing or malformed field: {}", e.what()));
  }
  return Status::ok();
}

}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>&, ImuSample& out) {
  out = ImuSample{};
  return fromJson(data, "cdff.ImuSample", [&](const json& j) {
    out.stamp = jsonTime(j);
    out.frame_id = j.at("frame_id").get<std::string>();
    out.angular_velocity = jsonXyz(j.at("angular_velocity"));
    out.linear_acceleration = jsonXyz(j.at("linear_acceleration"));
    out.angular_velocity_covariance = jsonMatrix3(j.at("angular_velocity_covariance"));
    out.linear_acceleration_covariance = jsonMatrix3(j.at("linear_acceleration_covariance"));
  });
}

Status decode(Bytes data, const std::shared_ptr<const void>&, Wrench& out) {
  out = Wrench{};
  return fromJson(data, "cdff.Wrench", [&](const json& j) {
    out.stamp = jsonTime(j);
    out.frame_id = j.at("frame_id").get<std::string>();
    out.force = jsonXyz(j.at("force"));
    out.torque = jsonXyz(j.at("torque"));
  });
}

Status decode(Bytes data, const std::shared_ptr<const void>&, JointState& out) {
  out = JointState{};
  return fromJson(data, "cdff.JointState", [&](const json& j) {
    out.stamp = jsonTime(j);
    out.names = j.at("name").get<std::vector<std::string>>();
    out.position = jsonNumbers(j.at("position"));
    out.velocity = jsonNumbers(j.at("velocity"));
    out.effort = jsonNumbers(j.at("effort"));
  });
}

Status decode(Bytes data, const std::shared_ptr<const void>&, nlohmann::json& out) {
  return parseJson(data, "JSON record", out);
}

namespace {
template <typename T>
Status decodeScalar(Bytes data, std::string_view schema, T& out) {
  return fromJson(data, schema, [&](const json& j) {
    const json& value = j.at("value");
    if constexpr (std::is_same_v<T, double>)
      out = value.is_null() ? std::nan("") : value.get<double>();
    else
      out = value.get<T>();
  });
}
}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>&, double& out) {
  return decodeScalar(data, "cdff.Double", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, bool& out) {
  return decodeScalar(data, "cdff.Bool", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, int& out) {
  return decodeScalar(data, "cdff.Int", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, std::int64_t& out) {
  return decodeScalar(data, "cdff.Timestamp", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, std::string& out) {
  return decodeScalar(data, "cdff.String", out);
}

// ---- type-erased decoding --------------------------------------------------------------------

namespace {

using DecodeFn = Result<AnyValue> (*)(Bytes, const std::shared_ptr<const void>&);

template <typename T>
Result<AnyValue> decodeShared(Bytes data, const std::shared_ptr<const void>& owner) {
  auto value = std::make_shared<T>();
  CDFF_RETURN_IF_ERROR(decode(data, owner, *value));
  return AnyValue{std::shared_ptr<const void>(std::move(value)), TypeName<T>::value,
                  std::type_index(typeid(T))};
}

struct DecoderEntry {
  std::string_view name;
  DecodeFn fn;
};

template <typename... T>
std::vector<DecoderEntry> decoders() {
  return {DecoderEntry{TypeName<T>::value, &decodeShared<T>}...};
}

}  // namespace

Result<AnyValue> decodeAny(std::string_view cdff_type, Bytes data,
                           const std::shared_ptr<const void>& owner) {
  static const std::vector<DecoderEntry> table =
      decoders<Image, DepthMap, StereoImagePair, CompressedImage, CameraModel, PointCloud,
               Transform, PoseWithCovariance, RigidBodyState, PoseArray, TriangleMesh, Features2D,
               Features3D, Matches, Correspondences2D, Correspondences3D, Correspondences2D3D,
               ImuSample, Wrench, JointState, nlohmann::json, double, bool, int, std::int64_t,
               std::string>();
  for (const DecoderEntry& e : table)
    if (e.name == cdff_type) return e.fn(data, owner);
  return notFound("no decoder for CDFF type '{}'", cdff_type);
}

}  // namespace cdff::io
