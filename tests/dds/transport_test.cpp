// Publish and subscribe through Cyclone DDS in one process (two participants on a domain of this
// test's own): every converted type arrives as it left, an image with its camera model, a pose
// with its child frame; a late reader gets a transient-local writer's history; a malformed
// sample is a rejection that says what and where, and the others still arrive.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include <gtest/gtest.h>

#include "cdff/dds/streams.hpp"
#include "dds/test_domain.hpp"
#include "samples.hpp"

namespace cdff::dds {
namespace {

constexpr Timestamp kStamp = 5'000'000;

// One domain for this test process, of its own (concurrent tests do not hear each other).
int testDomain() {
  static const int domain = cdff::testing::claimTestDomain();
  return domain;
}

std::vector<std::uint8_t> messageOf(const Value& v) {
  codec::Encoded e;
  EXPECT_TRUE(v.type().info().encode(v.raw(), kStamp, e).isOk());
  return e.flatten();
}

std::unique_ptr<Participant> participant() {
  Result<std::unique_ptr<Participant>> p = Participant::create(testDomain());
  EXPECT_TRUE(p.isOk()) << p.status().message();
  return p ? std::move(p).value() : nullptr;
}

// Polls until `count` messages came (or 10 s passed).
std::vector<dfpc::Message> receive(Subscriber& subscriber, std::size_t count,
                                   std::vector<Rejection>* rejections = nullptr) {
  std::vector<dfpc::Message> messages;
  std::vector<Rejection> rejected;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (messages.size() + rejected.size() < count && std::chrono::steady_clock::now() < deadline)
    EXPECT_TRUE(subscriber.poll(0.05, messages, rejected).isOk());
  if (rejections) *rejections = rejected;
  return messages;
}

void waitForReaders(const Publisher& publisher, const std::vector<std::string>& channels) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  for (const std::string& c : channels)
    while (publisher.matchedReaders(c) == 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

TEST(DdsTransport, EveryTypeArrivesAsItLeft) {
  const testing::IoSamples s = testing::makeIoSamples(5, kStamp);
  const std::vector<dfpc::Message> sent = {
      {"/test/camera/image", kStamp, Value::of(s.image_mono)},  // with its camera model
      {"/test/camera/calibration", kStamp, Value::of(s.camera)},
      {"/test/imu", kStamp, Value::of(s.imu)},
      {"/test/lidar/points", kStamp, Value::of(s.cloud)},
      {"/test/tf/camera", kStamp, Value::of(s.transform)},
      {"/test/pose", kStamp, Value::of(s.pose)},
      {"/test/state", kStamp, Value::of(s.state)},
      {"/test/matches", kStamp, Value::of(s.matches)},
      {"/test/record", kStamp, Value::of(s.record)}};
  auto sending = participant(), receiving = participant();
  ASSERT_TRUE(sending && receiving);
  Publisher publisher(*sending);
  Subscriber subscriber(*receiving);
  std::vector<std::string> channels;
  for (const dfpc::Message& m : sent) {
    ASSERT_TRUE(subscriber.subscribe(m.channel, m.type()).isOk());
    const PoseWithCovariance* pose = m.as<PoseWithCovariance>();
    ASSERT_TRUE(publisher.prepare(m.channel, m.type(), pose ? pose->pose.child_frame : ""));
    channels.push_back(m.channel);
  }
  waitForReaders(publisher, channels);
  for (const dfpc::Message& m : sent) ASSERT_TRUE(publisher.publish(m).isOk()) << m.channel;
  const std::vector<dfpc::Message> received = receive(subscriber, sent.size());
  ASSERT_EQ(received.size(), sent.size());
  for (std::size_t i = 0; i < sent.size(); ++i) {
    SCOPED_TRACE(sent[i].channel);
    // In the order of publication, whatever the topic.
    EXPECT_EQ(received[i].channel, sent[i].channel);
    EXPECT_EQ(received[i].stamp, sent[i].stamp);
    EXPECT_EQ(messageOf(received[i].value), messageOf(sent[i].value));
  }
  EXPECT_TRUE(received[0].as<Image>()->camera);
  EXPECT_EQ(received[5].as<PoseWithCovariance>()->pose.child_frame, "target");
}

TEST(DdsTransport, AReaderThatJoinsLateGetsATransientLocalWritersHistory) {
  auto sending = participant(), receiving = participant();
  ASSERT_TRUE(sending && receiving);
  Publisher publisher(*sending, {Durability::kTransientLocal, 10});
  for (int i = 0; i < 5; ++i)
    ASSERT_TRUE(publisher.publish(dfpc::Message::of("/test/late", kStamp + i, 0.5 * i)).isOk());
  Subscriber subscriber(*receiving);
  ASSERT_TRUE(subscriber.subscribeDiscovered({"/test/late"}).isOk());
  const std::vector<dfpc::Message> received = receive(subscriber, 5);
  ASSERT_EQ(received.size(), 5u);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(*received[i].as<double>(), 0.5 * i);
}

TEST(DdsTransport, MalformedSamplesAreRejectedWithWhatAndWhereAndTheOthersArrive) {
  auto sending = participant(), receiving = participant();
  ASSERT_TRUE(sending && receiving);
  Subscriber subscriber(*receiving);
  ASSERT_TRUE(subscriber.subscribe("/test/bad/image", TypeId::of<Image>()).isOk());
  ASSERT_TRUE(subscriber.subscribe("/test/bad/pose", TypeId::of<PoseWithCovariance>()).isOk());
  // A foreign publisher's samples, written with Cyclone's C API as any DDS program would.
  Result<dds_entity_t> image_topic =
      sending->topic("rt/test/bad/image", &sensor_msgs_msg_dds__Image__desc);
  Result<dds_entity_t> pose_topic =
      sending->topic("rt/test/bad/pose", &geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc);
  ASSERT_TRUE(image_topic && pose_topic);
  Result<dds_entity_t> image_writer = sending->createWriter(*image_topic, {});
  Result<dds_entity_t> pose_writer = sending->createWriter(*pose_topic, {});
  ASSERT_TRUE(image_writer && pose_writer);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  dds_publication_matched_status_t matched{};
  for (dds_entity_t w : {*image_writer, *pose_writer})
    while ((dds_get_publication_matched_status(w, &matched), matched.current_count == 0) &&
           std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));

  std::vector<std::uint8_t> pixels(100);
  sensor_msgs_msg_dds__Image_ image{};
  image.header.stamp = toRosTime(kStamp);
  image.header.frame_id = const_cast<char*>("camera");
  image.encoding = const_cast<char*>("mono8");
  image.width = image.step = 16;
  image.height = 8;
  image.data = {100, 100, pixels.data(), false};
  geometry_msgs_msg_dds__PoseWithCovarianceStamped_ pose{};
  pose.header.stamp = toRosTime(kStamp + 1);
  pose.header.frame_id = const_cast<char*>("chaser");
  pose.pose.pose.orientation.w = 1;
  pose.pose.pose.position.x = std::numeric_limits<double>::quiet_NaN();
  ASSERT_EQ(dds_write(*image_writer, &image), DDS_RETCODE_OK);
  ASSERT_EQ(dds_write(*pose_writer, &pose), DDS_RETCODE_OK);
  pose.pose.pose.position.x = 1.5;  // a good one after the bad ones
  ASSERT_EQ(dds_write(*pose_writer, &pose), DDS_RETCODE_OK);

  std::atomic<bool> stop{false};
  std::vector<Rejection> rejections;
  DdsInputStream input(subscriber, &stop, [&](const Rejection& r) { rejections.push_back(r); });
  Result<std::optional<dfpc::Message>> good = input.next();
  ASSERT_TRUE(good.isOk() && good->has_value());
  EXPECT_EQ((*good)->as<PoseWithCovariance>()->pose.translation.x(), 1.5);
  ASSERT_EQ(rejections.size(), 2u);
  EXPECT_EQ(rejections[0].channel, "/test/bad/image");
  EXPECT_EQ(rejections[0].stamp, kStamp);
  EXPECT_NE(rejections[0].status.message().find(
                "channel '/test/bad/image' (sensor_msgs::msg::dds_::Image_): image data holds 100 "
                "bytes; expected step * height = 16 * 8 = 128"),
            std::string::npos)
      << rejections[0].status.message();
  EXPECT_NE(rejections[1].status.message().find("non-finite entry (nan)"), std::string::npos)
      << rejections[1].status.message();
  stop = true;
  Result<std::optional<dfpc::Message>> end = input.next();
  ASSERT_TRUE(end.isOk());
  EXPECT_FALSE(end->has_value());
  EXPECT_EQ(input.rejected(), 2u);
}

}  // namespace
}  // namespace cdff::dds
