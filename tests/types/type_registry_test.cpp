// Every type of the registry round-trips through a DFN port, an MCAP recording and the Data
// Product Manager's files. Each registered type must have a sample value below: a new type fails
// `EveryRegisteredTypeHasASample` until it has one, and is then covered by every test here.
//
// Equality is tested on the encoded MCAP message: a decoded value whose encoding equals the
// original's has every field the codec writes (tests/io/codec_test.cpp checks field by field
// that the codec writes every field of the older types).
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cdff/dfn/port.hpp"
#include "cdff/dfpc/data_product_manager.hpp"
#include "cdff/io/recorder.hpp"
#include "cdff/io/replay.hpp"
#include "cdff/types/codec/codec.hpp"
#include "samples.hpp"

namespace cdff {
namespace {

namespace fs = std::filesystem;
constexpr Timestamp kStamp = 1'250'000;

fs::path tempDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("cdff_type_registry_test_" + std::to_string(::getpid())) / name;
  fs::create_directories(dir);
  return dir;
}

PolygonModel polygonModel() {
  PolygonModel m;
  m.frame_id = "target_body";
  m.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 1.25}, {0.5, 0.5, -0.5}};
  m.faces = {{{0, 1, 2, 3}, "base"}, {{0, 1, 4}, "side"}};
  m.lines = {{4, 5, "antenna"}};
  m.cylinders = {{0, 4, 0.05, "strut"}};
  m.circles = {{5, 0, 1, 0.3, "dish"}};
  return m;
}

ModelContours modelContours() {
  ModelContours c;
  c.stamp = kStamp;
  c.camera.width = 64;
  c.camera.height = 48;
  c.camera.fx = c.camera.fy = 80.5;
  c.camera.cx = 31.5;
  c.camera.cy = 23.5;
  c.camera_T_model = Transform::identity("camera_optical", "target_body", kStamp);
  c.camera_T_model.translation = Eigen::Vector3d(0.1, -0.2, 5.0);
  c.camera_T_model.rotation = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized();
  c.camera_T_reference = Transform::identity("camera_optical", "camera_optical", kStamp);
  c.segments = {{{0, 0, 0}, {1, 0, 0}, 3, ContourKind::kSilhouette},
                {{1, 0, 0}, {1, 1, 0}, 4, ContourKind::kLine}};
  VisibleFace f;
  f.face = 1;
  f.normal = Eigen::Vector3d(0, 0, -1);
  f.offset = 0.25;
  f.outline = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}};
  c.faces = {f};
  return c;
}

ContourSamples contourSamples() {
  ContourSamples s;
  s.contours = std::make_shared<const ModelContours>(modelContours());
  ContourSample a;
  a.point = {0.5, 0, 0};
  a.pixel = {30.25, 20.5};
  a.normal = {0, 1};
  a.segment = 0;
  a.first_candidate = 0;
  a.candidate_count = 2;
  ContourSample b = a;
  b.segment = 1;
  b.first_candidate = 2;
  b.candidate_count = 0;
  s.samples = {a, b};
  s.candidates = {{-1.5f, 40.0f}, {2.25f, 12.5f}};
  s.matched = true;
  return s;
}

LidarInfo lidarInfo() {
  LidarInfo l;
  l.stamp = kStamp;
  l.frame_id = "lidar";
  l.elevations = {-0.2617993877991494, 0.017453292519943295, -0.22689280275926285,
                  0.2617993877991494};
  l.rotation_rate = 10.0;
  l.min_range = 0.5;
  l.max_range = 100.0;
  l.range_noise = 0.03;
  return l;
}

Detections detections() {
  Detections d;
  d.stamp = kStamp;
  d.frame_id = "camera_optical";
  Detection best;
  best.pose = Transform::identity("camera_optical", "target_body", kStamp);
  best.pose.translation = Eigen::Vector3d(0.12, -0.05, 4.75);
  best.pose.rotation = Eigen::Quaterniond(0.8, -0.1, 0.3, 0.2).normalized();
  best.similarity = 0.9375;
  best.depth_agreement = 0.875;
  best.template_id = "range_3/1234";
  best.x = 212;
  best.y = 148;
  best.width = 96;
  best.height = 80;
  Detection second = best;
  second.pose.translation = Eigen::Vector3d(-0.4, 0.25, 6.5);
  second.pose.rotation = Eigen::Quaterniond(0.2, 0.7, -0.1, 0.6).normalized();
  second.similarity = 0.8125;
  second.depth_agreement = std::numeric_limits<double>::quiet_NaN();  // no depth checked
  second.template_id = "range_4/17";
  second.x = 0;
  second.y = 301;
  second.width = 64;
  second.height = 72;
  d.detections = {best, second};
  return d;
}

ImageRegion imageRegion() {
  ImageRegion r = ImageRegion::box(503.25, 498.5, 21, 17);
  r.stamp = kStamp;
  r.frame_id = "camera_far_optical";
  r.homography(0, 0) = 1.25;
  r.homography(1, 1) = 1.25;
  r.homography(2, 0) = 1e-5;  // a perspective term: every element travels
  r.score = 0.9375;
  r.covariance << 0.0625, 0.015625, 0.015625, 0.09375;
  r.source = "match";
  return r;
}

Bearing bearing() {
  Bearing b;
  b.stamp = kStamp;
  b.frame_id = "servicer";
  b.direction = Eigen::Vector3d(1.0, 0.02, -0.01).normalized();
  b.covariance = Eigen::Vector3d(0.0, 1e-8, 2e-8).asDiagonal();
  b.range = 1234.5;
  b.range_variance = 25.0;  // range rate unknown: NaN
  b.designation = "automatic";
  return b;
}

/// One sample value of every registered type, keyed by the type's name.
std::map<std::string, Value> samples() {
  const testing::IoSamples s = testing::makeIoSamples(3, kStamp);
  std::vector<Value> values = {Value::of(s.image_mono),
                               Value::of(s.depth_m),
                               Value::of(s.stereo),
                               Value::of(s.compressed),
                               Value::of(s.camera),
                               Value::of(s.cloud),
                               Value::of(s.transform),
                               Value::of(s.pose),
                               Value::of(s.state),
                               Value::of(s.trajectory),
                               Value::of(s.mesh),
                               Value::of(polygonModel()),
                               Value::of(modelContours()),
                               Value::of(contourSamples()),
                               Value::of(s.features2d),
                               Value::of(s.features3d),
                               Value::of(s.matches),
                               Value::of(s.corr2d),
                               Value::of(s.corr3d),
                               Value::of(s.corr2d3d),
                               Value::of(s.imu),
                               Value::of(s.wrench),
                               Value::of(s.joints),
                               Value::of(lidarInfo()),
                               Value::of(detections()),
                               Value::of(imageRegion()),
                               Value::of(bearing()),
                               Value::of(s.record),
                               Value::of(TrackState::kDegraded),
                               Value::of(-2.5e-3),
                               Value::of(true),
                               Value::of(-42),
                               Value::of(Timestamp{1'234'567'890'123}),
                               Value::of(std::string("a string, \"quoted\""))};
  std::map<std::string, Value> out;
  for (Value& v : values) out.emplace(std::string(v.type().name()), std::move(v));
  return out;
}

/// The value's MCAP message, the form compared before and after a round trip.
std::vector<std::uint8_t> messageOf(const Value& v) {
  codec::Encoded e;
  const Status st = v.type().info().encode(v.raw(), kStamp, e);
  EXPECT_TRUE(st.isOk()) << v.type().name() << ": " << st.message();
  return e.flatten();
}

/// Equal values: the same MCAP message, except that a PoseArray's rotation matrices travel as
/// quaternions (foxglove.PosesInFrame), a conversion exact to rounding (1e-15).
void expectSameValue(const Value& decoded, const Value& original) {
  ASSERT_EQ(decoded.type(), original.type());
  if (const PoseArray* a = decoded.get<PoseArray>()) {
    const PoseArray& b = *original.get<PoseArray>();
    EXPECT_EQ(a->stamp, b.stamp);
    EXPECT_EQ(a->frame_id, b.frame_id);
    ASSERT_EQ(a->poses.size(), b.poses.size());
    for (std::size_t i = 0; i < a->poses.size(); ++i)
      EXPECT_TRUE(a->poses[i].matrix().isApprox(b.poses[i].matrix(), 1e-14)) << "pose " << i;
    return;
  }
  EXPECT_EQ(messageOf(decoded), messageOf(original));
}

TEST(TypeRegistry, EveryRegisteredTypeHasASample) {
  const std::map<std::string, Value> values = samples();
  for (TypeId t : allTypes())
    EXPECT_TRUE(values.count(std::string(t.name())))
        << t.name() << " has no sample value in " << __FILE__ << "; add one to samples()";
  EXPECT_EQ(values.size(), allTypes().size());
}

TEST(TypeRegistry, NamesAndSchemasFindTheirEntries) {
  std::set<std::string_view> names;
  for (TypeId t : allTypes()) {
    const TypeInfo& info = t.info();
    EXPECT_TRUE(names.insert(info.name).second) << info.name << " is registered twice";
    EXPECT_EQ(findType(info.name), t);
    // A schema shared by two types finds the first; the second is told apart by the CDFF
    // metadata that the recorder writes (docs/recording.md).
    const TypeId by_schema = findTypeBySchema(info.schema_name, info.messageEncoding());
    ASSERT_TRUE(by_schema.valid()) << info.name;
    EXPECT_EQ(by_schema.info().schema_name, info.schema_name);
    EXPECT_FALSE(info.schemaData().empty()) << info.name;
  }
  EXPECT_FALSE(findType("PoseWithCovarience").valid());
  EXPECT_FALSE(findTypeBySchema("foxglove.RawImage", "json").valid());
}

TEST(TypeRegistry, EveryTypePassesThroughPortsWithoutACopy) {
  for (const auto& [name, value] : samples()) {
    SCOPED_TRACE(name);
    dfn::InputPortBase input("in", value.type(), false);
    ASSERT_TRUE(input.setAny(value).isOk());
    EXPECT_TRUE(input.isFresh());
    EXPECT_EQ(input.anyValue().raw(), value.raw());
    EXPECT_EQ(input.anyValue().type(), value.type());
    // A port of another type refuses it, naming both types.
    const TypeId other =
        value.type() == TypeId::of<double>() ? TypeId::of<int>() : TypeId::of<double>();
    dfn::InputPortBase wrong("wrong", other, false);
    const Status refused = wrong.setAny(value);
    EXPECT_EQ(refused.code(), StatusCode::kInvalidInput);
    EXPECT_NE(refused.message().find(name), std::string::npos) << refused.message();
  }
}

TEST(TypeRegistry, EveryTypeRoundTripsThroughAnMcapRecording) {
  const std::map<std::string, Value> values = samples();
  const std::string path = (tempDir("mcap") / "all_types.mcap").string();
  {
    io::Recorder recorder;
    ASSERT_TRUE(recorder.open(path).isOk());
    for (const auto& [name, value] : values)
      ASSERT_TRUE(recorder.write("/types/" + name, value, kStamp).isOk()) << name;
    ASSERT_TRUE(recorder.close().isOk());
  }
  io::Replay replay;
  ASSERT_TRUE(replay.open({path}).isOk());
  std::set<std::string> seen;
  while (replay.next()) {
    const io::ReplayMessage& m = replay.message();
    const std::string name = m.channel().substr(std::string("/types/").size());
    SCOPED_TRACE(name);
    ASSERT_TRUE(values.count(name));
    const Value& original = values.at(name);
    EXPECT_EQ(m.type(), original.type());
    Result<Value> decoded = m.decode();
    ASSERT_TRUE(decoded.isOk()) << decoded.status().message();
    expectSameValue(*decoded, original);
    seen.insert(name);
  }
  EXPECT_TRUE(replay.status().isOk()) << replay.status().message();
  EXPECT_EQ(seen.size(), values.size());
}

TEST(TypeRegistry, EveryTypeRoundTripsThroughProductFiles) {
  const std::map<std::string, Value> values = samples();
  const std::string dir = tempDir("products").string();
  {
    dfpc::DataProductManager products;
    for (const auto& [name, value] : values)
      ASSERT_TRUE(products.publish(name, kStamp, value).isOk()) << name;
    const Status saved = products.save(dir);
    ASSERT_TRUE(saved.isOk()) << saved.message();
  }
  dfpc::DataProductManager restored;
  const Status st = restored.restore(dir);
  ASSERT_TRUE(st.isOk()) << st.message();
  for (const auto& [name, value] : values) {
    SCOPED_TRACE(name);
    Result<dfpc::Product> p = restored.latest(name);
    ASSERT_TRUE(p.isOk()) << p.status().message();
    EXPECT_EQ(p->stamp, kStamp);
    expectSameValue(p->value, value);
  }
}

TEST(TypeRegistry, TruncatedMessagesOfEveryTypeAreCorruptDataNeverACrash) {
  for (const auto& [name, value] : samples()) {
    SCOPED_TRACE(name);
    const std::vector<std::uint8_t> bytes = messageOf(value);
    const TypeInfo& type = value.type().info();
    for (std::size_t n = 0; n < bytes.size(); n += 1 + bytes.size() / 61) {
      Result<Value> r = type.decode(Bytes(bytes.data(), n), nullptr);
      if (!r.isOk()) {
        EXPECT_EQ(r.status().code(), StatusCode::kCorruptData) << n;
      }
    }
  }
}

TEST(TypeRegistry, TrackStatesHaveOneStringForm) {
  for (TrackState s : allTrackStates()) {
    EXPECT_EQ(parseTrackState(toString(s)), s);
    nlohmann::json j = codec::toJson(s);
    TrackState back = TrackState::kUninitialised;
    ASSERT_TRUE(codec::fromJson(j, back).isOk());
    EXPECT_EQ(back, s);
  }
  EXPECT_FALSE(parseTrackState("tracking").has_value());
  EXPECT_FALSE(parseTrackState("NEVER").has_value());
  TrackState out;
  const Status bad = codec::fromJson(nlohmann::json("NEVER"), out);
  EXPECT_FALSE(bad.isOk());
  EXPECT_NE(bad.message().find("NEVER"), std::string::npos) << bad.message();
  EXPECT_NE(bad.message().find("LOST"), std::string::npos) << bad.message();
  EXPECT_TRUE(isTracked(TrackState::kTracking));
  EXPECT_TRUE(isTracked(TrackState::kDegraded));
  EXPECT_FALSE(isTracked(TrackState::kAcquiring));
  EXPECT_FALSE(isTracked(TrackState::kLost));
  EXPECT_FALSE(isTracked(TrackState::kUninitialised));
}

}  // namespace
}  // namespace cdff
