// The CDFF on the wire, three processes on a DDS domain of this test's own: `cdff bridge` plays
// a simulated far-range approach, `cdff node` runs dfpcs/far_range_tracking.yaml on what it
// receives, `cdff record` records the node's products and events. They are the products of
// `cdff run` on the same recording, bit for bit (the DFPC is deterministic; each product
// channel's samples come in the order the node published them). A malformed image published
// meanwhile by this test is an input_rejected event that says which channel and why.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cdff/dds/participant.hpp"
#include "cdff/dds/wire.hpp"
#include "cdff/io/replay.hpp"
#include "support/command.hpp"

namespace {

namespace fs = std::filesystem;
using cdff::testing::runCdff;

// Starts `cdff ARGS...` with its output in `log`; returns its pid.
pid_t spawnCdff(const std::vector<std::string>& args, const fs::path& log) {
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

// Sends SIGTERM and returns the exit status (-1: killed by a signal).
int stop(pid_t pid) {
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string readFile(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

struct Recorded {
  cdff::Timestamp stamp;
  std::vector<std::uint8_t> data;
  bool operator==(const Recorded&) const = default;
};

// The messages of every channel under `prefix`, in the file's order.
std::map<std::string, std::vector<Recorded>> channelsOf(const fs::path& file,
                                                        const std::string& prefix) {
  cdff::io::Replay replay;
  EXPECT_TRUE(replay.open({file.string()}).isOk()) << file;
  std::map<std::string, std::vector<Recorded>> channels;
  while (replay.next()) {
    const cdff::io::ReplayMessage& m = replay.message();
    if (m.channel().rfind(prefix, 0) != 0 || m.channel().ends_with("/timing")) continue;
    channels[m.channel()].push_back({m.logTime(), {m.data().begin(), m.data().end()}});
  }
  EXPECT_TRUE(replay.status().isOk()) << replay.status().message();
  return channels;
}

// A malformed image on the node's camera topic: 100 bytes for a 16x8 mono8 image.
void publishMalformedImage(int domain) {
  auto participant = cdff::dds::Participant::create(domain);
  ASSERT_TRUE(participant.isOk());
  auto topic =
      (*participant)->topic("rt/chaser/camera/far/image", &sensor_msgs_msg_dds__Image__desc);
  ASSERT_TRUE(topic.isOk());
  auto writer = (*participant)->createWriter(*topic, {});
  ASSERT_TRUE(writer.isOk());
  dds_publication_matched_status_t matched{};
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while ((dds_get_publication_matched_status(*writer, &matched), matched.current_count == 0) &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::vector<std::uint8_t> pixels(100);
  sensor_msgs_msg_dds__Image_ image{};
  image.header.stamp = cdff::dds::toRosTime(9'000'000);
  image.header.frame_id = const_cast<char*>("camera_far_optical");
  image.encoding = const_cast<char*>("mono8");
  image.width = image.step = 16;
  image.height = 8;
  image.data = {100, 100, pixels.data(), false};
  ASSERT_EQ(dds_write(*writer, &image), DDS_RETCODE_OK);
  ASSERT_EQ(dds_wait_for_acks(*writer, DDS_SECS(10)), DDS_RETCODE_OK);
}

TEST(DdsCommandLine, BridgeNodeRecordGiveTheProductsOfCdffRun) {
  const fs::path dir = cdff::testing::scratchDirectory("cdff_dds_node");
  fs::current_path(CDFF_SOURCE_DIR);  // the graph's paths are relative to the repository
  const int domain = 1 + static_cast<int>(::getpid() % cdff::dds::kMaxDomainId);
  const std::string sim = (dir / "sim.mcap").string(), run = (dir / "run.mcap").string(),
                    rec = (dir / "rec.mcap").string(), d = std::to_string(domain);
  // 8 s of the far-range approach: a 256x256 camera at 2 Hz, the AHRS at 10 Hz, the radar.
  auto r = runCdff(
      fmt::format("sim far_range_approach -q --duration 8 -o {} --set sensors.camera_far.rate=2 "
                  "--set sensors.camera_far.width=256 --set sensors.camera_far.height=256 "
                  "--set sensors.camera_far.supersampling=1",
                  sim));
  ASSERT_EQ(r.status, 0) << r.output;
  r = runCdff(fmt::format("run dfpcs/far_range_tracking.yaml -i {} -o {} -q", sim, run));
  ASSERT_EQ(r.status, 0) << r.output;

  const pid_t recorder = spawnCdff({"record", "-o", rec, "--domain", d, "/cdff/"}, dir / "rec.log");
  const pid_t node =
      spawnCdff({"node", "dfpcs/far_range_tracking.yaml", "--domain", d}, dir / "node.log");
  r = runCdff(fmt::format(
      "bridge {} --domain {} --speed 8 --wait-for /chaser/camera/far/image --wait-for "
      "/chaser/camera/far/calibration --wait-for /chaser/tf/camera_far_optical --wait-for "
      "/chaser/ahrs/attitude --wait-for /chaser/radar/measurement",
      sim, domain));
  EXPECT_EQ(r.status, 0) << r.output;
  publishMalformedImage(domain);
  EXPECT_EQ(stop(node), 0) << readFile(dir / "node.log");
  EXPECT_EQ(stop(recorder), 0) << readFile(dir / "rec.log");
  std::printf("%s%s%s", r.output.c_str(), readFile(dir / "node.log").c_str(),
              readFile(dir / "rec.log").c_str());

  const auto expected = channelsOf(run, "/cdff/far_range_tracking/");
  const auto received = channelsOf(rec, "/cdff/far_range_tracking/");
  ASSERT_EQ(expected.size(), 5u);  // bearing, match, score, state, designated
  for (const auto& [channel, messages] : expected) {
    SCOPED_TRACE(channel);
    ASSERT_TRUE(received.count(channel));
    EXPECT_EQ(received.at(channel).size(), messages.size());
    EXPECT_TRUE(received.at(channel) == messages) << "the products differ";
  }
  // The events of `cdff run`, then the rejection of the malformed image.
  const auto run_events = channelsOf(run, "/cdff/events").at("/cdff/events");
  const auto node_events = channelsOf(rec, "/cdff/events").at("/cdff/events");
  ASSERT_EQ(node_events.size(), run_events.size() + 1);
  std::vector<std::string> types;
  for (const Recorded& e : node_events) {
    const nlohmann::json record = nlohmann::json::parse(e.data.begin(), e.data.end());
    types.push_back(record["type"]);
    if (record["type"] != "input_rejected") continue;
    EXPECT_EQ(record["source"], "cdff node");
    EXPECT_EQ(e.stamp, 9'000'000);
    EXPECT_NE(record["message"].get<std::string>().find(
                  "channel '/chaser/camera/far/image' (sensor_msgs::msg::dds_::Image_): image "
                  "data holds 100 bytes; expected step * height = 16 * 8 = 128"),
              std::string::npos)
        << record.dump();
  }
  EXPECT_EQ(std::count(types.begin(), types.end(), "input_rejected"), 1);
}

}  // namespace
