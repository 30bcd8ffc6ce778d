// Faults on the wire (issue 25): a publisher that stops and a node killed and restarted.
//  - The bridge is killed (SIGKILL) in the middle of a far-range approach: the node notices the
//    departure when the bridge's lease expires (1.5 s here), publishes an input_lost event per
//    input channel that says so, keeps what it had (its products are those of `cdff run` up to
//    there) and finishes cleanly on SIGTERM (exit 0, its DFPCs' stopped events recorded).
//  - A node is killed (SIGKILL) while a recorder runs, and another is started: the recorder
//    keeps recording, and its file holds every product the first node published before it was
//    killed (that this test's own reader received too) and those of the second.
#include <stdlib.h>

#include <nlohmann/json.hpp>

#include "cdff/dds/api_service.hpp"
#include "cdff/dds/publisher.hpp"
#include "dds/cli_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace cdff::testing;
using nlohmann::json;

// The CDFF's Cyclone configuration with a 1.5 s participant lease (announced every 0.3 s), so
// that a killed process is noticed in 1.5 s instead of Cyclone's 10 s; for every process here.
void shortLeases() {
  std::string config = cdff::dds::kDefaultConfiguration;
  const std::string discovery =
      "<Discovery><LeaseDuration>1.5s</LeaseDuration><SPDPInterval>0.3s</SPDPInterval>"
      "</Discovery>";
  config.insert(config.find("<Internal>"), discovery);
  setenv("CYCLONEDDS_URI", config.c_str(), 1);
}

std::vector<json> eventsOf(const fs::path& rec) {
  std::vector<json> events;
  auto channels = channelsOf(rec, "/cdff/events");  // kept: the loop reads into it
  for (const Recorded& e : channels["/cdff/events"])
    events.push_back(json::parse(e.data.begin(), e.data.end()));
  return events;
}

TEST(DdsFaults, ABridgeKilledMidStreamIsAnInputLostAndTheNodeFinishesCleanly) {
  const fs::path dir = scratchDirectory("cdff_dds_faults");
  simulateFarRange(dir);
  shortLeases();
  const int domain = claimTestDomain();
  const std::string d = std::to_string(domain), rec = (dir / "rec.mcap").string();
  const pid_t recorder = spawnCdff({"record", "-o", rec, "--domain", d, "/cdff/"}, dir / "rec.log");
  const pid_t node =
      spawnCdff({"node", "dfpcs/far_range_tracking.yaml", "--domain", d}, dir / "node.log");
  // 8 s of stream at 4x: killed after about half of it.
  std::vector<std::string> bridge_args{
      "bridge", (dir / "sim.mcap").string(), "--domain", d, "--speed", "4"};
  for (const char* c : {"/chaser/camera/far/image", "/chaser/camera/far/calibration",
                        "/chaser/tf/camera_far_optical", "/chaser/ahrs/attitude"}) {
    bridge_args.push_back("--wait-for");
    bridge_args.push_back(c);
  }
  const pid_t bridge = spawnCdff(bridge_args, dir / "bridge.log");
  ASSERT_TRUE(waitForText(dir / "node.log", "external API on", 20)) << readFile(dir / "node.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  EXPECT_EQ(stopProcess(bridge, SIGKILL), -1);
  ASSERT_TRUE(waitForText(dir / "node.log", "input lost: channel '/chaser/camera/far/image'", 10))
      << readFile(dir / "node.log");
  EXPECT_EQ(stopProcess(node), 0) << readFile(dir / "node.log");
  EXPECT_EQ(stopProcess(recorder), 0) << readFile(dir / "rec.log");
  std::printf("%s", readFile(dir / "node.log").c_str());

  // Every product is the one `cdff run` made at the same place: the node's are a prefix.
  const auto expected = channelsOf(dir / "run.mcap", "/cdff/far_range_tracking/");
  const auto received = channelsOf(rec, "/cdff/far_range_tracking/");
  const auto& bearings = received.at("/cdff/far_range_tracking/bearing");
  EXPECT_GT(bearings.size(), 0u);
  EXPECT_LT(bearings.size(), expected.at("/cdff/far_range_tracking/bearing").size());
  for (const auto& [channel, messages] : received) {
    SCOPED_TRACE(channel);
    ASSERT_LE(messages.size(), expected.at(channel).size());
    for (std::size_t i = 0; i < messages.size(); ++i)
      ASSERT_TRUE(messages[i] == expected.at(channel)[i]) << i;
  }
  // The events say why nothing more came, then the DFPC stopped cleanly.
  std::vector<std::string> lost;
  std::string last_type;
  for (const json& e : eventsOf(rec)) {
    last_type = e["type"];
    if (e["type"] == "input_lost") lost.push_back(e["message"]);
  }
  EXPECT_EQ(last_type, "stopped");
  // image, calibration, camera mount, attitude, radar, IMU and its mount
  EXPECT_EQ(lost.size(), 7u);
  for (const std::string& message : lost)
    EXPECT_NE(message.find("1 publisher(s) left, 0 remain; nothing more comes until one joins"),
              std::string::npos)
        << message;
}

constexpr const char* kState = "/cdff/pose_filtering/state";

// The node's product count, once it has processed `messages` measurements (by the API).
int productsAfter(int domain, int messages) {
  json status;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  do {
    const auto r = runCdff(fmt::format("api getDFPCStatus pose_filtering --domain {}", domain));
    EXPECT_EQ(r.status, 0) << r.output;
    if (r.status != 0) return -1;
    status = json::parse(r.output);
  } while (status["messages"] != messages && std::chrono::steady_clock::now() < deadline);
  EXPECT_EQ(status["messages"], messages) << status.dump();
  return status["products"];
}

// Takes what this test's own reader of the state channel received (the witness: transient
// local, like the recorder's reader of a node's products), until none came for 0.5 s.
int takeStates(dds_entity_t witness) {
  int n = 0;
  auto quiet_since = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - quiet_since < std::chrono::milliseconds(500)) {
    void* samples[16] = {};
    dds_sample_info_t infos[16];
    const dds_return_t taken = dds_take(witness, samples, infos, 16, 16);
    EXPECT_GE(taken, 0);
    for (dds_return_t i = 0; i < taken; ++i) n += infos[i].valid_data ? 1 : 0;
    if (taken > 0) {
      dds_return_loan(witness, samples, taken);
      quiet_since = std::chrono::steady_clock::now();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return n;
}

// Waits until the recorder's last --progress line in `log` counts at least `count` messages on
// `channel` (what its reader has acknowledged and written); false on the timeout.
bool waitForRecorded(const fs::path& log, const std::string& channel, int count, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  const std::string key = ", " + channel + " ";
  do {
    const std::string text = readFile(log);
    const std::size_t line = text.rfind("recorded ");
    const std::size_t at = line == std::string::npos ? line : text.find(key, line);
    if (at != std::string::npos && std::atoi(text.c_str() + at + key.size()) >= count) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  } while (std::chrono::steady_clock::now() < deadline);
  return false;
}

TEST(DdsFaults, ANodeKilledAndRestartedLosesNothingTheRecorderAcknowledged) {
  const fs::path dir = scratchDirectory("cdff_dds_restart");
  fs::current_path(CDFF_SOURCE_DIR);
  shortLeases();
  const int domain = claimTestDomain();
  const std::string d = std::to_string(domain), rec = (dir / "rec.mcap").string();
  const pid_t recorder = spawnCdff(
      {"record", "-o", rec, "--domain", d, "--progress", "0.1", "/cdff/"}, dir / "rec.log");
  auto participant = cdff::dds::Participant::create(domain);
  ASSERT_TRUE(participant.isOk());
  auto topic =
      (*participant)->topic("rt/cdff/pose_filtering/state", &cdff_msgs_msg_dds__Record__desc);
  ASSERT_TRUE(topic.isOk());
  auto witness = (*participant)->createReader(*topic, {cdff::dds::Durability::kTransientLocal});
  ASSERT_TRUE(witness.isOk());

  int states[2] = {0, 0};
  for (int run = 0; run < 2; ++run) {
    const fs::path log = dir / fmt::format("node{}.log", run);
    const pid_t node = spawnCdff({"node", "dfpcs/pose_filtering.yaml", "--domain", d}, log);
    ASSERT_TRUE(waitForText(log, "external API on", 20)) << readFile(log);
    publishMeasurements(domain, 20 * run, 20);
    ASSERT_GT(productsAfter(domain, 20), 0);
    // What the witness received was sent to the recorder too (reliable, same writer); the node
    // is stopped once the recorder says it has them (its reader has acknowledged them).
    states[run] = takeStates(*witness);
    ASSERT_GT(states[run], 0);
    ASSERT_TRUE(waitForRecorded(dir / "rec.log", kState, states[0] + states[1], 20))
        << readFile(dir / "rec.log");
    if (run == 0)
      EXPECT_EQ(stopProcess(node, SIGKILL), -1);  // killed: no stopped event, no flush
    else
      EXPECT_EQ(stopProcess(node), 0) << readFile(log);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(stopProcess(recorder), 0) << readFile(dir / "rec.log");
  const auto recorded = channelsOf(rec, "/cdff/pose_filtering/");
  EXPECT_EQ(recorded.at(kState).size(), static_cast<std::size_t>(states[0] + states[1]))
      << readFile(dir / "rec.log");
  // The first node's states, then the second's (fresh DFPCs: their first state restarts).
  std::vector<std::string> types;
  for (const json& e : eventsOf(rec)) types.push_back(e["type"]);
  EXPECT_EQ(std::count(types.begin(), types.end(), "started"), 2);
  EXPECT_EQ(std::count(types.begin(), types.end(), "stopped"), 1);  // the killed node's: none
}

}  // namespace
