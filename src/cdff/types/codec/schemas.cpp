// The schemas of the CDFF types: protobuf descriptors (Foxglove's and CDFF's own) and JSON
// Schemas. docs/recording.md lists them.
#include <map>
#include <mutex>

#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory
using F = pb::FieldType;

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

// Protobuf's well-known time types and Foxglove's geometry, which the others are built of.
void addBasicMessages(pb::DescriptorPool& p) {
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
}

// Foxglove's messages of sensor data, transforms and poses.
void addSensorMessages(pb::DescriptorPool& p) {
  const std::string ts = "google.protobuf.Timestamp";
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
}

// The scene primitives: a SceneEntity refers to all of them.
void addScenePrimitives(pb::DescriptorPool& p) {
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
}

// The scene entities made of the primitives, and the updates that add and delete them.
void addSceneMessages(pb::DescriptorPool& p) {
  const std::string ts = "google.protobuf.Timestamp";
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
}

// CDFF's own schemas: features, matches, correspondences and stereo pairs.
void addCdffMessages(pb::DescriptorPool& p) {
  const std::string ts = "google.protobuf.Timestamp";
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
}

// Field numbers are those of the published Foxglove schemas (github.com/foxglove/foxglove-sdk,
// schemas/proto/foxglove/*.proto); CDFF's additions are numbered from 1000. Messages are added
// after the messages their fields refer to.
pb::DescriptorPool buildPool() {
  pb::DescriptorPool p;
  addBasicMessages(p);
  addSensorMessages(p);
  addScenePrimitives(p);
  addSceneMessages(p);
  addCdffMessages(p);
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

std::string lidarInfoSchema() {
  return jsonSchema(
      "cdff.LidarInfo",
      "A spinning LIDAR's description: laser elevations (rad, any order) about the z axis of "
      "frame_id, rotation rate (Hz), range limits and noise (m)",
      fmt::format(R"("timestamp":{},"frame_id":{{"type":"string"}},)"
                  R"("elevations":{{"type":"array","items":{{"type":["number","null"]}}}},)"
                  R"("rotation_rate":{{"type":["number","null"]}},)"
                  R"("min_range":{{"type":["number","null"]}},)"
                  R"("max_range":{{"type":["number","null"]}},)"
                  R"("range_noise":{{"type":["number","null"]}})",
                  kTimeSchema));
}

// A Transform as products.json writes it (codec::toJson).
constexpr std::string_view kTransformSchema =
    R"({"type":"object","properties":{"stamp_us":{"type":"integer"},)"
    R"("parent_frame":{"type":"string"},"child_frame":{"type":"string"},)"
    R"("translation":{"type":"array","items":{"type":["number","null"]},)"
    R"("minItems":3,"maxItems":3},"rotation_wxyz":{"type":"array",)"
    R"("items":{"type":["number","null"]},"minItems":4,"maxItems":4}}})";

std::string detectionsSchema() {
  return jsonSchema(
      "cdff.Detections",
      "The detections of known objects in one image, best first: each with its pose "
      "camera_T_object (parent frame_id, the image's optical frame), similarity (0..1), the "
      "depth agreement (0..1, null when no depth was checked), the "
      "matched template's id and box [x, y, width, height] (pixels of the input image)",
      fmt::format(R"("timestamp":{},"frame_id":{{"type":"string"}},)"
                  R"("detections":{{"type":"array","items":{{"type":"object","properties":{{)"
                  R"("pose":{},"similarity":{{"type":["number","null"]}},)"
                  R"("depth_agreement":{{"type":["number","null"]}},)"
                  R"("template_id":{{"type":"string"}},"box":{{"type":"array","items":)"
                  R"({{"type":"integer"}},"minItems":4,"maxItems":4}}}}}}}})",
                  kTimeSchema, kTransformSchema));
}

std::string imageRegionSchema() {
  return jsonSchema(
      "cdff.ImageRegion",
      "Where a template lies in one image (far-range tracking): the homography from template "
      "pixels to image pixels (row-major 3x3), the template's size [width, height] (px), its "
      "centre's image position (px), the matching score (ZNCC, null for a designation or a "
      "prediction), the centre's covariance (px^2, row-major 2x2) and the source (user, "
      "automatic, prediction, match)",
      fmt::format(R"("timestamp":{},"frame_id":{{"type":"string"}},)"
                  R"("homography":{{"type":"array","items":{{"type":["number","null"]}},)"
                  R"("minItems":9,"maxItems":9}},)"
                  R"("size":{{"type":"array","items":{{"type":"integer"}},"minItems":2,)"
                  R"("maxItems":2}},)"
                  R"("centre":{{"type":"array","items":{{"type":["number","null"]}}}},)"
                  R"("score":{{"type":["number","null"]}},)"
                  R"("covariance":{{"type":"array","items":{{"type":["number","null"]}},)"
                  R"("minItems":4,"maxItems":4}},"source":{{"type":"string"}})",
                  kTimeSchema));
}

std::string bearingSchema() {
  return jsonSchema(
      "cdff.Bearing",
      "The direction to the target (unit vector in frame_id, the servicer's body frame) with "
      "its covariance (rad^2, row-major 3x3), its azimuth and elevation (deg, REP-103), and the "
      "range (m) and range rate (m/s) with their variances where a sensor measures them (null "
      "otherwise); the designation that started the track",
      fmt::format(R"("timestamp":{},"frame_id":{{"type":"string"}},)"
                  R"("direction":{{"type":"array","items":{{"type":["number","null"]}}}},)"
                  R"("covariance":{{"type":"array","items":{{"type":["number","null"]}}}},)"
                  R"("azimuth_deg":{{"type":["number","null"]}},)"
                  R"("elevation_deg":{{"type":["number","null"]}},)"
                  R"("range":{{"type":["number","null"]}},)"
                  R"("range_variance":{{"type":["number","null"]}},)"
                  R"("range_rate":{{"type":["number","null"]}},)"
                  R"("range_rate_variance":{{"type":["number","null"]}},)"
                  R"("designation":{{"type":"string"}})",
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

std::string objectSchema(std::string_view title, std::string_view description) {
  return jsonSchema(title, description, fmt::format(R"("timestamp":{})", kTimeSchema));
}

/// The JSON Schema text of each JSON-encoded type's schema.
const std::map<std::string, std::string, std::less<>>& jsonSchemas() {
  static const std::map<std::string, std::string, std::less<>> schemas = {
      {"cdff.ImuSample", imuSchema()},
      {"cdff.Wrench", wrenchSchema()},
      {"cdff.JointState", jointSchema()},
      {"cdff.LidarInfo", lidarInfoSchema()},
      {"cdff.Detections", detectionsSchema()},
      {"cdff.ImageRegion", imageRegionSchema()},
      {"cdff.Bearing", bearingSchema()},
      {"cdff.Record", recordSchema()},
      {"cdff.PolygonModel",
       objectSchema("cdff.PolygonModel",
                    "A polygon model (points, faces, lines, cylinders, circles) in frame_id; "
                    "docs/recording.md lists the fields")},
      {"cdff.ModelContours",
       objectSchema("cdff.ModelContours",
                    "The contours of a model that one camera sees from a pose; docs/recording.md "
                    "lists the fields")},
      {"cdff.ContourSamples",
       objectSchema("cdff.ContourSamples",
                    "Points sampled along model contours with their image edge candidates; "
                    "docs/recording.md lists the fields")},
      {"cdff.TrackState",
       scalarSchema("cdff.TrackState",
                    R"({"enum":["UNINITIALISED","ACQUIRING","TRACKING","DEGRADED","LOST"]})",
                    "The state of a track")},
      {"cdff.Double",
       scalarSchema("cdff.Double", R"(["number","null"])", "A real value; null is NaN")},
      {"cdff.Bool", scalarSchema("cdff.Bool", R"("boolean")", "A flag")},
      {"cdff.Int", scalarSchema("cdff.Int", R"("integer")", "An integer")},
      {"cdff.Timestamp", scalarSchema("cdff.Timestamp", R"("integer")", "A time in microseconds")},
      {"cdff.String", scalarSchema("cdff.String", R"("string")", "A text, e.g. a tracker status")},
  };
  return schemas;
}

struct SchemaStore {
  std::mutex mutex;
  std::map<std::string, std::vector<std::uint8_t>, std::less<>> data;
};

}  // namespace

Bytes schemaData(std::string_view schema_name, MessageEncoding encoding) {
  static SchemaStore store;
  const std::lock_guard<std::mutex> lock(store.mutex);
  auto it = store.data.find(schema_name);
  if (it == store.data.end()) {
    std::vector<std::uint8_t> bytes;
    if (encoding == MessageEncoding::kJson) {
      auto schema = jsonSchemas().find(schema_name);
      if (schema != jsonSchemas().end()) bytes.assign(schema->second.begin(), schema->second.end());
    } else {
      auto set = pool().fileDescriptorSet(std::string(schema_name));
      if (set.isOk()) bytes = std::move(set).value();
    }
    it = store.data.emplace(std::string(schema_name), std::move(bytes)).first;
  }
  return Bytes(it->second);
}

}  // namespace cdff::codec
