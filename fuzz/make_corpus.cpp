// Writes the seed corpus of the MCAP reader fuzzer (fuzz/corpus/): small sound files covering
// every compression and every schema, and damaged variants. Run: mcap_fuzz_corpus fuzz/corpus
#include <filesystem>
#include <fstream>
#include <iterator>

#include <fmt/format.h>

#include "cdff/io/recorder.hpp"
#include "samples.hpp"

using namespace cdff;

namespace {

Status writeFile(const std::string& path, io::Compression compression, int part) {
  io::Recorder rec;
  io::McapWriterOptions options;
  options.compression = compression;
  options.chunk_size = 8192;
  CDFF_RETURN_IF_ERROR(rec.open(path, options));
  for (int i = 0; i < 2; ++i) {
    const Timestamp t = 1'000'000 + i * 100'000;
    testing::IoSamples s = testing::makeIoSamples(i, t);
    // Keep every seed small: a few channels per file, tiny payloads.
    s.image_mono = s.image_float;
    if (part == 0) {
      CDFF_RETURN_IF_ERROR(rec.write("/chaser/imu", s.imu));
      CDFF_RETURN_IF_ERROR(rec.write("/cdff/pose_estimation/pose", s.pose));
      CDFF_RETURN_IF_ERROR(rec.write("/chaser/tf/camera_left", s.transform));
      CDFF_RETURN_IF_ERROR(rec.write("/chaser/arm/joints", s.joints));
      CDFF_RETURN_IF_ERROR(rec.writeEvent(t, "info", "seed", "event"));
    } else if (part == 1) {
      CDFF_RETURN_IF_ERROR(rec.write("/chaser/thermal/image", s.image_float));
      CDFF_RETURN_IF_ERROR(
          rec.writeCalibration("/chaser/camera/left/calibration", s.camera, t, "cam"));
      CDFF_RETURN_IF_ERROR(rec.write("/truth/target_state", s.state));
      CDFF_RETURN_IF_ERROR(rec.write("/cdff/reconstruction/mesh", s.mesh));
    } else {
      PointCloud cloud = s.cloud;
      cloud.points = Buffer<Point4f>::copyOf(s.cloud.points.span().first(4));
      cloud.normals = Buffer<Point4f>::copyOf(s.cloud.normals.span().first(4));
      cloud.intensity = Buffer<float>::copyOf(s.cloud.intensity.span().first(4));
      cloud.ring = Buffer<std::uint16_t>::copyOf(s.cloud.ring.span().first(4));
      cloud.time_offset_us = Buffer<std::int32_t>::copyOf(s.cloud.time_offset_us.span().first(4));
      CDFF_RETURN_IF_ERROR(rec.write("/chaser/lidar/points", cloud));
      Features2D f = s.features2d;
      f.keypoints.resize(3);
      f.descriptors.rows = 3;
      f.descriptors.data =
          Buffer<std::uint8_t>::copyOf(s.features2d.descriptors.data.span().first(96));
      CDFF_RETURN_IF_ERROR(rec.write("/cdff/tracking/features", f));
      Matches m;
      m.matches.assign(s.matches.matches.begin(), s.matches.matches.begin() + 3);
      CDFF_RETURN_IF_ERROR(rec.write("/cdff/tracking/matches", m, t));
      CDFF_RETURN_IF_ERROR(rec.write("/chaser/arm/wrench", s.wrench));
    }
  }
  const std::vector<std::uint8_t> blob = {1, 2, 3, 4};
  CDFF_RETURN_IF_ERROR(rec.writeAttachment("a.bin", "application/octet-stream", 5, blob));
  CDFF_RETURN_IF_ERROR(rec.writeMetadata("run", {{"k", "v"}}));
  return rec.close();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    fmt::print(stderr, "usage: mcap_fuzz_corpus DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  std::filesystem::create_directories(dir);
  for (io::Compression c : {io::Compression::kNone, io::Compression::kLz4, io::Compression::kZstd})
    for (int part = 0; part < 3; ++part) {
      const std::string path = fmt::format("{}/seed_{}_{}.mcap", dir, io::toString(c), part);
      if (Status s = writeFile(path, c, part); !s.isOk()) {
        fmt::print(stderr, "{}\n", s.toString());
        return 1;
      }
      if (c == io::Compression::kZstd && part == 0) {  // a truncated copy: the recovery path
        std::ifstream in(path, std::ios::binary);
        std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
        std::ofstream(fmt::format("{}/seed_truncated.mcap", dir), std::ios::binary)
            .write(bytes.data(), static_cast<std::streamsize>(bytes.size() * 2 / 3));
      }
    }
  return 0;
}
