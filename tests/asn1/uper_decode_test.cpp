// Untrusted uPER bytes: every truncation of every type's encoding, trailing bytes, random bytes
// and bit flips of valid encodings (a deterministic fuzz loop, about a second) are decode errors
// or values within the ASN.1 constraints, never a crash (the sanitizer build checks memory).
#include <random>

#include <gtest/gtest.h>

#include "cdff/asn1/uper.hpp"
#include "samples.hpp"

namespace cdff::asn1 {
namespace {

constexpr Timestamp kStamp = 987'654'321;

struct Encoding {
  Asn1Type type;
  std::vector<std::uint8_t> bytes;
};

// One small value of every ASN.1 type, encoded.
std::vector<Encoding> encodings() {
  const testing::IoSamples s = testing::makeIoSamples(4, kStamp);
  Bearing bearing;
  bearing.stamp = kStamp;
  bearing.frame_id = "chaser";
  bearing.range = 100;
  bearing.range_variance = 1;
  std::vector<Encoding> out;
  for (const Value& v :
       {Value::of<Timestamp>(kStamp), Value::of(s.transform), Value::of(s.pose), Value::of(s.state),
        Value::of(bearing), Value::of(s.camera), Value::of(s.image_mono), Value::of(s.image_bgr),
        Value::of(s.image_float), Value::of(s.cloud)}) {
    Result<std::vector<std::uint8_t>> bytes = encode(v);
    EXPECT_TRUE(bytes.isOk()) << bytes.status().message();
    out.push_back({asn1TypeOf(v).value(), bytes ? *bytes : std::vector<std::uint8_t>()});
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(1, 2, 3);
  Encoding point{Asn1Type::kPoint, {}}, pose_bytes{Asn1Type::kPose, {}};
  EXPECT_TRUE(encodePoint({1, 2, 3}, point.bytes).isOk());
  EXPECT_TRUE(encodePose(pose, pose_bytes.bytes).isOk());
  out.push_back(point);
  out.push_back(pose_bytes);
  return out;
}

// Decodes as any type; an error or a value, which must then be within the constraints (its
// encoding succeeds).
Status decodeAny(Asn1Type type, std::span<const std::uint8_t> data) {
  if (type == Asn1Type::kPoint) return decodePoint(data).status();
  if (type == Asn1Type::kPose) return decodePose(data).status();
  Result<Value> v = decode(type, data);
  if (!v) return v.status();
  std::vector<std::uint8_t> again;
  const Status re = encode(*v, again);
  EXPECT_TRUE(re.isOk()) << asn1Name(type) << ": a decoded value does not encode: " << re.message();
  return Status::ok();
}

TEST(Asn1UperDecode, EveryTruncationIsAnErrorThatSaysTruncated) {
  for (const Encoding& e : encodings()) {
    SCOPED_TRACE(std::string(asn1Name(e.type)));
    ASSERT_FALSE(e.bytes.empty());
    ASSERT_TRUE(decodeAny(e.type, e.bytes).isOk());
    for (std::size_t n = 0; n < e.bytes.size(); ++n) {
      const Status s = decodeAny(e.type, std::span(e.bytes.data(), n));
      ASSERT_FALSE(s.isOk()) << n << " of " << e.bytes.size() << " bytes decoded";
      EXPECT_EQ(s.code(), StatusCode::kCorruptData) << s.message();
      EXPECT_NE(s.message().find(asn1Name(e.type)), std::string::npos) << s.message();
    }
  }
}

TEST(Asn1UperDecode, TrailingBytesAreAnError) {
  for (const Encoding& e : encodings()) {
    std::vector<std::uint8_t> longer = e.bytes;
    longer.push_back(0x5a);
    const Status s = decodeAny(e.type, longer);
    ASSERT_FALSE(s.isOk()) << asn1Name(e.type);
    EXPECT_NE(s.message().find("trailing"), std::string::npos) << s.message();
  }
}

// Image8UC1 and Image8UC3 have the same fields: 8 bytes of 4x2 mono8 pixels read as bgr8 do not
// match the size.
TEST(Asn1UperDecode, PixelsThatDoNotMatchTheSizeAreAnError) {
  Image mono = Image::fromBytes(std::vector<std::uint8_t>(8, 7), 4, 2, PixelFormat::kGray8).value();
  Result<std::vector<std::uint8_t>> bytes = encode(Value::of(mono));
  ASSERT_TRUE(bytes.isOk()) << bytes.status().message();
  Result<Value> v = decode(Asn1Type::kImage8UC3, *bytes);
  ASSERT_FALSE(v.isOk());
  EXPECT_NE(v.status().message().find("Image8UC3.data has 8 bytes; expected width * height * 3 = "
                                      "4 * 2 * 3 = 24"),
            std::string::npos)
      << v.status().message();
}

// A large image truncated at the 16K fragments of its pixels' length.
TEST(Asn1UperDecode, ALargeImageTruncatedAtItsFragmentsIsAnError) {
  const testing::IoSamples s = testing::makeIoSamples(1, kStamp, /*small=*/false);
  Result<std::vector<std::uint8_t>> bytes = encode(Value::of(s.image_float));
  ASSERT_TRUE(bytes.isOk()) << bytes.status().message();
  ASSERT_TRUE(decode(Asn1Type::kImage32FC1, *bytes).isOk());
  for (std::size_t n : {std::size_t{16}, std::size_t{65536 + 20}, std::size_t{65536 * 4 + 21},
                        bytes->size() / 2, bytes->size() - 1}) {
    Result<Value> v = decode(Asn1Type::kImage32FC1, std::span(bytes->data(), n));
    ASSERT_FALSE(v.isOk()) << n;
    EXPECT_NE(v.status().message().find("truncated"), std::string::npos) << v.status().message();
  }
}

// Random bytes, and valid encodings with random bits flipped or bytes overwritten, decoded as
// every type: errors or sound values, never a crash. Deterministic (fixed seed).
TEST(Asn1UperDecode, RandomAndMutatedBytesNeverCrash) {
  std::mt19937 rng(25);
  const std::vector<Encoding> valid = encodings();
  std::size_t errors = 0, decoded = 0;
  for (int round = 0; round < 20000; ++round) {
    std::vector<std::uint8_t> bytes;
    if (round % 2 == 0) {
      bytes.resize(rng() % 96);
      for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    } else {
      bytes = valid[rng() % valid.size()].bytes;
      const int flips = 1 + static_cast<int>(rng() % 4);
      for (int k = 0; k < flips; ++k) {
        const std::size_t at = rng() % bytes.size();
        if (rng() % 2)
          bytes[at] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
        else
          bytes[at] = static_cast<std::uint8_t>(rng());
      }
    }
    for (Asn1Type type : allAsn1Types()) (decodeAny(type, bytes).isOk() ? decoded : errors)++;
  }
  EXPECT_GT(errors, 0u);
  EXPECT_GT(decoded, 0u);  // some mutations keep a sound value: the loop reaches the converters
}

}  // namespace
}  // namespace cdff::asn1
