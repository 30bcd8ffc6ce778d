// The DDS transport (docs/dds.md) on loopback: publish -> receive latency of a 1624x1234 mono
// image (with its camera info) and of a 30k-point LIDAR scan (xyz, intensity, ring, time), as a
// CDFF program sees it: the value converted to its ROS 2 message, serialised by Cyclone DDS,
// sent over UDP to another process, deserialised and converted back to a CDFF value.
//
// Ping-pong, as Cyclone's own `ddsperf ping`/`pong`: this process publishes a ping, an echo
// process (this program, started with --echo DOMAIN) receives it as a CDFF value and publishes it
// back; the latency is half the round trip. The counters give p50 and p99 over the iterations,
// and the CPU time of this process per message. The peer figure, Cyclone's ddsperf with the same
// payload sizes, is run beside it by bench/dds_bench.sh.
#include <benchmark/benchmark.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <thread>

#include "cdff/dds/publisher.hpp"
#include "cdff/dds/subscriber.hpp"

namespace {

using namespace cdff;
using Clock = std::chrono::steady_clock;

std::atomic<bool> echo_stop{false};
extern "C" void onEchoStop(int) {
  echo_stop.store(true);
}

const std::pair<const char*, TypeId> kPings[] = {{"/bench/image", TypeId::of<Image>()},
                                                 {"/bench/cloud", TypeId::of<PointCloud>()}};

// The echo process: every ping comes back on <channel>/pong.
int runEcho(int domain) {
  std::signal(SIGTERM, onEchoStop);
  auto participant = dds::Participant::create(domain);
  if (!participant) return 1;
  dds::Subscriber subscriber(**participant);
  dds::Publisher publisher(**participant);
  for (const auto& [channel, type] : kPings)
    if (!subscriber.subscribe(channel, type) ||
        !publisher.prepare(std::string(channel) + "/pong", type))
      return 1;
  std::vector<dfpc::Message> messages;
  std::vector<dds::Rejection> rejections;
  while (!echo_stop.load() && getppid() != 1) {
    messages.clear();
    if (!subscriber.poll(0.1, messages, rejections)) return 1;
    for (dfpc::Message& m : messages) {
      m.channel += "/pong";
      if (!publisher.publish(m)) return 1;
    }
  }
  return 0;
}

Image benchImage() {
  const int w = 1624, h = 1234;
  std::vector<std::uint8_t> pixels(static_cast<std::size_t>(w) * h);
  std::mt19937 rng(1);
  for (auto& p : pixels) p = static_cast<std::uint8_t>(rng());
  Image image = Image::fromBytes(std::move(pixels), w, h, PixelFormat::kGray8).value();
  image.frame_id = "camera_left_optical";
  CameraModel camera;
  camera.width = w;
  camera.height = h;
  camera.fx = camera.fy = 1800;
  camera.cx = w / 2.0;
  camera.cy = h / 2.0;
  image.camera = camera;
  return image;
}

PointCloud benchCloud() {
  const std::size_t n = 30'000;
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-20, 20);
  std::vector<Eigen::Vector3f> xyz(n);
  for (auto& p : xyz) p = {u(rng), u(rng), u(rng)};
  PointCloud cloud = PointCloud::fromXyz(xyz, "lidar");
  std::vector<float> intensity(n, 0.5f);
  std::vector<std::uint16_t> ring(n);
  std::vector<std::int32_t> time(n);
  for (std::size_t i = 0; i < n; ++i) {
    ring[i] = static_cast<std::uint16_t>(i % 16);
    time[i] = static_cast<std::int32_t>(i * 3);
  }
  cloud.intensity = Buffer<float>::fromVector(std::move(intensity));
  cloud.ring = Buffer<std::uint16_t>::fromVector(std::move(ring));
  cloud.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(time));
  return cloud;
}

// Publishes `value` on `channel` and waits for its echo; the round trip in seconds, or < 0.
double roundTrip(dds::Publisher& publisher, dds::Subscriber& subscriber, const std::string& channel,
                 const Value& value, Timestamp stamp) {
  std::vector<dfpc::Message> messages;
  std::vector<dds::Rejection> rejections;
  const auto start = Clock::now();
  if (!publisher.publish({channel, stamp, value})) return -1;
  while (messages.empty()) {
    if (!subscriber.poll(1.0, messages, rejections) || !rejections.empty()) return -1;
    if (Clock::now() - start > std::chrono::seconds(5)) return -1;
  }
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void pingPong(benchmark::State& state, const std::string& channel, const Value& value) {
  const int domain = 1 + static_cast<int>(getpid() % dds::kMaxDomainId);
  const pid_t echo = fork();
  if (echo == 0) {
    execl("/proc/self/exe", "dds_bench", "--echo", std::to_string(domain).c_str(), nullptr);
    _exit(127);
  }
  {
    auto participant = dds::Participant::create(domain).value();
    dds::Publisher publisher(*participant);
    dds::Subscriber subscriber(*participant);
    (void)publisher.prepare(channel, value.type());
    (void)subscriber.subscribe(channel + "/pong", value.type());
    while (publisher.matchedReaders(channel) == 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    // The first round trips also wait for the pong topic to match.
    for (int i = 0; i < 5; ++i)
      if (roundTrip(publisher, subscriber, channel, value, i) < 0) i = i - 1;
    std::vector<double> latencies;
    for (auto _ : state) {
      const double rtt = roundTrip(publisher, subscriber, channel, value, 10 + state.iterations());
      if (rtt < 0) {
        state.SkipWithError("no echo within 5 s");
        break;
      }
      latencies.push_back(rtt / 2);
      state.SetIterationTime(rtt / 2);
    }
    std::sort(latencies.begin(), latencies.end());
    if (!latencies.empty()) {
      state.counters["p50_us"] = latencies[latencies.size() / 2] * 1e6;
      state.counters["p99_us"] = latencies[latencies.size() * 99 / 100] * 1e6;
    }
  }
  kill(echo, SIGTERM);
  waitpid(echo, nullptr, 0);
}

void BM_DdsLatency_Image1624x1234(benchmark::State& state) {
  const Image image = benchImage();
  pingPong(state, "/bench/image", Value::of(image));
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(image.pixels.size()));
}
BENCHMARK(BM_DdsLatency_Image1624x1234)
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond)
    ->Iterations(200);

void BM_DdsLatency_PointCloud30k(benchmark::State& state) {
  const PointCloud cloud = benchCloud();
  pingPong(state, "/bench/cloud", Value::of(cloud));
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(cloud.size()));
}
BENCHMARK(BM_DdsLatency_PointCloud30k)
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond)
    ->Iterations(200);

}  // namespace

// The benchmark's main, with the echo mode the ping-pong starts and the configuration for ddsperf.
int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--echo") == 0) return runEcho(std::atoi(argv[2]));
  if (argc == 2 && std::strcmp(argv[1], "--print-config") == 0) {
    std::puts(dds::kDefaultConfiguration);  // for ddsperf, the peer (bench/dds_bench.sh)
    return 0;
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
