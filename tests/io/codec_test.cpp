// Every core type survives Recorder -> MCAP -> Replay losslessly; replay merges files in time
// order; the embedded schemas are valid descriptors.
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cdff/dfn/port.hpp"
#include "cdff/io/inspect.hpp"
#include "cdff/io/recorder.hpp"
#include "cdff/io/replay.hpp"
#include "cdff/types/codec/codec.hpp"
#include "cdff/types/codec/protobuf.hpp"
#include "samples.hpp"

namespace cdff::io {
namespace {

namespace fs = std::filesystem;
namespace pb = ::cdff::codec::pb;
using codec::Encoded;
using testing::IoSamples;

fs::path tempDir() {
  return fs::temp_directory_path() / ("cdff_codec_test_" + std::to_string(::getpid()));
}
std::string tempPath(const std::string& name) {
  fs::create_directories(tempDir());
  return (tempDir() / name).string();
}
class RemoveTempDir : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(tempDir(), ignored);
  }
};
const auto* const kCleanup = ::testing::AddGlobalTestEnvironment(new RemoveTempDir);

// Exact comparison, NaN equal to NaN.
bool same(double a, double b) {
  return a == b || (std::isnan(a) && std::isnan(b));
}

template <typename M>
void expectSameMatrix(const M& a, const M& b, const char* what) {
  ASSERT_EQ(a.rows(), b.rows()) << what;
  ASSERT_EQ(a.cols(), b.cols()) << what;
  for (Eigen::Index r = 0; r < a.rows(); ++r)
    for (Eigen::Index c = 0; c < a.cols(); ++c)
      EXPECT_TRUE(same(a(r, c), b(r, c)))
          << what << "(" << r << "," << c << "): " << a(r, c) << " vs " << b(r, c);
}

void expectSame(const CameraModel& a, const CameraModel& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.fx, b.fx);
  EXPECT_EQ(a.fy, b.fy);
  EXPECT_EQ(a.cx, b.cx);
  EXPECT_EQ(a.cy, b.cy);
  EXPECT_EQ(a.distortion_model, b.distortion_model);
  EXPECT_EQ(a.distortion, b.distortion);
}

void expectSame(const Image& a, const Image& b) {
  EXPECT_EQ(a.stamp, b.stamp);
  EXPECT_EQ(a.frame_id, b.frame_id);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.format, b.format);
  EXPECT_EQ(a.stride_bytes, b.stride_bytes);
  const std::size_t n = static_cast<std::size_t>(a.height) * a.stride_bytes;
  ASSERT_GE(b.pixels.size(), n);
  EXPECT_EQ(0, std::memcmp(a.pixels.data(), b.pixels.data(), n));
  ASSERT_EQ(a.camera.has_value(), b.camera.has_value());
  if (a.camera) expectSame(*a.camera, *b.camera);
}

void expectSame(const Transform& a, const Transform& b) {
  EXPECT_EQ(a.stamp, b.stamp);
  EXPECT_EQ(a.parent_frame, b.parent_frame);
  EXPECT_EQ(a.child_frame, b.child_frame);
  expectSameMatrix(a.translation, b.translation, "translation");
  expectSameMatrix(a.rotation.coeffs(), b.rotation.coeffs(), "rotation");
}

template <typename T>
void expectSameBuffer(const Buffer<T>& a, const Buffer<T>& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  if (a.size()) {
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(T))) << what;
  }
}

void expectSame(const PointCloud& a, const PointCloud& b) {
  EXPECT_EQ(a.stamp, b.stamp);
  EXPECT_EQ(a.frame_id, b.frame_id);
  expectSameBuffer(a.points, b.points, "points");
  expectSameBuffer(a.normals, b.normals, "normals");
  expectSameBuffer(a.intensity, b.intensity, "intensity");
  expectSameBuffer(a.ring, b.ring, "ring");
  expectSameBuffer(a.time_offset_us, b.time_offset_us, "time offsets");
}

void expectSame(const DescriptorMatrix& a, const DescriptorMatrix& b) {
  EXPECT_EQ(a.element, b.element);
  EXPECT_EQ(a.distance, b.distance);
  EXPECT_EQ(a.rows, b.rows);
  EXPECT_EQ(a.cols, b.cols);
  expectSameBuffer(a.data, b.data, "descriptors");
}

// Reads back a file written with writeIoSamples() and checks every channel against `s`.
void checkSamples(Replay& replay, const IoSamples& s, std::size_t* count = nullptr) {
  std::size_t n = 0;
  while (replay.next()) {
    const ReplayMessage& m = replay.message();
    const std::string& c = m.channel();
    ++n;
    SCOPED_TRACE(c);
    // Every channel decodes through the type-erased path to its type.
    Result<Value> any = m.decode();
    ASSERT_TRUE(any.isOk()) << any.status().toString();
    EXPECT_EQ(any->type(), m.type());
    if (c == "/chaser/camera/left/image") {
      expectSame(*m.decode<Image>().value(), s.image_mono);
      EXPECT_NE(any->as<Image>(), nullptr);
    } else if (c == "/chaser/camera/right/image") {
      expectSame(*m.decode<Image>().value(), s.image_bgr);
    } else if (c == "/chaser/thermal/image") {
      expectSame(*m.decode<Image>().value(), s.image_float);
    } else if (c == "/chaser/camera/left/calibration") {
      expectSame(*m.decode<CameraModel>().value(), s.camera);
    } else if (c == "/chaser/camera/left/compressed") {
      auto v = m.decode<CompressedImage>().value();
      EXPECT_EQ(v->stamp, s.compressed.stamp);
      EXPECT_EQ(v->frame_id, s.compressed.frame_id);
      EXPECT_EQ(v->format, "png");
      expectSameBuffer(v->data, s.compressed.data, "compressed data");
    } else if (c == "/chaser/stereo/pair") {
      auto v = m.decode<StereoImagePair>().value();
      expectSame(v->left, s.stereo.left);
      expectSame(v->right, s.stereo.right);
      expectSame(v->right_T_left, s.stereo.right_T_left);
    } else if (c == "/chaser/tof/depth" || c == "/chaser/tof/depth_mm") {
      const DepthMap& expected = c == "/chaser/tof/depth" ? s.depth_m : s.depth_mm;
      auto v = m.decode<DepthMap>().value();
      expectSame(v->image, expected.image);
      EXPECT_EQ(v->meters_per_unit, expected.meters_per_unit);
    } else if (c == "/chaser/lidar/points") {
      expectSame(*m.decode<PointCloud>().value(), s.cloud);
    } else if (c == "/chaser/lidar/points_xyz") {
      expectSame(*m.decode<PointCloud>().value(), s.cloud_xyz);
    } else if (c == "/chaser/tf/camera_left") {
      expectSame(*m.decode<Transform>().value(), s.transform);
    } else if (c == "/cdff/pose_estimation/pose") {
      auto v = m.decode<PoseWithCovariance>().value();
      expectSame(v->pose, s.pose.pose);
      expectSameMatrix(v->covariance, s.pose.covariance, "covariance");
    } else if (c == "/truth/target_state") {
      auto v = m.decode<RigidBodyState>().value();
      expectSame(v->pose, s.state.pose);
      expectSameMatrix(v->twist.linear, s.state.twist.linear, "linear velocity");
      expectSameMatrix(v->twist.angular, s.state.twist.angular, "angular velocity");
      expectSameMatrix(v->covariance, s.state.covariance, "covariance");
      // The same schema read as a pose keeps the pose block of the covariance.
      auto p = m.decode<PoseWithCovariance>();
      ASSERT_TRUE(p.isOk()) << p.status().toString();
      expectSameMatrix((*p)->covariance, Matrix6d(s.state.covariance.topLeftCorner<6, 6>()),
                       "pose block");
    } else if (c == "/cdff/pose_estimation/trajectory") {
      auto v = m.decode<PoseArray>().value();
      EXPECT_EQ(v->frame_id, s.trajectory.frame_id);
      ASSERT_EQ(v->poses.size(), s.trajectory.poses.size());
      for (std::size_t i = 0; i < v->poses.size(); ++i)
        EXPECT_TRUE(v->poses[i].isApprox(s.trajectory.poses[i], 1e-12));
    } else if (c == "/cdff/reconstruction/mesh") {
      auto v = m.decode<TriangleMesh>().value();
      EXPECT_EQ(v->stamp, s.mesh.stamp);
      EXPECT_EQ(v->frame_id, s.mesh.frame_id);
      expectSameBuffer(v->vertices, s.mesh.vertices, "vertices");
      expectSameBuffer(v->vertex_normals, s.mesh.vertex_normals, "normals");
      expectSameBuffer(v->triangles, s.mesh.triangles, "triangles");
    } else if (c == "/cdff/tracking/features") {
      auto v = m.decode<Features2D>().value();
      EXPECT_EQ(v->stamp, s.features2d.stamp);
      EXPECT_EQ(v->frame_id, s.features2d.frame_id);
      ASSERT_EQ(v->keypoints.size(), s.features2d.keypoints.size());
      for (std::size_t i = 0; i < v->keypoints.size(); ++i) {
        const auto &a = v->keypoints[i], &b = s.features2d.keypoints[i];
        EXPECT_EQ(a.position, b.position);
        EXPECT_EQ(a.size, b.size);
        EXPECT_EQ(a.angle, b.angle);
        EXPECT_EQ(a.response, b.response);
        EXPECT_EQ(a.octave, b.octave);
      }
      expectSame(v->descriptors, s.features2d.descriptors);
    } else if (c == "/cdff/tracking/features3d") {
      auto v = m.decode<Features3D>().value();
      ASSERT_EQ(v->keypoints.size(), s.features3d.keypoints.size());
      for (std::size_t i = 0; i < v->keypoints.size(); ++i) {
        EXPECT_EQ(v->keypoints[i].position, s.features3d.keypoints[i].position);
        EXPECT_EQ(v->keypoints[i].normal, s.features3d.keypoints[i].normal);
      }
      expectSame(v->descriptors, s.features3d.descriptors);
    } else if (c == "/cdff/tracking/matches") {
      auto v = m.decode<Matches>().value();
      ASSERT_EQ(v->size(), s.matches.size());
      for (std::size_t i = 0; i < v->size(); ++i) {
        EXPECT_EQ(v->matches[i].query, s.matches.matches[i].query);
        EXPECT_EQ(v->matches[i].train, s.matches.matches[i].train);
        EXPECT_EQ(v->matches[i].distance, s.matches.matches[i].distance);
      }
    } else if (c == "/cdff/tracking/correspondences2d") {
      auto v = m.decode<Correspondences2D>().value();
      EXPECT_EQ(v->first, s.corr2d.first);
      EXPECT_EQ(v->second, s.corr2d.second);
    } else if (c == "/cdff/tracking/correspondences3d") {
      auto v = m.decode<Correspondences3D>().value();
      EXPECT_EQ(v->first, s.corr3d.first);
      EXPECT_EQ(v->second, s.corr3d.second);
    } else if (c == "/cdff/tracking/correspondences2d3d") {
      auto v = m.decode<Correspondences2D3D>().value();
      EXPECT_EQ(v->points, s.corr2d3d.points);
      EXPECT_EQ(v->pixels, s.corr2d3d.pixels);
    } else if (c == "/chaser/imu") {
      auto v = m.decode<ImuSample>().value();
      EXPECT_EQ(v->stamp, s.imu.stamp);
      EXPECT_EQ(v->frame_id, s.imu.frame_id);
      expectSameMatrix(v->angular_velocity, s.imu.angular_velocity, "gyro");
      expectSameMatrix(v->linear_acceleration, s.imu.linear_acceleration, "accel");
      expectSameMatrix(v->angular_velocity_covariance, s.imu.angular_velocity_covariance,
                       "gyro cov");
      expectSameMatrix(v->linear_acceleration_covariance, s.imu.linear_acceleration_covariance,
                       "accel cov");
    } else if (c == "/chaser/arm/wrench") {
      auto v = m.decode<Wrench>().value();
      EXPECT_EQ(v->stamp, s.wrench.stamp);
      EXPECT_EQ(v->frame_id, s.wrench.frame_id);
      EXPECT_EQ(v->force, s.wrench.force);
      EXPECT_EQ(v->torque, s.wrench.torque);
    } else if (c == "/chaser/arm/joints") {
      auto v = m.decode<JointState>().value();
      EXPECT_EQ(v->stamp, s.joints.stamp);
      EXPECT_EQ(v->names, s.joints.names);
      EXPECT_EQ(v->position, s.joints.position);
      EXPECT_EQ(v->velocity, s.joints.velocity);
      EXPECT_EQ(v->effort, s.joints.effort);
    } else if (c == "/cdff/pose_estimation/timing") {
      auto v = m.decode<nlohmann::json>().value();
      EXPECT_EQ((*v)["dfn"], s.record["dfn"]);
      EXPECT_EQ((*v)["wall_s"], s.record["wall_s"]);
      EXPECT_EQ((*v)["timestamp"]["sec"].get<std::int64_t>(), m.logTime() / 1'000'000);
    } else if (c == "/cdff/events") {
      auto v = m.decode<nlohmann::json>().value();
      EXPECT_EQ((*v)["level"], "info");
      EXPECT_EQ((*v)["source"], "orchestrator");
    } else {
      ADD_FAILURE() << "unexpected channel " << c;
    }
  }
  EXPECT_TRUE(replay.status().isOk()) << replay.status().toString();
  if (count) *count = n;
}

class CodecRoundTrip : public ::testing::TestWithParam<Compression> {};

TEST_P(CodecRoundTrip, EveryCoreTypeIsLossless) {
  const std::string path = tempPath(std::string("types_") + toString(GetParam()) + ".mcap");
  const Timestamp stamp = 1'700'000'123'456'789;  // us, with sub-second digits
  const IoSamples s = testing::makeIoSamples(3, stamp);
  {
    Recorder rec;
    McapWriterOptions options;
    options.compression = GetParam();
    ASSERT_TRUE(rec.open(path, options).isOk());
    ASSERT_TRUE(testing::writeIoSamples(rec, s, stamp).isOk());
    ASSERT_TRUE(rec.close().isOk());
  }
  Replay replay;
  ASSERT_TRUE(replay.open({path}).isOk());
  EXPECT_EQ(replay.channels().size(), 26u);
  std::size_t n = 0;
  checkSamples(replay, s, &n);
  EXPECT_EQ(n, 26u);
}

INSTANTIATE_TEST_SUITE_P(Compressions, CodecRoundTrip,
                         ::testing::Values(Compression::kNone, Compression::kLz4,
                                           Compression::kZstd),
                         [](const auto& info) { return std::string(toString(info.param)); });

TEST(Codec, RecordedTypesAreTheRegistrysTypes) {
  // A channel's type is found in the registry by the name its metadata records, the name the
  // DFN ports use: every name finds its own entry, and a port's type is that entry.
  for (TypeId t : allTypes()) EXPECT_EQ(findType(t.name()), t) << t.name();
  EXPECT_EQ(dfn::InputPort<PointCloud>("cloud").type(), findType("PointCloud"));
  EXPECT_FALSE(findType("Imgae").valid());
}

TEST(Recorder, ScalarsRoundTripWithTheirPortTypes) {
  const std::string path = tempPath("scalars.mcap");
  {
    Recorder rec;
    ASSERT_TRUE(rec.open(path).isOk());
    ASSERT_TRUE(rec.write("/nis", 3.25, 10).isOk());
    ASSERT_TRUE(rec.write("/nis", std::nan(""), 20).isOk());
    ASSERT_TRUE(rec.write("/ok", true, 10).isOk());
    ASSERT_TRUE(rec.write("/count", 42, 10).isOk());
    ASSERT_TRUE(rec.write("/time", Timestamp{1234567890123}, 10).isOk());
    ASSERT_TRUE(rec.write("/status", std::string("TRACKING"), 10).isOk());
    ASSERT_TRUE(rec.write("/state", TrackState::kDegraded, 10).isOk());
    const Status wrong = rec.write("/status", 1.0, 11);
    EXPECT_EQ(wrong.code(), StatusCode::kInvalidInput);
    EXPECT_NE(wrong.message().find("String"), std::string::npos) << wrong.message();
    ASSERT_TRUE(rec.close().isOk());
  }
  Replay replay;
  ASSERT_TRUE(replay.open({path}).isOk());
  std::vector<std::string> seen;
  while (replay.next()) {
    const ReplayMessage& m = replay.message();
    Result<Value> any = m.decode();
    ASSERT_TRUE(any.isOk()) << any.status().toString();
    EXPECT_EQ(any->type(), m.type());
    if (m.channel() == "/nis") {
      const double v = *any->as<double>();
      EXPECT_TRUE(m.logTime() == 10 ? v == 3.25 : std::isnan(v)) << v;
    } else if (m.channel() == "/ok") {
      EXPECT_TRUE(*any->as<bool>());
    } else if (m.channel() == "/count") {
      EXPECT_EQ(*any->as<int>(), 42);
    } else if (m.channel() == "/time") {
      EXPECT_EQ(*any->as<Timestamp>(), 1234567890123);
    } else if (m.channel() == "/state") {
      EXPECT_EQ(*any->as<TrackState>(), TrackState::kDegraded);
    } else {
      EXPECT_EQ(*any->as<std::string>(), "TRACKING");
    }
    seen.push_back(std::string(m.type().name()));
  }
  EXPECT_TRUE(replay.status().isOk());
  EXPECT_EQ(seen.size(), 7u);
}

TEST(Codec, DecodedValuesFeedPortsThroughTheTypeErasedPath) {
  const IoSamples s = testing::makeIoSamples(1, 5);
  Encoded e;
  ASSERT_TRUE(codec::encode(s.cloud, 5, e).isOk());
  const std::vector<std::uint8_t> flat = e.flatten();
  Result<Value> any = TypeId::of<PointCloud>().info().decode(flat, nullptr);
  ASSERT_TRUE(any.isOk());
  dfn::InputPort<PointCloud> port("cloud");
  ASSERT_TRUE(port.setAny(*any).isOk());
  EXPECT_EQ(port.get()->size(), s.cloud.size());
  dfn::InputPort<Image> wrong("image");
  EXPECT_FALSE(wrong.setAny(*any).isOk());
}

TEST(Codec, ImagePixelsAreSharedWithTheChunkNotCopied) {
  const std::string path = tempPath("zero_copy.mcap");
  const IoSamples s = testing::makeIoSamples(0, 10);
  {
    Recorder rec;
    McapWriterOptions o;
    o.compression = Compression::kNone;
    ASSERT_TRUE(rec.open(path, o).isOk());
    ASSERT_TRUE(rec.write("/img", s.image_mono).isOk());
    ASSERT_TRUE(rec.close().isOk());
  }
  Replay replay;
  ASSERT_TRUE(replay.open({path}).isOk());
  ASSERT_TRUE(replay.next());
  auto image = replay.message().decode<Image>();
  ASSERT_TRUE(image.isOk());
  const std::uint8_t* chunk_data = replay.message().data().data();
  const std::uint8_t* pixels = (*image)->pixels.data();
  EXPECT_GE(pixels, chunk_data);
  EXPECT_LT(pixels, chunk_data + replay.message().data().size());
}

TEST(Codec, EmbeddedDescriptorsParseBackWithFoxgloveFieldNumbers) {
  const TypeInfo& image = TypeId::of<Image>().info();
  EXPECT_EQ(image.schema_name, "foxglove.RawImage");
  auto pool = pb::DescriptorPool::parse(image.schemaData());
  ASSERT_TRUE(pool.isOk()) << pool.status().toString();
  const pb::MessageDef* raw = pool->message("foxglove.RawImage");
  ASSERT_NE(raw, nullptr);
  EXPECT_EQ(raw->field(7)->name, "frame_id");
  EXPECT_EQ(raw->field(6)->name, "data");
  EXPECT_EQ(raw->field(6)->type, pb::FieldType::kBytes);
  EXPECT_EQ(raw->field(1)->type_name, "google.protobuf.Timestamp");
  ASSERT_NE(pool->message("google.protobuf.Timestamp"), nullptr);
  ASSERT_NE(pool->message("foxglove.CameraCalibration"), nullptr);
  EXPECT_EQ(raw->file, "foxglove/RawImage.proto");

  auto scene = pb::DescriptorPool::parse(TypeId::of<TriangleMesh>().info().schemaData());
  ASSERT_TRUE(scene.isOk());
  for (const char* name :
       {"foxglove.SceneUpdate", "foxglove.SceneEntity", "foxglove.ArrowPrimitive",
        "foxglove.ModelPrimitive", "google.protobuf.Duration"})
    EXPECT_NE(scene->message(name), nullptr) << name;
  EXPECT_NE(scene->enumType("foxglove.LinePrimitive.Type"), nullptr);
  EXPECT_EQ(scene->message("foxglove.SceneEntity")->field(12)->name, "triangles");

  for (TypeId t : allTypes()) {
    const TypeInfo& f = t.info();
    const Bytes data = f.schemaData();
    ASSERT_FALSE(data.empty()) << f.name;
    if (f.schemaEncoding() == "protobuf") {
      auto p = pb::DescriptorPool::parse(data);
      ASSERT_TRUE(p.isOk()) << f.name;
      EXPECT_NE(p->message(f.schema_name), nullptr) << f.name;
    } else {
      const auto j = nlohmann::json::parse(data.begin(), data.end(), nullptr, false);
      ASSERT_FALSE(j.is_discarded()) << f.name;
      EXPECT_EQ(j["title"], f.schema_name);
    }
  }
}

TEST(Codec, MalformedMessagesAreRefusedWithTheFieldAndOffset) {
  const IoSamples s = testing::makeIoSamples(0, 10);
  Encoded e;
  ASSERT_TRUE(codec::encode(s.image_mono, 10, e).isOk());
  const std::vector<std::uint8_t> flat = e.flatten();
  // Cut inside the pixel data.
  std::vector<std::uint8_t> cut(flat.begin(), flat.end() - 10);
  Image image;
  Status st = codec::decode(cut, nullptr, image);
  EXPECT_EQ(st.code(), StatusCode::kCorruptData);
  EXPECT_NE(st.message().find("foxglove.RawImage"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("byte offset"), std::string::npos) << st.message();
  // Every truncation of every type fails cleanly or decodes; nothing crashes.
  const std::vector<Value> values = {Value::of(s.image_mono), Value::of(s.cloud), Value::of(s.mesh),
                                     Value::of(s.features2d), Value::of(s.imu),   Value::of(s.pose),
                                     Value::of(s.stereo)};
  for (const Value& v : values) {
    const TypeInfo& type = v.type().info();
    Encoded enc;
    ASSERT_TRUE(type.encode(v.raw(), 10, enc).isOk()) << type.name;
    const std::vector<std::uint8_t> bytes = enc.flatten();
    for (std::size_t n = 0; n < bytes.size(); n += 1 + bytes.size() / 97) {
      Result<Value> r = type.decode(Bytes(bytes.data(), n), nullptr);
      if (!r.isOk()) {
        EXPECT_EQ(r.status().code(), StatusCode::kCorruptData) << type.name << " " << n;
      }
    }
  }
}

TEST(Inspector, ShowsEveryChannelAsJsonThroughTheFilesOwnSchemas) {
  const std::string path = tempPath("inspect.mcap");
  const IoSamples s = testing::makeIoSamples(2, 1'000'000);
  {
    Recorder rec;
    ASSERT_TRUE(rec.open(path).isOk());
    ASSERT_TRUE(testing::writeIoSamples(rec, s, 1'000'000).isOk());
    ASSERT_TRUE(rec.close().isOk());
  }
  McapReader reader;
  ASSERT_TRUE(reader.open(path).isOk());
  InspectOptions options;
  options.max_array = 8;
  options.head = 3;
  std::map<std::string, nlohmann::json> shown;
  auto it = reader.messages();
  while (it.next()) {
    const MessageView& m = it.message();
    auto inspector = MessageInspector::create(*m.channel, m.schema, options);
    ASSERT_TRUE(inspector.isOk()) << m.channel->topic;
    auto j = inspector->toJson(m.data);
    ASSERT_TRUE(j.isOk()) << m.channel->topic << ": " << j.status().toString();
    shown[m.channel->topic] = *j;
  }
  ASSERT_EQ(shown.size(), 26u);
  const auto& image = shown["/chaser/camera/left/image"];
  EXPECT_EQ(image["width"], s.image_mono.width);
  EXPECT_EQ(image["encoding"], "mono8");
  EXPECT_EQ(image["frame_id"], "camera_left_optical");
  EXPECT_EQ(image["data"]["$bytes"], s.image_mono.pixels.size());
  EXPECT_EQ(image["cdff_camera"]["distortion_model"], "plumb_bob");
  EXPECT_EQ(image["timestamp"]["seconds"], 1);
  const auto& matches = shown["/cdff/tracking/matches"];
  EXPECT_EQ(matches["query"]["$array"], s.matches.size());
  EXPECT_EQ(matches["query"]["head"][0], -1);  // negative int32 varints
  const auto& features = shown["/cdff/tracking/features"];
  EXPECT_EQ(features["descriptors"]["element"], "UINT8");  // enum names from the descriptor
  EXPECT_EQ(features["descriptors"]["distance"], "HAMMING");
  const auto& cloud = shown["/chaser/lidar/points"];
  EXPECT_EQ(cloud["fields"]["$array"], 9);
  EXPECT_EQ(cloud["fields"]["head"][0]["type"], "FLOAT32");
  const auto& imu = shown["/chaser/imu"];
  EXPECT_TRUE(imu["linear_acceleration_covariance"]["head"].is_array());
  EXPECT_EQ(shown["/cdff/pose_estimation/pose"]["cdff_child_frame_id"], "target");

  Channel opaque;
  opaque.topic = "/ros";
  opaque.message_encoding = "cdr";
  auto raw = MessageInspector::create(opaque, nullptr);
  ASSERT_TRUE(raw.isOk());
  const std::vector<std::uint8_t> bytes(10, 1);
  EXPECT_EQ((*raw->toJson(bytes))["$bytes"], 10);

  Schema broken{1, "foxglove.RawImage", "protobuf", {0x0A, 0xFF, 0x01}};
  Channel ch;
  ch.topic = "/bad";
  ch.message_encoding = "protobuf";
  EXPECT_FALSE(MessageInspector::create(ch, &broken).isOk());
}

TEST(Recorder, RefusesAnotherTypeOnAChannelAndNegativeStamps) {
  const std::string path = tempPath("refuse.mcap");
  Recorder rec;
  ASSERT_TRUE(rec.open(path).isOk());
  const IoSamples s = testing::makeIoSamples(0, 10);
  ASSERT_TRUE(rec.write("/x", s.transform).isOk());
  const Status st = rec.write("/x", s.imu);
  EXPECT_EQ(st.code(), StatusCode::kInvalidInput);
  EXPECT_NE(st.message().find("records Transform values"), std::string::npos) << st.message();
  Transform early = s.transform;
  early.stamp = -1;
  EXPECT_EQ(rec.write("/y", early).code(), StatusCode::kInvalidInput);
  Image bad = s.image_mono;
  bad.height += 1;  // the buffer no longer holds height * stride bytes
  const Status b = rec.write("/img", bad);
  EXPECT_EQ(b.code(), StatusCode::kInvalidInput);
  EXPECT_NE(b.message().find("/img"), std::string::npos) << b.message();
  EXPECT_FALSE(rec.writeEvent(0, "loud", "me", "x").isOk());
  ASSERT_TRUE(rec.close().isOk());
  Recorder closed;
  EXPECT_FALSE(closed.write("/x", s.transform).isOk());
}

TEST(Replay, MergesFilesInTimeOrderAndSeeksByTimeAndChannel) {
  const std::string a = tempPath("a.mcap"), b = tempPath("b.mcap");
  {
    Recorder ra, rb;
    McapWriterOptions o;
    o.chunk_size = 4000;
    ASSERT_TRUE(ra.open(a, o).isOk());
    ASSERT_TRUE(rb.open(b, o).isOk());
    for (int i = 0; i < 200; ++i) {
      const IoSamples s = testing::makeIoSamples(i, 0);
      ImuSample imu = s.imu;
      imu.stamp = 1000 + i * 1000;  // 1 kHz on file a
      ASSERT_TRUE(ra.write("/chaser/imu", imu).isOk());
      if (i % 10 == 0) {  // 100 Hz poses on file b, at the same instants as some IMU samples
        PoseWithCovariance p = s.pose;
        p.pose.stamp = imu.stamp;
        ASSERT_TRUE(rb.write("/truth/target_pose", p).isOk());
      }
    }
    ASSERT_TRUE(ra.close().isOk());
    ASSERT_TRUE(rb.close().isOk());
  }
  Replay replay;
  ASSERT_TRUE(replay.open({a, b}).isOk());
  EXPECT_EQ(replay.channels().size(), 2u);
  EXPECT_EQ(replay.channel("/chaser/imu")->message_count, 200u);
  EXPECT_EQ(replay.channel("/truth/target_pose")->type, TypeId::of<PoseWithCovariance>());
  EXPECT_EQ(replay.startTime(), 1000);
  EXPECT_EQ(replay.endTime(), 200'000);
  Timestamp last = -1;
  std::size_t n = 0;
  std::size_t last_file = 0;
  while (replay.next()) {
    const Timestamp t = replay.message().logTime();
    EXPECT_GE(t, last);
    if (t == last) {
      EXPECT_GE(replay.message().fileIndex(), last_file);  // ties: file order
    }
    last = t;
    last_file = replay.message().fileIndex();
    ++n;
  }
  EXPECT_EQ(n, 220u);
  EXPECT_TRUE(replay.status().isOk());

  ReplayOptions window;
  window.start = 50'000;
  window.end = 59'000;
  window.channels = {"/chaser/imu"};
  Replay part;
  ASSERT_TRUE(part.open({a, b}, window).isOk());
  n = 0;
  while (part.next()) {
    EXPECT_EQ(part.message().channel(), "/chaser/imu");
    EXPECT_GE(part.message().logTime(), 50'000);
    EXPECT_LE(part.message().logTime(), 59'000);
    ++n;
  }
  EXPECT_EQ(n, 10u);

  ReplayOptions unknown;
  unknown.channels = {"/chaser/imu_typo"};
  Replay bad;
  const Status st = bad.open({a, b}, unknown);
  EXPECT_EQ(st.code(), StatusCode::kNotFound);
  EXPECT_NE(st.message().find("/chaser/imu_typo"), std::string::npos);
  EXPECT_NE(st.message().find("/chaser/imu, /truth/target_pose"), std::string::npos)
      << st.message();
}

// A window of a recording keeps, on request, what was recorded once at its beginning (a sensor's
// mounting): first, at its own time, from the file that holds it.
TEST(Replay, AWindowKeepsTheStaticChannelsOnRequest) {
  const std::string a = tempPath("static_a.mcap"), b = tempPath("static_b.mcap");
  {
    Recorder ra, rb;
    ASSERT_TRUE(ra.open(a).isOk());
    ASSERT_TRUE(rb.open(b).isOk());
    const IoSamples s = testing::makeIoSamples(0, 0);
    Transform mounting = s.transform;
    mounting.stamp = 0;
    ASSERT_TRUE(rb.write("/chaser/tf/lidar", mounting).isOk());
    for (int i = 0; i < 100; ++i) {
      ImuSample imu = s.imu;
      imu.stamp = i * 1000;
      ASSERT_TRUE(ra.write("/chaser/imu", imu).isOk());
    }
    ASSERT_TRUE(ra.close().isOk());
    ASSERT_TRUE(rb.close().isOk());
  }
  const auto read = [&](bool keep_static) {
    ReplayOptions window;
    window.start = 50'000;
    window.keep_static = keep_static;
    Replay replay;
    EXPECT_TRUE(replay.open({a, b}, window).isOk());
    std::vector<std::pair<std::string, Timestamp>> out;
    while (replay.next()) {
      out.emplace_back(replay.message().channel(), replay.message().logTime());
      if (out.back().first == "/chaser/tf/lidar") EXPECT_EQ(replay.message().fileIndex(), 1u);
    }
    EXPECT_TRUE(replay.status().isOk());
    return out;
  };
  const auto plain = read(false), kept = read(true);
  ASSERT_EQ(plain.size(), 50u);  // 50 ms to 99 ms
  EXPECT_EQ(plain.front(), (std::pair<std::string, Timestamp>("/chaser/imu", 50'000)));
  ASSERT_EQ(kept.size(), 51u);
  EXPECT_EQ(kept.front(), (std::pair<std::string, Timestamp>("/chaser/tf/lidar", 0)));
  EXPECT_EQ(kept[1], plain.front());
}

TEST(Replay, DecodingAsTheWrongTypeIsRefused) {
  const std::string path = tempPath("wrong.mcap");
  {
    Recorder rec;
    ASSERT_TRUE(rec.open(path).isOk());
    ASSERT_TRUE(rec.write("/chaser/imu", testing::makeIoSamples(0, 5).imu).isOk());
    ASSERT_TRUE(rec.close().isOk());
  }
  Replay replay;
  ASSERT_TRUE(replay.open({path}).isOk());
  ASSERT_TRUE(replay.next());
  auto wrong = replay.message().decode<Image>();
  EXPECT_FALSE(wrong.isOk());
  EXPECT_NE(wrong.status().message().find("cannot decode it as Image"), std::string::npos)
      << wrong.status().message();
}

}  // namespace
}  // namespace cdff::io
