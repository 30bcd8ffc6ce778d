#pragma once
// What the DDS command-line tests share: `cdff` started in the background, a far-range approach
// simulated and run by `cdff run` once per test program, the messages of a recording by channel,
// and a DDS domain of the test's own.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "cdff/dds/participant.hpp"
#include "cdff/dds/publisher.hpp"
#include "cdff/io/replay.hpp"
#include "dds/test_domain.hpp"
#include "support/command.hpp"

namespace cdff::testing {

namespace fs = std::filesystem;

/// Starts `cdff ARGS...` with its output in `log`; returns its pid.
inline pid_t spawnCdff(const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::FILE* out = std::fopen(log.c_str(), "w");
    if (out != nullptr) {
      dup2(fileno(out), 1);
      dup2(fileno(out), 2);
    }
    std::vector<char*> argv{const_cast<char*>(CDFF_EXECUTABLE)};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(CDFF_EXECUTABLE, argv.data());
    _exit(127);
  }
  return pid;
}

/// Sends `signal` and returns the exit status (-1: ended by a signal).
inline int stopProcess(pid_t pid, int signal = SIGTERM) {
  kill(pid, signal);
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// Waits up to `timeout_s` for a process to exit; its exit status, or -2 when it still runs.
inline int waitForExit(pid_t pid, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    if (std::chrono::steady_clock::now() > deadline) return -2;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

inline std::string readFile(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// Waits until `text` appears in the file at `path` (a process's log); false after `timeout_s`.
inline bool waitForText(const fs::path& path, const std::string& text, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (readFile(path).find(text) == std::string::npos) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

struct Recorded {
  Timestamp stamp;
  std::vector<std::uint8_t> data;
  bool operator==(const Recorded&) const = default;
};

/// The messages of every channel under `prefix`, in the file's order (timing records left out).
inline std::map<std::string, std::vector<Recorded>> channelsOf(const fs::path& file,
                                                               const std::string& prefix) {
  io::Replay replay;
  EXPECT_TRUE(replay.open({file.string()}).isOk()) << file;
  std::map<std::string, std::vector<Recorded>> channels;
  while (replay.next()) {
    const io::ReplayMessage& m = replay.message();
    if (m.channel().rfind(prefix, 0) != 0 || m.channel().ends_with("/timing")) continue;
    channels[m.channel()].push_back({m.logTime(), {m.data().begin(), m.data().end()}});
  }
  EXPECT_TRUE(replay.status().isOk()) << replay.status().message();
  return channels;
}

/// 8 s of the far-range approach (a 256x256 camera at 2 Hz, the AHRS at 10 Hz, the radar) in
/// `dir`/sim.mcap, and `cdff run dfpcs/far_range_tracking.yaml` on it in `dir`/run.mcap. The
/// current directory becomes the repository (the graph's paths are relative to it).
inline void simulateFarRange(const fs::path& dir) {
  fs::current_path(CDFF_SOURCE_DIR);
  const std::string sim = (dir / "sim.mcap").string(), run = (dir / "run.mcap").string();
  auto r = runCdff(
      fmt::format("sim far_range_approach -q --duration 8 -o {} --set sensors.camera_far.rate=2 "
                  "--set sensors.camera_far.width=256 --set sensors.camera_far.height=256 "
                  "--set sensors.camera_far.supersampling=1",
                  sim));
  ASSERT_EQ(r.status, 0) << r.output;
  r = runCdff(fmt::format("run dfpcs/far_range_tracking.yaml -i {} -o {} -q", sim, run));
  ASSERT_EQ(r.status, 0) << r.output;
}

/// The bridge's --wait-for arguments: the far-range graph's input channels.
inline std::string waitForFarRangeInputs() {
  return "--wait-for /chaser/camera/far/image --wait-for /chaser/camera/far/calibration "
         "--wait-for /chaser/tf/camera_far_optical --wait-for /chaser/ahrs/attitude "
         "--wait-for /chaser/radar/measurement";
}

/// Publishes the measurements [first, first + n) of a target 10 m ahead of the camera moving at
/// 0.2 m/s along x, at 20 Hz, on /chaser/target_pose_measurement (what dfpcs/pose_filtering.yaml
/// reads), once a reader matched; waits until every reader acknowledged them.
inline void publishMeasurements(int domain, int first, int n) {
  auto participant = cdff::dds::Participant::create(domain);
  ASSERT_TRUE(participant.isOk());
  cdff::dds::Publisher publisher(**participant);
  const std::string channel = "/chaser/target_pose_measurement";
  ASSERT_TRUE(
      publisher.prepare(channel, cdff::TypeId::of<cdff::PoseWithCovariance>(), "target").isOk());
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (publisher.matchedReaders(channel) == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  for (int i = first; i < first + n; ++i) {
    cdff::PoseWithCovariance pose;
    pose.pose.stamp = 50'000 * i;
    pose.pose.parent_frame = "camera";
    pose.pose.child_frame = "target";
    pose.pose.translation = {0.01 * i, 0.0, 10.0};
    pose.covariance = cdff::Matrix6d::Identity() * 1e-4;
    ASSERT_TRUE(publisher.publish(cdff::dfpc::Message::of(channel, pose.pose.stamp, pose)).isOk());
  }
  ASSERT_TRUE(publisher.waitForAcknowledgements(10).isOk());
}

}  // namespace cdff::testing
