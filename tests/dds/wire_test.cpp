// CDFF values -> ROS 2 / CDFF wire samples -> CDFF values, without a network: every converted
// type is lossless (the decoded value's MCAP message equals the original's), except what a ROS 2
// type cannot hold, which each test below names. Malformed samples are errors that say what.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "cdff/dds/wire.hpp"
#include "samples.hpp"

namespace cdff::dds {
namespace {

constexpr Timestamp kStamp = 12'345'678;

std::vector<std::uint8_t> messageOf(const Value& v) {
  codec::Encoded e;
  const Status s = v.type().info().encode(v.raw(), kStamp, e);
  EXPECT_TRUE(s.isOk()) << s.message();
  return e.flatten();
}

// The value after encodeSample() and decodeSample(); `child_frame` is what a pose writer's user
// data carries.
Value roundTrip(const Value& value, const std::string& child_frame = "") {
  OutgoingSample sample;
  const Status encoded = encodeSample(value, kStamp, sample);
  EXPECT_TRUE(encoded.isOk()) << encoded.message();
  EXPECT_EQ(sample.wire(), wireTypeOf(value.type()));
  Result<std::vector<Decoded>> decoded =
      decodeSample(sample.wire(), sample.data(), {"/test", child_frame, TypeId()});
  EXPECT_TRUE(decoded.isOk()) << decoded.status().message();
  if (!decoded || decoded->size() != 1) return Value();
  return decoded->front().value;
}

TEST(DdsWire, RosTypesCarryTheirCdffTypesWithoutLoss) {
  const testing::IoSamples s = testing::makeIoSamples(2, kStamp);
  const std::vector<Value> values = {
      Value::of(s.image_bgr), Value::of(s.image_float), Value::of(s.camera), Value::of(s.cloud),
      Value::of(s.cloud_xyz), Value::of(s.transform),   Value::of(s.imu),    Value::of(s.pose)};
  for (const Value& v : values) {
    SCOPED_TRACE(std::string(v.type().name()));
    EXPECT_NE(wireTypeOf(v.type()), WireType::kRecord);
    const Value back = roundTrip(v, "target");
    ASSERT_TRUE(back);
    EXPECT_EQ(messageOf(back), messageOf(v));
  }
}

TEST(DdsWire, AnImageWithPaddedRowsAndACameraTravelsWithItsCameraInfo) {
  const testing::IoSamples s = testing::makeIoSamples(1, kStamp);
  ASSERT_TRUE(s.image_mono.camera);
  ASSERT_GT(s.image_mono.stride_bytes, static_cast<std::size_t>(s.image_mono.width));
  const Value back = roundTrip(Value::of(s.image_mono));
  ASSERT_TRUE(back);
  // The ROS 2 Image has no camera model: it travels on <dir>/camera_info (the subscriber puts
  // it back, tests/dds/transport_test.cpp).
  EXPECT_FALSE(back.get<Image>()->camera);
  OutgoingSample info;
  ASSERT_TRUE(encodeCameraInfo(*s.image_mono.camera, kStamp, "camera_left_optical", info));
  Result<CameraModel> camera =
      decodeCameraInfo(*static_cast<const sensor_msgs_msg_dds__CameraInfo_*>(info.data()));
  ASSERT_TRUE(camera) << camera.status().message();
  Image restored = *back.get<Image>();
  restored.camera = *camera;
  EXPECT_EQ(messageOf(Value::of(restored)), messageOf(Value::of(s.image_mono)));
  EXPECT_EQ(restored.stride_bytes, s.image_mono.stride_bytes);
}

TEST(DdsWire, OtherTypesTravelAsRecordsWithoutLoss) {
  const testing::IoSamples s = testing::makeIoSamples(3, kStamp);
  const std::vector<Value> values = {
      Value::of(s.state),    Value::of(s.depth_m),          Value::of(s.stereo),
      Value::of(s.mesh),     Value::of(s.features2d),       Value::of(s.matches),
      Value::of(s.corr2d3d), Value::of(s.wrench),           Value::of(s.joints),
      Value::of(s.record),   Value::of(TrackState::kLost),  Value::of(-2.5e-3),
      Value::of(true),       Value::of(std::string("text"))};
  for (const Value& v : values) {
    SCOPED_TRACE(std::string(v.type().name()));
    EXPECT_EQ(wireTypeOf(v.type()), WireType::kRecord);
    const Value back = roundTrip(v);
    ASSERT_TRUE(back);
    EXPECT_EQ(messageOf(back), messageOf(v));
  }
}

TEST(DdsWire, TheLossesAreThoseStated) {
  const testing::IoSamples s = testing::makeIoSamples(4, kStamp);
  // A pose from a writer without the CDFF's user data (a ROS 2 node) has no child frame.
  const Value pose = roundTrip(Value::of(s.pose), "");
  ASSERT_TRUE(pose);
  EXPECT_EQ(pose.get<PoseWithCovariance>()->pose.child_frame, "");
  EXPECT_EQ(pose.get<PoseWithCovariance>()->pose.parent_frame, s.pose.pose.parent_frame);
  // A point's padding float is not sent; it comes back as 1 (homogeneous w).
  PointCloud cloud = PointCloud::fromXyz({{1, 2, 3}, {4, 5, 6}}, "lidar", kStamp);
  std::vector<Point4f> points(cloud.points.begin(), cloud.points.end());
  points[1].pad = 7;
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  const Value back = roundTrip(Value::of(cloud));
  ASSERT_TRUE(back);
  EXPECT_EQ(back.get<PointCloud>()->points[1].pad, 1.0f);
  EXPECT_EQ(back.get<PointCloud>()->points[1].z, 6.0f);
}

TEST(DdsWire, TimesAreExactToTheMicrosecondBothWays) {
  for (Timestamp t : {Timestamp{0}, Timestamp{1}, Timestamp{-1}, Timestamp{-1'000'000},
                      Timestamp{1'234'567'890'123'456}}) {
    const builtin_interfaces_msg_dds__Time_ ros = toRosTime(t);
    EXPECT_LT(ros.nanosec, 1'000'000'000u) << t;
    EXPECT_EQ(fromRosTime(ros), t);
  }
  EXPECT_EQ(toRosTime(-1).sec, -1);
  EXPECT_EQ(toRosTime(-1).nanosec, 999'999'000u);
  // A ROS 2 stamp's nanoseconds below the microsecond are truncated.
  EXPECT_EQ(fromRosTime({3, 1'999}), 3'000'001);
}

TEST(DdsWire, TopicsAreChannelsUnderRos2sPrefix) {
  EXPECT_EQ(topicOfChannel("/chaser/camera/far/image"), "rt/chaser/camera/far/image");
  EXPECT_EQ(channelOfTopic("rt/cdff/events"), "/cdff/events");
  EXPECT_FALSE(channelOfTopic("DCPSPublication"));
  EXPECT_EQ(cameraInfoChannel("/chaser/camera/far/image"), "/chaser/camera/far/camera_info");
  EXPECT_EQ(wireInfo(WireType::kImage).type_name, "sensor_msgs::msg::dds_::Image_");
  EXPECT_EQ(std::string(wireInfo(WireType::kImage).descriptor->m_typename),
            "sensor_msgs::msg::dds_::Image_");
  EXPECT_EQ(std::string(wireInfo(WireType::kPoseWithCovarianceStamped).descriptor->m_typename),
            "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_");
  EXPECT_EQ(wireTypeNamed("tf2_msgs::msg::dds_::TFMessage_"), WireType::kTfMessage);
  EXPECT_FALSE(wireTypeNamed("std_msgs::msg::dds_::String_"));
}

// ---- malformed samples ----------------------------------------------------------------------

std::string errorOf(WireType wire, const void* sample, TypeId expected = TypeId()) {
  Result<std::vector<Decoded>> decoded = decodeSample(wire, sample, {"/test", "", expected});
  EXPECT_FALSE(decoded.isOk());
  return decoded ? "" : decoded.status().message();
}

TEST(DdsWire, AnImageWhoseDataDoesNotMatchItsSizeIsRejected) {
  std::vector<std::uint8_t> data(100);
  sensor_msgs_msg_dds__Image_ msg{};
  msg.header.frame_id = const_cast<char*>("camera");
  msg.encoding = const_cast<char*>("mono8");
  msg.width = 16;
  msg.height = 8;
  msg.step = 16;
  msg.data._buffer = data.data();
  msg.data._length = 100;
  EXPECT_NE(errorOf(WireType::kImage, &msg)
                .find("image data holds 100 bytes; expected step * "
                      "height = 16 * 8 = 128"),
            std::string::npos);
  msg.data._length = 128;
  data.resize(128);
  msg.data._buffer = data.data();
  msg.encoding = const_cast<char*>("yuv422");
  EXPECT_NE(errorOf(WireType::kImage, &msg).find("image encoding 'yuv422'"), std::string::npos);
  msg.encoding = const_cast<char*>("mono8");
  msg.step = 8;
  msg.height = 16;
  EXPECT_NE(errorOf(WireType::kImage, &msg).find("stride is 8 bytes; expected >= 16"),
            std::string::npos);
}

TEST(DdsWire, ANonFinitePoseIsRejected) {
  OutgoingSample sample;
  const testing::IoSamples s = testing::makeIoSamples(1, kStamp);
  ASSERT_TRUE(encodeSample(Value::of(s.pose), kStamp, sample));
  auto msg = *static_cast<const geometry_msgs_msg_dds__PoseWithCovarianceStamped_*>(sample.data());
  msg.pose.pose.position.y = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(errorOf(WireType::kPoseWithCovarianceStamped, &msg).find("non-finite entry (nan)"),
            std::string::npos);
  // The publisher refuses one too.
  PoseWithCovariance bad = s.pose;
  bad.covariance(2, 2) = -1;
  EXPECT_FALSE(encodeSample(Value::of(bad), kStamp, sample).isOk());
}

TEST(DdsWire, APointCloudWithoutZOrWithATruncatedBufferIsRejected) {
  OutgoingSample sample;
  const testing::IoSamples s = testing::makeIoSamples(1, kStamp);
  ASSERT_TRUE(encodeSample(Value::of(s.cloud_xyz), kStamp, sample));
  auto msg = *static_cast<const sensor_msgs_msg_dds__PointCloud2_*>(sample.data());
  msg.data._length -= 1;
  EXPECT_NE(errorOf(WireType::kPointCloud2, &msg).find("point cloud data holds"),
            std::string::npos);
  msg.data._length += 1;
  msg.fields._length = 2;  // x, y
  EXPECT_NE(errorOf(WireType::kPointCloud2, &msg).find("no FLOAT32 field 'z'"), std::string::npos);
}

TEST(DdsWire, ARecordOfAnotherOrAnUnknownTypeIsRejected) {
  OutgoingSample sample;
  ASSERT_TRUE(encodeSample(Value::of(2.5), kStamp, sample));
  const void* record = sample.data();
  EXPECT_NE(errorOf(WireType::kRecord, record, TypeId::of<int>())
                .find("record of type 'Double' on a channel of Int"),
            std::string::npos);
  auto msg = *static_cast<const cdff_msgs_msg_dds__Record_*>(record);
  msg.type_name = const_cast<char*>("Doubel");
  EXPECT_NE(errorOf(WireType::kRecord, &msg).find("record of type 'Doubel'"), std::string::npos);
  msg.type_name = const_cast<char*>("Double");
  msg.data._length = 1;
  EXPECT_FALSE(errorOf(WireType::kRecord, &msg).empty());
}

// --encoding asn1-uper: the types with an ESROCOS ASN.1 type travel as Records of their uPER
// bytes, named by the ASN.1 type; each comes back as it left (an image's rows packed, its camera
// inside it, a pose's child frame inside it); the others travel as before.
TEST(DdsWire, Asn1UperRecordsCarryTheTypesWithAnAsn1TypeWithoutLoss) {
  const testing::IoSamples s = testing::makeIoSamples(2, kStamp);
  const std::vector<std::pair<Value, std::string>> values = {
      {Value::of(s.image_bgr), "Image8UC3"},      {Value::of(s.image_float), "Image32FC1"},
      {Value::of(s.camera), "CalibrationMatrix"}, {Value::of(s.cloud), "PointCloud"},
      {Value::of(s.transform), "Transform"},      {Value::of(s.pose), "TransformWithCovariance"},
      {Value::of(s.state), "RigidBodyState"}};
  for (const auto& [v, asn1_name] : values) {
    SCOPED_TRACE(asn1_name);
    EXPECT_EQ(wireTypeOf(v.type(), Encoding::kAsn1Uper), WireType::kRecord);
    OutgoingSample sample;
    ASSERT_TRUE(encodeSample(v, kStamp, sample, Encoding::kAsn1Uper).isOk());
    const auto& record = *static_cast<const cdff_msgs_msg_dds__Record_*>(sample.data());
    EXPECT_STREQ(record.type_name, asn1_name.c_str());
    EXPECT_STREQ(record.encoding, "asn1-uper");
    Result<std::vector<Decoded>> decoded =
        decodeSample(WireType::kRecord, sample.data(), {"/test", "", v.type()});
    ASSERT_TRUE(decoded.isOk()) << decoded.status().message();
    ASSERT_EQ(decoded->size(), 1u);
    EXPECT_EQ(decoded->front().stamp, kStamp);
    EXPECT_EQ(messageOf(decoded->front().value), messageOf(v));
  }
  // No ASN.1 type: as with ROS 2 messages.
  EXPECT_EQ(wireTypeOf(TypeId::of<ImuSample>(), Encoding::kAsn1Uper), WireType::kImu);
  EXPECT_EQ(wireTypeOf(TypeId::of<int>(), Encoding::kAsn1Uper), WireType::kRecord);
  OutgoingSample sample;
  ASSERT_TRUE(encodeSample(Value::of(2), kStamp, sample, Encoding::kAsn1Uper).isOk());
  EXPECT_STREQ(static_cast<const cdff_msgs_msg_dds__Record_*>(sample.data())->encoding, "json");
  EXPECT_TRUE(parseEncoding("asn1-uper").isOk());
  EXPECT_NE(parseEncoding("uper").status().message().find(
                "encoding 'uper': expected ros2 (ROS 2 messages, else the recording codec's "
                "bytes) or asn1-uper"),
            std::string::npos);
}

// A uPER Record that is truncated, names an unknown ASN.1 type or another type than the
// channel's is rejected with what, which value and what was expected; a Gray16 image cannot be
// published in uPER.
TEST(DdsWire, AMalformedAsn1UperRecordIsRejected) {
  const testing::IoSamples s = testing::makeIoSamples(2, kStamp);
  OutgoingSample sample;
  ASSERT_TRUE(encodeSample(Value::of(s.pose), kStamp, sample, Encoding::kAsn1Uper).isOk());
  auto msg = *static_cast<const cdff_msgs_msg_dds__Record_*>(sample.data());
  const std::uint32_t size = msg.data._length;
  EXPECT_NE(errorOf(WireType::kRecord, &msg, TypeId::of<Transform>())
                .find("record of ASN.1 type 'TransformWithCovariance' (a PoseWithCovariance) on "
                      "a channel of Transform; expected a Transform"),
            std::string::npos);
  for (std::uint32_t cut : {0u, 1u, size / 2, size - 1}) {
    msg.data._length = cut;
    EXPECT_NE(errorOf(WireType::kRecord, &msg)
                  .find(fmt::format("record of ASN.1 type 'TransformWithCovariance' (asn1-uper): "
                                    "uPER TransformWithCovariance of {} bytes:",
                                    cut)),
              std::string::npos)
        << cut;
  }
  msg.data._length = size;
  msg.type_name = const_cast<char*>("Image16UC1");
  EXPECT_NE(errorOf(WireType::kRecord, &msg)
                .find("record of ASN.1 type 'Image16UC1' (asn1-uper): expected one of Time, "),
            std::string::npos)
      << errorOf(WireType::kRecord, &msg);
  const Status gray16 =
      encodeSample(Value::of(s.depth_mm.image), kStamp, sample, Encoding::kAsn1Uper);
  EXPECT_NE(gray16.message().find("has no ASN.1 type; expected mono8 (Image8UC1), bgr8 "
                                  "(Image8UC3) or 32FC1 (Image32FC1)"),
            std::string::npos)
      << gray16.message();
}

}  // namespace
}  // namespace cdff::dds
