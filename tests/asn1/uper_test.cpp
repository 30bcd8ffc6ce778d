// CDFF values -> uPER bytes of the ESROCOS-style ASN.1 types -> CDFF values: every type is
// lossless (the decoded value's MCAP message equals the original's) except what docs/asn1.md
// names, asserted here; the encoded sizes; values outside the ASN.1 constraints are encode
// errors that name the field, the value and the bound.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "cdff/asn1/uper.hpp"
#include "samples.hpp"

namespace cdff::asn1 {
namespace {

constexpr Timestamp kStamp = 1'700'000'123'456'789;

std::vector<std::uint8_t> messageOf(const Value& v) {
  codec::Encoded e;
  const Status s = v.type().info().encode(v.raw(), kStamp, e);
  EXPECT_TRUE(s.isOk()) << s.message();
  return e.flatten();
}

// encode() then decode() as the value's ASN.1 type; also returns the bytes.
Value roundTrip(const Value& value, std::vector<std::uint8_t>* bytes = nullptr) {
  Result<Asn1Type> type = asn1TypeOf(value);
  EXPECT_TRUE(type.isOk()) << type.status().message();
  if (!type) return Value();
  Result<std::vector<std::uint8_t>> encoded = encode(value);
  EXPECT_TRUE(encoded.isOk()) << encoded.status().message();
  if (!encoded) return Value();
  Result<Value> decoded = decode(*type, *encoded);
  EXPECT_TRUE(decoded.isOk()) << decoded.status().message();
  if (bytes) *bytes = *encoded;
  return decoded ? *decoded : Value();
}

Bearing makeBearing(bool with_range) {
  Bearing b;
  b.stamp = kStamp;
  b.frame_id = "chaser";
  b.direction = Eigen::Vector3d(0.9, -0.3, 0.1).normalized();
  Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - b.direction * b.direction.transpose();
  b.covariance = p * 1e-8 * p.transpose();
  if (with_range) {
    b.range = 1834.25;
    b.range_variance = 12.5;
    b.range_rate = -0.125;
    b.range_rate_variance = 1e-4;
  }
  b.designation = "automatic";
  return b;
}

TEST(Asn1Uper, EveryTypeRoundTripsWithoutLoss) {
  const testing::IoSamples s = testing::makeIoSamples(3, kStamp);
  const std::vector<Value> values = {Value::of(s.transform),       Value::of(s.pose),
                                     Value::of(s.state),           Value::of(s.camera),
                                     Value::of(s.image_bgr),       Value::of(s.image_float),
                                     Value::of(s.cloud),           Value::of(s.cloud_xyz),
                                     Value::of(makeBearing(true)), Value::of(makeBearing(false)),
                                     Value::of<Timestamp>(kStamp)};
  for (const Value& v : values) {
    SCOPED_TRACE(std::string(v.type().name()));
    const Value back = roundTrip(v);
    ASSERT_TRUE(back);
    EXPECT_EQ(back.type(), v.type());
    EXPECT_EQ(messageOf(back), messageOf(v));
  }
  // The NaNs of an unknown range are absent fields, NaN again on the way back.
  const Value unknown = roundTrip(Value::of(makeBearing(false)));
  ASSERT_TRUE(unknown);
  EXPECT_TRUE(std::isnan(unknown.get<Bearing>()->range));
  EXPECT_TRUE(std::isnan(unknown.get<Bearing>()->range_rate_variance));
}

TEST(Asn1Uper, EveryCameraModelAndExtremeTimesRoundTrip) {
  CameraModel c = testing::makeIoSamples(1, kStamp).camera;
  for (auto [model, coefficients] :
       {std::pair{DistortionModel::kNone, std::vector<double>{}},
        {DistortionModel::kRadialTangential, {0.1, -0.2, 1e-3, 2e-4}},
        {DistortionModel::kRadialTangential, {0.1, -0.2, 1e-3, 2e-4, 0.3, 1, 2, 3}},
        {DistortionModel::kEquidistant, {0.01, -0.002, 3e-4, -4e-5}}}) {
    c.distortion_model = model;
    c.distortion = coefficients;
    const Value back = roundTrip(Value::of(c));
    ASSERT_TRUE(back);
    EXPECT_EQ(messageOf(back), messageOf(Value::of(c)));
  }
  for (Timestamp t : {std::numeric_limits<Timestamp>::min(), Timestamp{-1}, Timestamp{0},
                      std::numeric_limits<Timestamp>::max()}) {
    const Value back = roundTrip(Value::of<Timestamp>(t));
    ASSERT_TRUE(back);
    EXPECT_EQ(*back.get<Timestamp>(), t);
  }
}

// Rows are packed in the ASN.1 image: a padded image comes back with the same pixels and its
// camera, its stride the row's width (the one loss, docs/asn1.md).
TEST(Asn1Uper, APaddedImageComesBackPackedWithItsPixelsAndCamera) {
  const testing::IoSamples s = testing::makeIoSamples(2, kStamp);
  const Image& in = s.image_mono;
  ASSERT_GT(in.stride_bytes, static_cast<std::size_t>(in.width));
  const Value back = roundTrip(Value::of(in));
  ASSERT_TRUE(back);
  const Image& out = *back.get<Image>();
  EXPECT_EQ(out.stride_bytes, static_cast<std::size_t>(in.width));
  EXPECT_EQ(out.width, in.width);
  EXPECT_EQ(out.height, in.height);
  EXPECT_EQ(out.stamp, in.stamp);
  EXPECT_EQ(out.frame_id, in.frame_id);
  for (int y = 0; y < in.height; ++y)
    ASSERT_EQ(std::memcmp(out.row(y), in.row(y), static_cast<std::size_t>(in.width)), 0) << y;
  ASSERT_TRUE(out.camera);
  EXPECT_EQ(messageOf(Value::of(*out.camera)), messageOf(Value::of(*in.camera)));
}

// A length that is a multiple of 16K items is fragmented to its end (X.691 §11.9.3.8): the
// last fragment is followed by a zero length, which asn1c 0.9.28's encoders omitted
// (src/cdff/asn1/fix_fragments.cmake). Images of 128x128, 256x256 and 512x256 mono8 pixels and
// 16K and 80K-point clouds (5 fragments: 4 in one length, then 1) round-trip; the lengths
// beside them too.
TEST(Asn1Uper, LengthsThatAreMultiplesOf16KRoundTrip) {
  for (auto [width, height] : {std::pair{128, 128}, {256, 256}, {512, 256}, {257, 256}}) {
    SCOPED_TRACE(fmt::format("{}x{}", width, height));
    std::vector<std::uint8_t> pixels(static_cast<std::size_t>(width * height));
    for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<std::uint8_t>(i * 7);
    Result<Image> image = Image::fromBytes(std::move(pixels), width, height, PixelFormat::kGray8);
    ASSERT_TRUE(image.isOk());
    image->stamp = kStamp;
    image->frame_id = "camera";
    const Value back = roundTrip(Value::of(*image));
    ASSERT_TRUE(back);
    EXPECT_EQ(messageOf(back), messageOf(Value::of(*image)));
  }
  for (std::size_t n : {16384u, 16385u, 81920u}) {
    SCOPED_TRACE(n);
    std::vector<Eigen::Vector3f> xyz(n);
    for (std::size_t i = 0; i < n; ++i) xyz[i] = {0.001f * i, 1.0f, -2.0f};
    PointCloud cloud = PointCloud::fromXyz(xyz, "lidar", kStamp);
    cloud.intensity = Buffer<float>::fromVector(std::vector<float>(n, 0.5f));
    const Value back = roundTrip(Value::of(cloud));
    ASSERT_TRUE(back);
    EXPECT_EQ(messageOf(back), messageOf(Value::of(cloud)));
  }
}

TEST(Asn1Uper, PointsAndPosesRoundTrip) {
  const Eigen::Vector3d p(1.5, -2.25e-7, 3e12);
  std::vector<std::uint8_t> bytes;
  ASSERT_TRUE(encodePoint(p, bytes).isOk());
  Result<Eigen::Vector3d> back = decodePoint(bytes);
  ASSERT_TRUE(back.isOk()) << back.status().message();
  EXPECT_EQ(*back, p);

  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = expSO3({0.3, -0.2, 1.1}).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(10, -20, 0.5);
  ASSERT_TRUE(encodePose(pose, bytes).isOk());
  Result<Eigen::Isometry3d> pose_back = decodePose(bytes);
  ASSERT_TRUE(pose_back.isOk()) << pose_back.status().message();
  // A rotation matrix travels as its quaternion: equal within rounding, not bit for bit.
  EXPECT_EQ(pose_back->translation(), pose.translation());
  EXPECT_LT((pose_back->linear() - pose.linear()).cwiseAbs().maxCoeff(), 1e-15);
}

// The uPER sizes: a double is 10 bytes at most (a length, a header, an exponent, 7 mantissa
// bytes), fewer for a short mantissa; an image is its pixels and a byte per 64K of them.
TEST(Asn1Uper, EncodedSizesAreThePayloadAndAFewBytes) {
  const testing::IoSamples s = testing::makeIoSamples(1, kStamp, /*small=*/false);
  std::vector<std::uint8_t> bytes;
  ASSERT_TRUE(roundTrip(Value::of<Timestamp>(0), &bytes));
  EXPECT_EQ(bytes.size(), 2u);  // a length byte and one value byte
  ASSERT_TRUE(roundTrip(Value::of(s.image_bgr), &bytes));
  const std::size_t pixels = 1624u * 1234u * 3u;
  EXPECT_GT(bytes.size(), pixels);
  // A length byte per 64K fragment of the pixels, the last one's length, the header fields.
  EXPECT_LT(bytes.size(), pixels + pixels / 65536 + 64);
  ASSERT_TRUE(roundTrip(Value::of(s.pose), &bytes));
  EXPECT_LE(bytes.size(), 2u + 20u + 6u + 7u * 10u + 36u * 10u + 8u);
  const Value mono = roundTrip(Value::of(s.image_mono), &bytes);
  ASSERT_TRUE(mono);
  EXPECT_EQ(mono.get<Image>()->pixels.size(), 1624u * 1234u);
}

void expectError(const Status& s, std::initializer_list<std::string_view> parts) {
  ASSERT_FALSE(s.isOk());
  for (std::string_view part : parts)
    EXPECT_NE(s.message().find(part), std::string::npos) << s.message() << "\nlacks: " << part;
}

TEST(Asn1Uper, AnImageOverItsBoundIsAnEncodeErrorThatNamesTheBound) {
  std::vector<std::uint8_t> out;
  Image big =
      Image::fromBytes(std::vector<std::uint8_t>(2049u * 2048u), 2049, 2048, PixelFormat::kGray8)
          .value();
  expectError(encode(Value::of(big), out), {"Image8UC1.data", "2049x2048", "4196352", "4194304"});
  Image wide =
      Image::fromBytes(std::vector<std::uint8_t>(5000u * 2u * 4u), 5000, 2, PixelFormat::kFloat32)
          .value();
  expectError(encode(Value::of(wide), out), {"Image32FC1.width", "5000", "1..4096"});
  Image deep =
      Image::fromBytes(std::vector<std::uint8_t>(8u * 2u), 4, 2, PixelFormat::kGray16).value();
  expectError(encode(Value::of(deep), out), {"16UC1", "no ASN.1 type"});
  expectError(asn1TypeOf(Value::of(Wrench{})).status(), {"Wrench", "no ASN.1 type"});
}

TEST(Asn1Uper, NonFiniteNumbersLongStringsAndWrongSizesAreEncodeErrors) {
  const testing::IoSamples s = testing::makeIoSamples(1, kStamp);
  std::vector<std::uint8_t> out;
  PoseWithCovariance pose = s.pose;
  pose.covariance(1, 2) = std::numeric_limits<double>::quiet_NaN();
  expectError(encode(Value::of(pose), out), {"TransformWithCovariance.cov[13]", "nan", "finite"});
  Transform t = s.transform;
  t.parent_frame = std::string(300, 'a');
  expectError(encode(Value::of(t), out), {"Transform.parent-frame", "300 bytes", "255"});
  t = s.transform;
  t.rotation.coeffs() *= 2;
  expectError(encode(Value::of(t), out), {"Transform.pose.orientation", "has norm 1.99", "unit"});
  RigidBodyState state = s.state;
  state.twist.angular.y() = std::numeric_limits<double>::infinity();
  expectError(encode(Value::of(state), out), {"RigidBodyState.angular-velocity[1]", "inf"});
  Bearing b = makeBearing(true);
  b.range = -std::numeric_limits<double>::infinity();
  expectError(encode(Value::of(b), out), {"Bearing.range", "-inf"});
  CameraModel c = s.camera;
  c.distortion.assign(9, 0.1);
  expectError(encode(Value::of(c), out), {"CalibrationMatrix.distortion", "9", "bound is 8"});
  PointCloud cloud = s.cloud;
  std::vector<Point4f> points(cloud.points.begin(), cloud.points.end());
  points[5].y = std::numeric_limits<float>::quiet_NaN();
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  expectError(encode(Value::of(cloud), out), {"PointCloud.points[5]", "nan"});
  cloud = s.cloud;
  cloud.intensity = Buffer<float>::fromVector({1.0f});
  expectError(encode(Value::of(cloud), out),
              {"PointCloud.intensity", "1 entries", "one per point"});
}

TEST(Asn1Uper, ACloudOverItsBoundIsAnEncodeError) {
  PointCloud cloud;
  cloud.points = Buffer<Point4f>::fromVector(std::vector<Point4f>(kMaxCloudPoints + 1));
  std::vector<std::uint8_t> out;
  expectError(encode(Value::of(cloud), out), {"PointCloud.points", "2097153", "2097152"});
}

TEST(Asn1Uper, NamesAndTypesAgree) {
  for (Asn1Type t : allAsn1Types()) {
    EXPECT_EQ(asn1TypeNamed(asn1Name(t)), t);
    if (cdffTypeOf(t)) {
      EXPECT_TRUE(hasAsn1Type(cdffTypeOf(t)));
    }
  }
  EXPECT_FALSE(asn1TypeNamed("Image16UC1"));
  EXPECT_FALSE(hasAsn1Type(TypeId::of<Wrench>()));
}

}  // namespace
}  // namespace cdff::asn1
