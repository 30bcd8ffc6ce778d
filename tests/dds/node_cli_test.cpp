// The CDFF on the wire, three processes on a DDS domain of this test's own: `cdff bridge` plays
// a simulated far-range approach, `cdff node` runs dfpcs/far_range_tracking.yaml on what it
// receives, `cdff record` records the node's products and events. They are the products of
// `cdff run` on the same recording, bit for bit (the DFPC is deterministic; each product
// channel's samples come in the order the node published them), with ROS 2 messages and with
// the ESROCOS ASN.1 types in uPER (`--encoding asn1-uper` on the bridge and the node). A
// malformed sample published meanwhile by this test is an input_rejected event that says which
// channel and why.
#include <algorithm>
#include <functional>

#include <nlohmann/json.hpp>

#include "cdff/asn1/uper.hpp"
#include "cdff/dds/wire.hpp"
#include "dds/cli_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace cdff::testing;

// Waits until `writer` has a reader, writes `sample` and waits for its acknowledgement.
void writeWhenMatched(dds_entity_t writer, const void* sample) {
  dds_publication_matched_status_t matched{};
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while ((dds_get_publication_matched_status(writer, &matched), matched.current_count == 0) &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_EQ(dds_write(writer, sample), DDS_RETCODE_OK);
  ASSERT_EQ(dds_wait_for_acks(writer, DDS_SECS(10)), DDS_RETCODE_OK);
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
  std::vector<std::uint8_t> pixels(100);
  sensor_msgs_msg_dds__Image_ image{};
  image.header.stamp = cdff::dds::toRosTime(9'000'000);
  image.header.frame_id = const_cast<char*>("camera_far_optical");
  image.encoding = const_cast<char*>("mono8");
  image.width = image.step = 16;
  image.height = 8;
  image.data = {100, 100, pixels.data(), false};
  writeWhenMatched(*writer, &image);
}

// A truncated uPER attitude on the node's attitude topic (a Record in asn1-uper): the first
// half of a TransformWithCovariance's bytes. Returns the size sent.
std::size_t publishTruncatedUperPose(int domain) {
  cdff::PoseWithCovariance pose;
  pose.pose.stamp = 9'000'000;
  pose.pose.parent_frame = "lvlh";
  pose.pose.child_frame = "servicer";
  pose.covariance = cdff::Matrix6d::Identity() * 1e-4;
  auto bytes = cdff::asn1::encode(cdff::Value::of(pose));
  EXPECT_TRUE(bytes.isOk()) << bytes.status().message();
  if (!bytes) return 0;
  bytes->resize(bytes->size() / 2);
  auto participant = cdff::dds::Participant::create(domain);
  EXPECT_TRUE(participant.isOk());
  auto topic = (*participant)->topic("rt/chaser/ahrs/attitude", &cdff_msgs_msg_dds__Record__desc);
  EXPECT_TRUE(topic.isOk());
  auto writer = (*participant)->createWriter(*topic, {});
  EXPECT_TRUE(writer.isOk());
  cdff_msgs_msg_dds__Record_ record{};
  record.header.stamp = cdff::dds::toRosTime(9'000'000);
  record.header.frame_id = const_cast<char*>("");
  record.type_name = const_cast<char*>("TransformWithCovariance");
  record.encoding = const_cast<char*>("asn1-uper");
  const auto size = static_cast<std::uint32_t>(bytes->size());
  record.data = {size, size, bytes->data(), false};
  writeWhenMatched(*writer, &record);
  return bytes->size();
}

// The type name and encoding of a Record that the node keeps on `topic` (transient-local).
std::pair<std::string, std::string> latestRecord(int domain, const std::string& topic_name) {
  auto participant = cdff::dds::Participant::create(domain);
  EXPECT_TRUE(participant.isOk());
  auto topic = (*participant)->topic(topic_name, &cdff_msgs_msg_dds__Record__desc);
  EXPECT_TRUE(topic.isOk());
  auto reader = (*participant)->createReader(*topic, {cdff::dds::Durability::kTransientLocal});
  EXPECT_TRUE(reader.isOk());
  void* samples[1] = {};
  dds_sample_info_t info{};
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < deadline) {
    if (dds_take(*reader, samples, &info, 1, 1) == 1 && info.valid_data) {
      const auto* record = static_cast<const cdff_msgs_msg_dds__Record_*>(samples[0]);
      std::pair<std::string, std::string> out{record->type_name, record->encoding};
      dds_return_loan(*reader, samples, 1);
      return out;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ADD_FAILURE() << "no sample on " << topic_name;
  return {};
}

class DdsCommandLine : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = scratchDirectory("cdff_dds_node");
    simulateFarRange(dir_);
  }

  // bridge -> node -> record with `encoding`; `malformed` publishes a sample the node rejects
  // before it stops (and returns what the rejection must say). The recording's path.
  fs::path runChain(const std::string& encoding, const std::function<std::string(int)>& malformed,
                    std::string& rejection) {
    const int domain = claimTestDomain();
    const std::string d = std::to_string(domain), rec = (dir_ / (encoding + ".mcap")).string();
    const fs::path node_log = dir_ / (encoding + "_node.log");
    const pid_t recorder =
        spawnCdff({"record", "-o", rec, "--domain", d, "/cdff/"}, dir_ / (encoding + "_rec.log"));
    const pid_t node = spawnCdff(
        {"node", "dfpcs/far_range_tracking.yaml", "--domain", d, "--encoding", encoding}, node_log);
    const auto r = runCdff(fmt::format("bridge {} --domain {} --speed 8 --encoding {} {}",
                                       (dir_ / "sim.mcap").string(), domain, encoding,
                                       waitForFarRangeInputs()));
    EXPECT_EQ(r.status, 0) << r.output;
    rejection = malformed(domain);
    EXPECT_EQ(stopProcess(node), 0) << readFile(node_log);
    EXPECT_EQ(stopProcess(recorder), 0) << readFile(dir_ / (encoding + "_rec.log"));
    std::printf("%s%s", r.output.c_str(), readFile(node_log).c_str());
    return rec;
  }

  // Every product channel of `cdff run`, equal message for message, and its events plus one
  // input_rejected that says `rejection` (and input_lost events when the publishers leave).
  static void expectTheProductsOfCdffRun(const fs::path& rec, const std::string& rejection) {
    const fs::path run = dir_ / "run.mcap";
    const auto expected = channelsOf(run, "/cdff/far_range_tracking/");
    const auto received = channelsOf(rec, "/cdff/far_range_tracking/");
    ASSERT_EQ(expected.size(), 5u);  // bearing, match, score, state, designated
    for (const auto& [channel, messages] : expected) {
      SCOPED_TRACE(channel);
      ASSERT_TRUE(received.count(channel));
      EXPECT_EQ(received.at(channel).size(), messages.size());
      EXPECT_TRUE(received.at(channel) == messages) << "the products differ";
    }
    const auto run_events = channelsOf(run, "/cdff/events").at("/cdff/events");
    const auto node_events = channelsOf(rec, "/cdff/events").at("/cdff/events");
    std::vector<std::string> types;
    for (const Recorded& e : node_events) {
      const nlohmann::json record = nlohmann::json::parse(e.data.begin(), e.data.end());
      // The bridge and the test's publisher leave before the node stops: input_lost events.
      if (record["type"] == "input_lost") continue;
      types.push_back(record["type"]);
      if (record["type"] != "input_rejected") continue;
      EXPECT_EQ(record["source"], "cdff node");
      EXPECT_EQ(e.stamp, 9'000'000);
      EXPECT_NE(record["message"].get<std::string>().find(rejection), std::string::npos)
          << record.dump() << "\nexpected: " << rejection;
    }
    EXPECT_EQ(types.size(), run_events.size() + 1);
    EXPECT_EQ(std::count(types.begin(), types.end(), "input_rejected"), 1);
    EXPECT_GT(node_events.size(), types.size());  // input_lost
  }

  static inline fs::path dir_;
};

TEST_F(DdsCommandLine, BridgeNodeRecordGiveTheProductsOfCdffRun) {
  std::string rejection;
  const fs::path rec = runChain(
      "ros2",
      [](int domain) {
        publishMalformedImage(domain);
        return std::string(
            "channel '/chaser/camera/far/image' (sensor_msgs::msg::dds_::Image_): image data "
            "holds 100 bytes; expected step * height = 16 * 8 = 128");
      },
      rejection);
  expectTheProductsOfCdffRun(rec, rejection);
}

// The images, cameras, transforms, attitudes, bearings and states travel as uPER Records: the
// products are still bit for bit those of `cdff run`, and a truncated uPER value is rejected.
TEST_F(DdsCommandLine, Asn1UperEncodingGivesTheProductsOfCdffRun) {
  std::string rejection;
  const fs::path rec = runChain(
      "asn1-uper",
      [](int domain) {
        // The node's bearings and states are uPER Records on the wire.
        for (const auto& [channel, type] :
             {std::pair{"bearing", "Bearing"}, {"state", "RigidBodyState"}}) {
          const auto [type_name, encoding] =
              latestRecord(domain, fmt::format("rt/cdff/far_range_tracking/{}", channel));
          EXPECT_EQ(type_name, type);
          EXPECT_EQ(encoding, "asn1-uper");
        }
        const std::size_t size = publishTruncatedUperPose(domain);
        return fmt::format(
            "channel '/chaser/ahrs/attitude' (cdff_msgs::msg::dds_::Record_): record of ASN.1 "
            "type 'TransformWithCovariance' (asn1-uper): uPER TransformWithCovariance of {} "
            "bytes: truncated: the bytes end inside the value",
            size);
      },
      rejection);
  expectTheProductsOfCdffRun(rec, rejection);
}

}  // namespace
