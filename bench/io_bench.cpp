// Recording and replay throughput (MCAP): 2 MP images and 30k-point clouds written and read,
// uncompressed, lz4 and zstd; the cost of opening a file's index versus its size; the CRC and
// the raw compressors as peers. Files go to $TMPDIR (default /tmp).
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include "bench_support.hpp"
#include "cdff/io/crc32.hpp"
#include "cdff/io/recorder.hpp"
#include "cdff/io/replay.hpp"

namespace {

using namespace cdff;
namespace fs = std::filesystem;

std::string tempFile(const std::string& name) {
  const char* dir = std::getenv("TMPDIR");
  return (fs::path(dir ? dir : "/tmp") /
          ("cdff_io_bench_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

io::Compression compressionArg(const benchmark::State& state) {
  return static_cast<io::Compression>(state.range(0));
}

// A 1624 x 1234 frame as the simulator renders them: dark space, a textured target over about
// a third of the image, Gaussian sensor noise (sigma 2 DN).
Image frame(int seed) {
  const int w = 1624, h = 1234;
  std::vector<std::uint8_t> pixels(static_cast<std::size_t>(w) * h);
  std::mt19937 rng(static_cast<std::uint32_t>(seed));
  std::normal_distribution<float> noise(0.f, 2.f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float dx = (x - w * 0.5f) / (w * 0.3f), dy = (y - h * 0.5f) / (h * 0.35f);
      float v = 6.f;
      if (dx * dx + dy * dy < 1.f)
        v = 120.f + 60.f * std::sin(x * 0.05f + seed) * std::cos(y * 0.031f) +
            25.f * ((x / 16 + y / 16) % 2);
      pixels[static_cast<std::size_t>(y) * w + x] =
          static_cast<std::uint8_t>(std::clamp(v + noise(rng), 0.f, 255.f));
    }
  Image im = Image::fromBytes(std::move(pixels), w, h, PixelFormat::kGray8).value();
  im.frame_id = "camera_left_optical";
  return im;
}

// 30 000 lidar returns on a target ~10 m away, with intensity, ring and time offsets ("full"),
// or points only.
PointCloud cloud(int seed, bool full) {
  const std::size_t n = 30'000;
  std::mt19937 rng(static_cast<std::uint32_t>(seed));
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<Point4f> points(n);
  std::vector<float> intensity(n);
  std::vector<std::uint16_t> ring(n);
  std::vector<std::int32_t> offsets(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float az = u(rng) * 0.6f, el = u(rng) * 0.3f, r = 10.f + u(rng);
    points[i] =
        Point4f(r * std::cos(el) * std::cos(az), r * std::cos(el) * std::sin(az), r * std::sin(el));
    intensity[i] = 50.f + 40.f * u(rng);
    ring[i] = static_cast<std::uint16_t>(i % 32);
    offsets[i] = static_cast<std::int32_t>(i * 3);
  }
  PointCloud c;
  c.frame_id = "lidar";
  c.points = Buffer<Point4f>::fromVector(std::move(points));
  if (full) {
    c.intensity = Buffer<float>::fromVector(std::move(intensity));
    c.ring = Buffer<std::uint16_t>::fromVector(std::move(ring));
    c.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(offsets));
  }
  return c;
}

std::size_t cloudBytes(const PointCloud& c) {
  return c.points.size() * 12 + c.intensity.size() * 4 + c.ring.size() * 2 +
         c.time_offset_us.size() * 4;
}

// Writes `value` at 10 Hz, into a file in $TMPDIR (sink 0) or into /dev/null (sink 1: the
// writer's own cost, without the kernel's page cache and disk); the file is restarted (untimed)
// every 50 messages to bound its size.
template <typename T>
void writeLoop(benchmark::State& state, T value, std::size_t payload_bytes, const char* channel) {
  const bool null_sink = state.range(1) != 0;
  const std::string path = null_sink ? std::string("/dev/null") : tempFile("write.mcap");
  io::McapWriterOptions options;
  options.compression = compressionArg(state);
  io::Recorder rec;
  if (!rec.open(path, options).isOk()) {
    state.SkipWithError("cannot open the output file");
    return;
  }
  std::int64_t i = 0;
  for (auto _ : state) {
    value.stamp = i * 100'000;
    if (!rec.write(channel, value).isOk()) {
      state.SkipWithError("write failed");
      break;
    }
    if (++i % 50 == 0) {
      state.PauseTiming();
      (void)rec.close();
      (void)rec.open(path, options);
      state.ResumeTiming();
    }
  }
  (void)rec.close();
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(payload_bytes));
  if (!null_sink) fs::remove(path);
}

void BM_WriteImage2MP(benchmark::State& state) {
  const Image im = frame(1);
  writeLoop(state, im, im.pixels.size(), "/chaser/camera/left/image");
}
BENCHMARK(BM_WriteImage2MP)->ArgNames({"compression", "sink"})->ArgsProduct({{0, 1, 2}, {0, 1}});

void BM_WriteCloud30k(benchmark::State& state) {
  const PointCloud c = cloud(1, state.range(2) != 0);
  writeLoop(state, c, cloudBytes(c), "/chaser/lidar/points");
}
BENCHMARK(BM_WriteCloud30k)
    ->ArgNames({"compression", "sink", "fields"})
    ->ArgsProduct({{0, 1, 2}, {0, 1}, {0, 1}});

// Reads (and decodes) 32 messages written beforehand.
template <typename T>
void readLoop(benchmark::State& state, const std::vector<T>& values, std::size_t payload_bytes,
              const char* channel) {
  const std::string path = tempFile("read.mcap");
  {
    io::McapWriterOptions options;
    options.compression = compressionArg(state);
    io::Recorder rec;
    if (!rec.open(path, options).isOk()) {
      state.SkipWithError("cannot write the input file");
      return;
    }
    for (const T& v : values) (void)rec.write(channel, v);
    (void)rec.close();
  }
  std::size_t n = 0;
  for (auto _ : state) {
    io::Replay replay;
    if (!replay.open({path}).isOk()) {
      state.SkipWithError("cannot open the input file");
      break;
    }
    while (replay.next()) {
      auto v = replay.message().decode<T>();
      benchmark::DoNotOptimize(v);
      ++n;
    }
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(n * payload_bytes));
  state.SetItemsProcessed(static_cast<std::int64_t>(n));
  fs::remove(path);
}

void BM_ReadImage2MP(benchmark::State& state) {
  std::vector<Image> images;
  for (int i = 0; i < 32; ++i) {
    Image im = frame(i % 4);
    im.stamp = i * 100'000;
    images.push_back(im);
  }
  readLoop(state, images, images[0].pixels.size(), "/chaser/camera/left/image");
}
BENCHMARK(BM_ReadImage2MP)->ArgName("compression")->Arg(0)->Arg(1)->Arg(2);

void BM_ReadCloud30k(benchmark::State& state) {
  std::vector<PointCloud> clouds;
  for (int i = 0; i < 32; ++i) {
    PointCloud c = cloud(i, state.range(1) != 0);
    c.stamp = i * 100'000;
    clouds.push_back(c);
  }
  readLoop(state, clouds, cloudBytes(clouds[0]), "/chaser/lidar/points");
}
BENCHMARK(BM_ReadCloud30k)->ArgNames({"compression", "fields"})->ArgsProduct({{0, 1, 2}, {0, 1}});

// Opening a file reads its summary: the cost follows the number of chunks, not of messages.
void BM_OpenIndex(benchmark::State& state) {
  const auto chunks = static_cast<std::size_t>(state.range(0));
  const auto per_chunk = static_cast<std::size_t>(state.range(1));
  const std::string path = tempFile("index.mcap");
  {
    io::McapWriter w;
    io::McapWriterOptions options;
    options.compression = io::Compression::kNone;
    options.chunk_duration_ns = 0;
    options.chunk_size = std::numeric_limits<std::size_t>::max();
    (void)w.open(path, options);
    auto ch = w.addChannel("/chaser/imu", "raw", 0);
    const std::uint8_t payload[16] = {};
    std::uint64_t t = 0;
    for (std::size_t c = 0; c < chunks; ++c) {
      for (std::size_t m = 0; m < per_chunk; ++m, t += 1000) (void)w.write(*ch, t, t, payload);
      (void)w.flush();
    }
    (void)w.close();
  }
  for (auto _ : state) {
    io::McapReader r;
    if (!r.open(path).isOk() || r.chunks().size() != chunks) {
      state.SkipWithError("unexpected index");
      break;
    }
    benchmark::DoNotOptimize(r.statistics().message_count);
  }
  state.counters["file_MB"] = static_cast<double>(fs::file_size(path)) / 1e6;
  state.counters["messages"] = static_cast<double>(chunks * per_chunk);
  fs::remove(path);
}
BENCHMARK(BM_OpenIndex)
    ->ArgNames({"chunks", "messages_per_chunk"})
    ->ArgsProduct({{100, 1000, 4000}, {10, 400}})
    ->Unit(benchmark::kMicrosecond);

// Peers: CRC-32 (ours, slice-by-16, and zlib's) and the raw compressors on one frame.
void BM_Crc32(benchmark::State& state) {
  const Image im = frame(2);
  const bool zlib = state.range(0) != 0;
  for (auto _ : state) {
    std::uint32_t c = zlib ? static_cast<std::uint32_t>(
                                 ::crc32(0L, im.pixels.data(), static_cast<uInt>(im.pixels.size())))
                           : io::crc32(im.pixels.span());
    benchmark::DoNotOptimize(c);
  }
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(im.pixels.size()));
  state.SetLabel(zlib ? "zlib crc32" : "cdff slice-by-16");
}
BENCHMARK(BM_Crc32)->ArgName("zlib")->Arg(0)->Arg(1);

void BM_RawCompressor(benchmark::State& state) {
  const Image im = frame(1);
  const bool zstd = state.range(0) != 0;
  std::vector<std::uint8_t> out(std::max(ZSTD_compressBound(im.pixels.size()),
                                         LZ4F_compressFrameBound(im.pixels.size(), nullptr)));
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  std::size_t n = 0;
  for (auto _ : state) {
    if (zstd) {
      n = ZSTD_compressCCtx(cctx, out.data(), out.size(), im.pixels.data(), im.pixels.size(), 1);
    } else {
      LZ4F_preferences_t prefs{};
      prefs.frameInfo.blockSizeID = LZ4F_max4MB;
      n = LZ4F_compressFrame(out.data(), out.size(), im.pixels.data(), im.pixels.size(), &prefs);
    }
    benchmark::DoNotOptimize(n);
  }
  ZSTD_freeCCtx(cctx);
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(im.pixels.size()));
  state.counters["ratio"] = static_cast<double>(im.pixels.size()) / static_cast<double>(n);
  state.SetLabel(zstd ? "ZSTD_compressCCtx level 1" : "LZ4F_compressFrame");
}
BENCHMARK(BM_RawCompressor)->ArgName("zstd")->Arg(0)->Arg(1);

}  // namespace

CDFF_BENCHMARK_MAIN();
