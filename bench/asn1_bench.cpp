// The ESROCOS ASN.1 types in uPER (docs/asn1.md): encode and decode time per type, and the uPER
// size beside the size of the same value as the CDFF's MCAP message (its protobuf or JSON
// codec, src/cdff/types/codec), whose encode and decode times are measured too.
//   build/bench/asn1_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
// Counters: uper_bytes, mcap_bytes (per message).
#include <random>

#include "bench_support.hpp"
#include "cdff/asn1/uper.hpp"
#include "cdff/types/codec/codec.hpp"

namespace cdff::bench {
namespace {

constexpr Timestamp kStamp = 1'700'000'000'000'000;

Image image(PixelFormat format) {
  const int w = 1624, h = 1234;
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(w) * h * bytesPerPixel(format));
  std::mt19937 rng(7);
  if (format == PixelFormat::kFloat32) {
    std::uniform_real_distribution<float> depth(1.0f, 20.0f);
    for (std::size_t i = 0; i < bytes.size(); i += 4) {
      const float d = depth(rng);
      std::memcpy(&bytes[i], &d, 4);
    }
  } else {
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng() & 0x3f);
  }
  Image im = Image::fromBytes(std::move(bytes), w, h, format).value();
  im.stamp = kStamp;
  im.frame_id = "camera_left_optical";
  CameraModel c;
  c.width = w;
  c.height = h;
  c.fx = c.fy = 1400.5;
  c.cx = 811.5;
  c.cy = 616.5;
  c.distortion_model = DistortionModel::kRadialTangential;
  c.distortion = {-0.21, 0.05, 0.001, -0.0005, 0.002};
  im.camera = c;
  return im;
}

PointCloud cloud(bool fields) {
  const std::size_t n = 30000;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  std::vector<Point4f> points(n);
  std::vector<float> intensity(n);
  std::vector<std::uint16_t> ring(n);
  std::vector<std::int32_t> offsets(n);
  for (std::size_t i = 0; i < n; ++i) {
    points[i] = Point4f(u(rng), u(rng), 10 + u(rng));
    intensity[i] = static_cast<float>(i % 255);
    ring[i] = static_cast<std::uint16_t>(i % 16);
    offsets[i] = static_cast<std::int32_t>(i * 3);
  }
  PointCloud c;
  c.stamp = kStamp;
  c.frame_id = "lidar";
  c.points = Buffer<Point4f>::fromVector(std::move(points));
  if (fields) {
    c.intensity = Buffer<float>::fromVector(std::move(intensity));
    c.ring = Buffer<std::uint16_t>::fromVector(std::move(ring));
    c.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(offsets));
  }
  return c;
}

PoseWithCovariance pose() {
  PoseWithCovariance p;
  p.pose.stamp = kStamp;
  p.pose.parent_frame = "camera_left_optical";
  p.pose.child_frame = "target";
  p.pose.translation = {0.12, -0.34, 9.87};
  p.pose.rotation = expSO3({0.1, -0.2, 0.3});
  Matrix6d a = Matrix6d::Random();
  p.covariance = a * a.transpose() * 1e-4;
  return p;
}

RigidBodyState state() {
  RigidBodyState s;
  s.pose = pose().pose;
  s.twist.linear = {0.01, -0.02, 0.003};
  s.twist.angular = {0.001, 0.002, -0.03};
  Matrix12d b = Matrix12d::Random();
  s.covariance = b * b.transpose() * 1e-4;
  return s;
}

Bearing bearing() {
  Bearing b;
  b.stamp = kStamp;
  b.frame_id = "chaser";
  b.direction = Eigen::Vector3d(0.9, -0.3, 0.1).normalized();
  b.covariance = Eigen::Matrix3d::Identity() * 1e-8;
  b.range = 1834.25;
  b.range_variance = 12.5;
  b.designation = "automatic";
  return b;
}

// The values by benchmark argument.
Value sample(int which) {
  switch (which) {
    case 0:
      return Value::of(pose().pose);
    case 1:
      return Value::of(pose());
    case 2:
      return Value::of(state());
    case 3:
      return Value::of(bearing());
    case 4:
      return Value::of(*image(PixelFormat::kGray8).camera);
    case 5:
      return Value::of(image(PixelFormat::kGray8));
    case 6:
      return Value::of(image(PixelFormat::kBgr8));
    case 7:
      return Value::of(image(PixelFormat::kFloat32));
    case 8:
      return Value::of(cloud(false));
    default:
      return Value::of(cloud(true));
  }
}

const char* const kNames[] = {"Transform",           "TransformWithCovariance",
                              "RigidBodyState",      "Bearing",
                              "CalibrationMatrix",   "Image8UC1 1624x1234",
                              "Image8UC3 1624x1234", "Image32FC1 1624x1234",
                              "PointCloud 30k xyz",  "PointCloud 30k +intensity,ring,time"};

std::size_t mcapBytes(const Value& v) {
  codec::Encoded e;
  return v.type().info().encode(v.raw(), kStamp, e).isOk() ? e.size() : 0;
}

void counters(benchmark::State& s, const Value& v, std::size_t uper) {
  s.SetLabel(kNames[s.range(0)]);
  s.counters["uper_bytes"] = static_cast<double>(uper);
  s.counters["mcap_bytes"] = static_cast<double>(mcapBytes(v));
}

void BM_UperEncode(benchmark::State& s) {
  const Value v = sample(static_cast<int>(s.range(0)));
  std::vector<std::uint8_t> out;
  for (auto _ : s) {
    if (!asn1::encode(v, out).isOk()) return s.SkipWithError("encode failed");
    benchmark::DoNotOptimize(out.data());
  }
  counters(s, v, out.size());
}
BENCHMARK(BM_UperEncode)->DenseRange(0, 9)->Unit(benchmark::kMicrosecond);

void BM_UperDecode(benchmark::State& s) {
  const Value v = sample(static_cast<int>(s.range(0)));
  const std::vector<std::uint8_t> bytes = asn1::encode(v).value();
  const asn1::Asn1Type type = asn1::asn1TypeOf(v).value();
  for (auto _ : s) {
    Result<Value> back = asn1::decode(type, bytes);
    if (!back) return s.SkipWithError(back.status().message().c_str());
    benchmark::DoNotOptimize(back->raw());
  }
  counters(s, v, bytes.size());
}
BENCHMARK(BM_UperDecode)->DenseRange(0, 9)->Unit(benchmark::kMicrosecond);

// The peer: the CDFF's own codec (the MCAP message), same values.
void BM_McapEncode(benchmark::State& s) {
  const Value v = sample(static_cast<int>(s.range(0)));
  codec::Encoded e;
  for (auto _ : s) {
    if (!v.type().info().encode(v.raw(), kStamp, e).isOk()) return s.SkipWithError("failed");
    std::vector<std::uint8_t> flat = e.flatten();  // one contiguous message, like uPER's
    benchmark::DoNotOptimize(flat.data());
  }
  counters(s, v, asn1::encode(v).value().size());
}
BENCHMARK(BM_McapEncode)->DenseRange(0, 9)->Unit(benchmark::kMicrosecond);

void BM_McapDecode(benchmark::State& s) {
  const Value v = sample(static_cast<int>(s.range(0)));
  codec::Encoded e;
  (void)v.type().info().encode(v.raw(), kStamp, e);
  const std::vector<std::uint8_t> bytes = e.flatten();
  for (auto _ : s) {
    Result<Value> back = v.type().info().decode(bytes, nullptr);
    if (!back) return s.SkipWithError(back.status().message().c_str());
    benchmark::DoNotOptimize(back->raw());
  }
  counters(s, v, asn1::encode(v).value().size());
}
BENCHMARK(BM_McapDecode)->DenseRange(0, 9)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace cdff::bench

CDFF_BENCHMARK_MAIN();
