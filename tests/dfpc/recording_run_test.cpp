// `cdff run` end to end over MCAP files: dfpcs/pose_filtering.yaml on a recorded relative
// trajectory, the output read back with the recording library; a damaged input; the command's
// exit statuses and messages.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <nlohmann/json.hpp>

#include "cdff/dfpc/recording_streams.hpp"
#include "cdff/dfpc/replay.hpp"
#include "cdff/io/replay.hpp"
#include "support/command.hpp"
#include "test_helpers.hpp"

namespace cdff::dfpc {
namespace {

namespace fs = std::filesystem;
const std::string kGraph = std::string(CDFF_SOURCE_DIR) + "/dfpcs/pose_filtering.yaml";
constexpr double kSigmaPosition = 0.05;  // m, per axis
constexpr double kSigmaAngle = 1.0 * M_PI / 180.0;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "cdff_recording_run_test";
  fs::create_directories(dir);
  return dir / name;
}

Eigen::Vector3d truePosition(double t) {
  return {1.0 + 0.05 * t, -0.5, 10.0 - 0.02 * t};
}
Eigen::Quaterniond trueRotation(double t) {
  return expSO3(Eigen::Vector3d(1, 2, 0.5).normalized() * (2.0 * M_PI / 180.0) * t);
}

// 20 s at 10 Hz: noisy pose measurements, the truth, and a camera model that no DFPC reads (it
// must be neither replayed into the output nor in the way).
void writeInput(const fs::path& path, double duration_s = 20.0, std::size_t chunk_size = 4 << 20) {
  io::Recorder rec;
  io::McapWriterOptions options;
  options.chunk_size = chunk_size;
  ASSERT_OK(rec.open(path.string(), options));
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; 0.1 * k <= duration_s + 1e-9; ++k) {
    const double t = 0.1 * k;
    PoseWithCovariance z{Transform::identity("servicer", "target", fromSeconds(t)),
                         Matrix6d::Zero()};
    z.pose.translation = truePosition(t) + kSigmaPosition * Eigen::Vector3d(n(rng), n(rng), n(rng));
    z.pose.rotation =
        expSO3(kSigmaAngle * Eigen::Vector3d(n(rng), n(rng), n(rng))) * trueRotation(t);
    z.covariance.diagonal() << Eigen::Vector3d::Constant(kSigmaPosition * kSigmaPosition),
        Eigen::Vector3d::Constant(kSigmaAngle * kSigmaAngle);
    ASSERT_OK(rec.write("/chaser/target_pose_measurement", z));
    PoseWithCovariance truth{Transform::identity("servicer", "target", fromSeconds(t)),
                             Matrix6d::Zero()};
    truth.pose.translation = truePosition(t);
    truth.pose.rotation = trueRotation(t);
    ASSERT_OK(rec.write("/truth/target_pose", truth));
    CameraModel camera;
    ASSERT_OK(
        rec.writeCalibration("/chaser/camera/left/camera_info", camera, fromSeconds(t), "camera"));
  }
  ASSERT_OK(rec.close());
}

struct Output {
  std::map<std::string, std::uint64_t> counts;
  std::vector<nlohmann::json> events, timings;
  double position_rmse = 0, angle_rmse = 0;
};

// Reads a run's output back and measures the state products against the copied truth.
Output readOutput(const fs::path& path) {
  Output out;
  io::Replay replay;
  EXPECT_OK(replay.open({path.string()}));
  std::map<Timestamp, PoseWithCovariance> truth;
  std::vector<RigidBodyState> states;
  while (replay.next()) {
    const io::ReplayMessage& m = replay.message();
    ++out.counts[m.channel()];
    if (m.channel() == "/cdff/events") out.events.push_back(*m.decode<nlohmann::json>().value());
    if (m.channel() == "/cdff/pose_filtering/timing")
      out.timings.push_back(*m.decode<nlohmann::json>().value());
    if (m.channel() == "/truth/target_pose")
      truth[m.logTime()] = *m.decode<PoseWithCovariance>().value();
    if (m.channel() == "/cdff/pose_filtering/state")
      states.push_back(*m.decode<RigidBodyState>().value());
  }
  EXPECT_OK(replay.status());
  double p2 = 0, r2 = 0;
  int n = 0;
  for (const RigidBodyState& x : states) {
    auto t = truth.find(x.pose.stamp);
    if (t == truth.end() || x.pose.stamp < fromSeconds(5)) continue;  // after convergence
    p2 += (x.pose.translation - t->second.pose.translation).squaredNorm();
    r2 += logSO3(x.pose.rotation * t->second.pose.rotation.conjugate()).squaredNorm();
    ++n;
  }
  if (n > 0) {
    out.position_rmse = std::sqrt(p2 / n);
    out.angle_rmse = std::sqrt(r2 / n);
  }
  return out;
}

TEST(RecordingRun, PoseFilteringFromOneRecordingIntoAnother) {
  const fs::path in = scratch("pose_in.mcap"), out = scratch("pose_out.mcap");
  writeInput(in);
  McapInputStream input;
  ASSERT_OK(input.open({in.string()}));
  // Every channel of the input is a port type, so all three are replayed.
  EXPECT_EQ(input.channels().size(), 3u);
  EXPECT_TRUE(input.skippedChannels().empty());
  McapSink sink;
  ASSERT_OK(sink.open(out.string()));
  ReplayOptions options;
  options.graph_files = {kGraph};
  Result<ReplayResult> result = replay(input, sink, options);
  ASSERT_OK(result.status());
  ASSERT_OK(sink.close());

  const Output o = readOutput(out);
  // 201 measurements; the truth copied, the camera model not (not under /truth/).
  EXPECT_EQ(o.counts.at("/truth/target_pose"), 201u);
  EXPECT_EQ(o.counts.count("/chaser/camera/left/camera_info"), 0u);
  EXPECT_EQ(o.counts.count("/chaser/target_pose_measurement"), 0u);
  // A state per measurement and per 50 ms tick in between (20 s -> about 400); all recorded.
  EXPECT_GE(o.counts.at("/cdff/pose_filtering/state"), 390u);
  EXPECT_EQ(o.counts.at("/cdff/pose_filtering/state") + o.counts.at("/cdff/pose_filtering/nis"),
            result->summary.products);
  // The filtered states are better than the measurements (RMSE of 3 axes: 8.7 cm, 1.7 deg).
  EXPECT_LT(o.position_rmse, 0.5 * std::sqrt(3.0) * kSigmaPosition);
  EXPECT_LT(o.angle_rmse, 0.5 * std::sqrt(3.0) * kSigmaAngle);
  // One timing record per EKF call, with the documented fields.
  ASSERT_FALSE(o.timings.empty());
  EXPECT_EQ(o.timings.size(), result->dfpcs.at(0).instances.at(0).calls);
  EXPECT_EQ(o.counts.at("/cdff/pose_filtering/nis"), o.timings.size());  // one per EKF call
  for (const char* key : {"timestamp", "dfn", "dfn_type", "dfi", "wall_s", "cpu_s", "status"})
    EXPECT_TRUE(o.timings.front().contains(key)) << key;
  EXPECT_EQ(o.timings.front()["dfn"], "ekf");
  EXPECT_EQ(o.timings.front()["dfi"], "ExtendedKalman");
  // Events: at least the DFPC's start, with level, source, kind and type.
  ASSERT_FALSE(o.events.empty());
  bool started = false;
  for (const nlohmann::json& e : o.events) {
    for (const char* key : {"timestamp", "level", "source", "kind", "type", "message"})
      EXPECT_TRUE(e.contains(key)) << e.dump();
    started |= e["type"] == "started" && e["dfpc"] == "pose_filtering";
  }
  EXPECT_TRUE(started);
  // The end of the input stops the DFPC: the recording says so, at the last stream time.
  EXPECT_EQ(o.events.back()["type"], "stopped");
  EXPECT_EQ(o.events.back()["dfpc"], "pose_filtering");
  const nlohmann::json& stop_time = o.events.back()["timestamp"];
  EXPECT_EQ(
      stop_time["sec"].get<Timestamp>() * 1'000'000 + stop_time["nsec"].get<Timestamp>() / 1000,
      *result->summary.last);
  EXPECT_EQ(result->dfpcs.at(0).state, DfpcState::kStopped);
  // The graph declares no track state, so none is reported.
  EXPECT_FALSE(result->dfpcs.at(0).track_state.has_value());
  EXPECT_EQ(o.events.size(), result->summary.events);
}

TEST(RecordingRun, ADamagedInputStopsWithWhereAndKeepsEverythingBefore) {
  const fs::path in = scratch("damaged_in.mcap"), out = scratch("damaged_out.mcap");
  writeInput(in, 20.0, 16 << 10);  // small chunks: many of them survive the cut
  const auto size = fs::file_size(in);
  fs::resize_file(in, size / 2);  // a writer killed half way
  McapInputStream input;
  ASSERT_OK(input.open({in.string()}));
  McapSink sink;
  ASSERT_OK(sink.open(out.string()));
  ReplayOptions options;
  options.graph_files = {kGraph};
  Result<ReplayResult> result = replay(input, sink, options);
  ASSERT_FALSE(result.isOk());
  EXPECT_NE(result.status().message().find("damaged"), std::string::npos)
      << result.status().message();
  EXPECT_NE(result.status().message().find("byte"), std::string::npos) << result.status().message();
  ASSERT_OK(sink.close());
  Output o = readOutput(out);
  // The recoverable first part was replayed and its products kept.
  EXPECT_GT(o.counts["/truth/target_pose"], 40u);
  EXPECT_LT(o.counts["/truth/target_pose"], 201u);
  EXPECT_GT(o.counts["/cdff/pose_filtering/state"], 40u);
}

// Every registered type has a recording encoding: a product of any type is recorded, and read back
// as the same type.
TEST(RecordingRun, ProductsOfEveryKindAreRecorded) {
  McapSink sink;
  const fs::path out = scratch("every_kind.mcap");
  ASSERT_OK(sink.open(out.string()));
  ASSERT_OK(sink.writeMessage(Message::of("/cdff/x/samples", 10, ContourSamples{})));
  ASSERT_OK(sink.writeMessage(Message::of("/cdff/x/samples", 20, ContourSamples{})));
  ASSERT_OK(sink.writeMessage(Message::of("/cdff/x/state", 20, TrackState::kTracking)));
  ASSERT_OK(sink.writeMessage(Message::of("/cdff/x/value", 20, 1.5)));
  ASSERT_OK(sink.close());
  const Output o = readOutput(out);
  EXPECT_EQ(o.counts.at("/cdff/x/samples"), 2u);
  EXPECT_EQ(o.counts.at("/cdff/x/state"), 1u);
  EXPECT_EQ(o.counts.at("/cdff/x/value"), 1u);
  EXPECT_TRUE(o.events.empty());
}

// ---------------------------------------------------------------------------------------------
// The command

using cdff::testing::CommandResult;
using cdff::testing::runCdff;

TEST(RunCommand, RecordsProductsAndSaysWhatItDid) {
  const fs::path in = scratch("cmd_in.mcap"), out = scratch("cmd_out.mcap");
  writeInput(in, 5.0);
  const CommandResult r = runCdff(
      fmt::format("run {} -i {} -o {} --compression zstd", kGraph, in.string(), out.string()));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("153 messages read"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("pose_filtering: stopped"), std::string::npos) << r.output;
  const Output o = readOutput(out);
  EXPECT_EQ(o.counts.at("/truth/target_pose"), 51u);
  EXPECT_GT(o.counts.at("/cdff/pose_filtering/state"), 90u);
}

TEST(RunCommand, RealTimeAtHighSpeedAndAWindow) {
  const fs::path in = scratch("cmd_rt_in.mcap"), out = scratch("cmd_rt_out.mcap");
  writeInput(in, 5.0);
  const CommandResult r =
      runCdff(fmt::format("run {} -i {} -o {} --realtime --speed 50 "
                          "--start 1 --end 3 --no-timing -q",
                          kGraph, in.string(), out.string()));
  ASSERT_EQ(r.status, 0) << r.output;
  const Output o = readOutput(out);
  EXPECT_EQ(o.counts.at("/truth/target_pose"), 21u);  // 1.0 s .. 3.0 s inclusive
  EXPECT_EQ(o.counts.count("/cdff/pose_filtering/timing"), 0u);
}

// `--set` changes an instance's parameter for one run: a process noise 10^4 times the graph's
// makes the filter follow the measurements' noise.
TEST(RunCommand, SetChangesAParameterWithoutEditingTheGraph) {
  const fs::path in = scratch("cmd_set_in.mcap"), plain = scratch("cmd_set_plain.mcap"),
                 set = scratch("cmd_set_set.mcap");
  writeInput(in, 10.0);
  CommandResult r =
      runCdff(fmt::format("run {} -i {} -o {} -q", kGraph, in.string(), plain.string()));
  ASSERT_EQ(r.status, 0) << r.output;
  r =
      runCdff(fmt::format("run {} -i {} -o {} -q --set ekf.linear_acceleration_psd=1.0 "
                          "--set pose_filtering/ekf.angular_acceleration_psd=0.1",
                          kGraph, in.string(), set.string()));
  ASSERT_EQ(r.status, 0) << r.output;
  const Output a = readOutput(plain), b = readOutput(set);
  EXPECT_EQ(a.counts.at("/cdff/pose_filtering/state"), b.counts.at("/cdff/pose_filtering/state"));
  EXPECT_GT(b.position_rmse, 1.5 * a.position_rmse);
  EXPECT_GT(b.angle_rmse, 1.5 * a.angle_rmse);
}

TEST(RunCommand, BadInputGetsAClearErrorAndANonZeroStatus) {
  const fs::path in = scratch("cmd_bad_in.mcap"), out = scratch("cmd_bad_out.mcap");
  writeInput(in, 1.0);
  struct Case {
    std::string arguments, expected;
    int status;
  };
  const std::string missing = scratch("does_not_exist.mcap").string();
  const std::vector<Case> cases = {
      {fmt::format("run {} -i {} -o {}", kGraph, missing, out.string()), missing, 1},
      {fmt::format("run /nonexistent/graph.yaml -i {} -o {}", in.string(), out.string()),
       "/nonexistent/graph.yaml", 1},
      {fmt::format("run {} -i {} -o {} --map nonsense", kGraph, in.string(), out.string()),
       "nonsense", 2},
      {fmt::format("run {} -i {} -o {} --map pose_filtering.pose=/no/such/channel", kGraph,
                   in.string(), out.string()),
       "/no/such/channel", 1},
      {fmt::format("run {} -i {} -o {} --compression brotli", kGraph, in.string(), out.string()),
       "brotli", 2},
      {fmt::format("run {} -i {} -o /nonexistent/dir/out.mcap", kGraph, in.string()),
       "/nonexistent/dir/out.mcap", 1},
      {fmt::format("run {} -i {}", kGraph, in.string()), "--output", 2},
      {fmt::format("run {} -i {} -o {} --set ekf", kGraph, in.string(), out.string()),
       "--set ekf: expected [DFPC/]NODE.PARAMETER=VALUE", 2},
      {fmt::format("run {} -i {} -o {} --set ekff.position_sigma=1", kGraph, in.string(),
                   out.string()),
       "--set ekff.position_sigma=1: no DFPC graph has a node 'ekff'; expected one of {ekf} "
       "(did you mean 'ekf'?)",
       1},
      {fmt::format("run {} -i {} -o {} --set lidar/ekf.position_sigma=1", kGraph, in.string(),
                   out.string()),
       "no DFPC 'lidar' is run; expected one of {pose_filtering}", 1},
      {fmt::format("run {} -i {} -o {} --set ekf.position_sigma=-1", kGraph, in.string(),
                   out.string()),
       "position_sigma = -1: out of range", 1},
      {fmt::format("run {} -i {} -o {} --pair /p=/left", kGraph, in.string(), out.string()),
       "--pair: stereo pairing '/p=/left': expected CHANNEL=LEFT,RIGHT", 2},
      {fmt::format("run {} -i {} -o {} --run-while pose_filtering=x:LOSING", kGraph, in.string(),
                   out.string()),
       "'LOSING' is not a track state", 2},
      {fmt::format("run {} -i {} -o {} --run-while pose_filtering=tracking:LOST", kGraph,
                   in.string(), out.string()),
       "run-while rule: no DFPC 'tracking'; expected one of {pose_filtering}", 1},
      {fmt::format("run {} -i {} -o {} --roi 1,2,3@0", kGraph, in.string(), out.string()),
       "--roi: designation '1,2,3@0': 3 numbers before '@'; expected X,Y,W,H@TIME", 2},
      {fmt::format("run {} -i {} -o {} --roi 10,20,0,5@1", kGraph, in.string(), out.string()),
       "size 0x5; expected X,Y,W,H@TIME", 2},
      {fmt::format("run {} -i {} -o {} --roi 10,20,8,8", kGraph, in.string(), out.string()),
       "no '@TIME'", 2},
  };
  for (const Case& c : cases) {
    const CommandResult r = runCdff(c.arguments);
    EXPECT_EQ(r.status, c.status) << c.arguments << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.arguments << "\n" << r.output;
  }
}

}  // namespace
}  // namespace cdff::dfpc
