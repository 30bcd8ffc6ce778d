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
//
// Throughput, the load of a servicer's sensor suite: a 25 Hz stereo pair (two 1624x1234 mono
// images with their camera infos) and a 10 Hz 30k-point scan, published for 5 s to a sink process
// (this program, started with --sink DOMAIN FD) that receives them as CDFF values. The counters
// give each process's CPU (all its threads, Cyclone's included) as a percentage of one core, the
// samples lost, and the one-way latency under that load (the sample's stamp is the publisher's
// CLOCK_MONOTONIC, which the sink reads too). Peer: ddsperf pub/sub at the same rates and sizes.
#include <benchmark/benchmark.h>
#include <signal.h>
#include <sys/resource.h>
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
#include "cdff/types/memory.hpp"

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

// The CPU time of this process (every thread), in seconds.
double processCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

std::int64_t monotonicMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(Clock::now().time_since_epoch())
      .count();
}

const std::pair<const char*, TypeId> kSensorSuite[] = {
    {"/bench/stereo/left/image", TypeId::of<Image>()},
    {"/bench/stereo/right/image", TypeId::of<Image>()},
    {"/bench/lidar/points", TypeId::of<PointCloud>()}};

// What the sink reports through its pipe when it stops.
struct SinkReport {
  std::uint64_t received = 0;
  double cpu_s = 0;  // from its first sample to its last
  double wall_s = 0;
  double latency_p50_s = 0;  // publish (stamp) -> received as a CDFF value
  double latency_p99_s = 0;
};

// The sink process: receives the sensor suite as CDFF values until SIGTERM, then writes a
// SinkReport to `fd`.
int runSink(int domain, int fd) {
  std::signal(SIGTERM, onEchoStop);
  auto participant = dds::Participant::create(domain);
  if (!participant) return 1;
  dds::Subscriber subscriber(**participant);
  for (const auto& [channel, type] : kSensorSuite)
    if (!subscriber.subscribe(channel, type)) return 1;
  std::vector<dfpc::Message> messages;
  std::vector<dds::Rejection> rejections;
  std::vector<double> latencies;
  SinkReport report;
  double cpu_first = 0;
  Clock::time_point wall_first, wall_last;
  while (!echo_stop.load() && getppid() != 1) {
    messages.clear();
    if (!subscriber.poll(0.1, messages, rejections)) return 1;
    const std::int64_t now = monotonicMicros();
    for (const dfpc::Message& m : messages) {
      if (report.received++ == 0) {
        cpu_first = processCpuSeconds();
        wall_first = Clock::now();
      }
      latencies.push_back(1e-6 * static_cast<double>(now - m.stamp));
    }
    if (!messages.empty()) {
      report.cpu_s = processCpuSeconds() - cpu_first;
      wall_last = Clock::now();
    }
  }
  report.wall_s = std::chrono::duration<double>(wall_last - wall_first).count();
  std::sort(latencies.begin(), latencies.end());
  if (!latencies.empty()) {
    report.latency_p50_s = latencies[latencies.size() / 2];
    report.latency_p99_s = latencies[latencies.size() * 99 / 100];
  }
  return write(fd, &report, sizeof report) == sizeof report ? 0 : 1;
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

// 25 Hz stereo + 10 Hz LIDAR for 5 s (one iteration), to a sink in another process.
void BM_DdsThroughput_Stereo25Hz_Lidar10Hz(benchmark::State& state) {
  const Image left = benchImage();
  Image right = left;
  right.frame_id = "camera_right_optical";
  const PointCloud cloud = benchCloud();
  const int domain = 1 + static_cast<int>((getpid() + 7) % dds::kMaxDomainId);
  int report_pipe[2];
  if (pipe(report_pipe) != 0) {
    state.SkipWithError("pipe() failed");
    return;
  }
  const pid_t sink = fork();
  if (sink == 0) {
    close(report_pipe[0]);
    execl("/proc/self/exe", "dds_bench", "--sink", std::to_string(domain).c_str(),
          std::to_string(report_pipe[1]).c_str(), nullptr);
    _exit(127);
  }
  close(report_pipe[1]);
  std::uint64_t sent = 0;
  double publisher_cpu = 0, publisher_wall = 0;
  {
    auto participant = dds::Participant::create(domain).value();
    dds::Publisher publisher(*participant);
    for (const auto& [channel, type] : kSensorSuite) (void)publisher.prepare(channel, type);
    for (const auto& [channel, type] : kSensorSuite)
      while (publisher.matchedReaders(channel) == 0)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    for (auto _ : state) {
      const auto start = Clock::now();
      const double cpu_start = processCpuSeconds();
      const auto period =
          std::chrono::milliseconds(20);  // the 50 Hz tick: stereo every 2nd, LIDAR every 5th
      for (int tick = 0; tick < 250; ++tick) {
        std::this_thread::sleep_until(start + tick * period);
        // The samples' stamps: the publisher's CLOCK_MONOTONIC (the pixels and points are shared
        // buffers: a copy of the value does not copy them).
        const std::int64_t stamp = monotonicMicros();
        Image left_now = left, right_now = right;
        PointCloud cloud_now = cloud;
        left_now.stamp = right_now.stamp = cloud_now.stamp = stamp;
        const Value left_value = Value::of(std::move(left_now));
        const Value right_value = Value::of(std::move(right_now));
        const Value cloud_value = Value::of(std::move(cloud_now));
        bool ok = true;
        if (tick % 2 == 0) {
          ok = ok && publisher.publish({kSensorSuite[0].first, stamp, left_value}).isOk();
          ok = ok && publisher.publish({kSensorSuite[1].first, stamp, right_value}).isOk();
          sent += 2;
        }
        if (tick % 5 == 0) {
          ok = ok && publisher.publish({kSensorSuite[2].first, stamp, cloud_value}).isOk();
          ++sent;
        }
        if (!ok) {
          state.SkipWithError("publish failed");
          break;
        }
      }
      publisher_cpu = processCpuSeconds() - cpu_start;
      publisher_wall = std::chrono::duration<double>(Clock::now() - start).count();
      state.SetIterationTime(publisher_wall);
    }
    (void)publisher.waitForAcknowledgements(5.0);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(sink, SIGTERM);
  SinkReport report;
  const bool reported = read(report_pipe[0], &report, sizeof report) == sizeof report;
  close(report_pipe[0]);
  waitpid(sink, nullptr, 0);
  if (!reported) {
    state.SkipWithError("the sink did not report");
    return;
  }
  state.counters["sent"] = static_cast<double>(sent);
  state.counters["lost"] = static_cast<double>(sent) - static_cast<double>(report.received);
  state.counters["pub_cpu_pct"] = 100 * publisher_cpu / publisher_wall;
  state.counters["sub_cpu_pct"] = report.wall_s > 0 ? 100 * report.cpu_s / report.wall_s : 0;
  state.counters["lat_p50_us"] = report.latency_p50_s * 1e6;
  state.counters["lat_p99_us"] = report.latency_p99_s * 1e6;
  state.SetBytesProcessed(static_cast<std::int64_t>(
      (2 * left.pixels.size() * 125 + cloud.size() * 22 * 50) * state.iterations()));
}
BENCHMARK(BM_DdsThroughput_Stereo25Hz_Lidar10Hz)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace

// The benchmark's main, with the echo mode the ping-pong starts and the configuration for ddsperf.
int main(int argc, char** argv) {
  keepFreedBuffersForReuse();  // as the `cdff` command does
  if (argc == 3 && std::strcmp(argv[1], "--echo") == 0) return runEcho(std::atoi(argv[2]));
  if (argc == 4 && std::strcmp(argv[1], "--sink") == 0)
    return runSink(std::atoi(argv[2]), std::atoi(argv[3]));
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
