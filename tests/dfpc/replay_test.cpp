// What `cdff run` does without files: graphs loaded, channels remapped, ground truth copied,
// products, events and timings written, progress reported.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "cdff/dfpc/replay.hpp"
#include "test_helpers.hpp"

namespace cdff::dfpc {
namespace {

using testing::number;

std::string writeGraph(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("cdff_replay_" + name + ".yaml");
  std::ofstream(path) << text;
  return path.string();
}

const std::string kRelay = R"(name: relay
inputs: [{name: x, type: Double, channel: /in/x}]
outputs: [{name: y, type: Double}]
nodes:
  add: {dfn: ProbeRelay, dfi: Plain, parameters: {offset: 0.5}}
connections: [x -> add.a, add.result -> y]
)";

TEST(Replay, CopiesTheCamerasCalibrationsAndWhatPatternsName) {
  EXPECT_TRUE(matchesChannelPattern("/truth/target_pose", "/truth/"));
  EXPECT_FALSE(matchesChannelPattern("/cdff/truth/x", "/truth/"));
  EXPECT_TRUE(
      matchesChannelPattern("/chaser/camera/far/calibration", "/chaser/camera/*/calibration"));
  EXPECT_TRUE(
      matchesChannelPattern("/chaser/camera/a/b/calibration", "/chaser/camera/*/calibration"));
  EXPECT_FALSE(matchesChannelPattern("/chaser/camera/far/image", "/chaser/camera/*/calibration"));
  EXPECT_FALSE(
      matchesChannelPattern("/chaser/camera/far/calibration/x", "/chaser/camera/*/calibration"));
  EXPECT_TRUE(matchesChannelPattern("/chaser/lidar2", "/chaser/lidar[0-9]"));

  const auto inputs = [] {
    MemoryStream input;
    for (int k = 0; k < 3; ++k) {
      input.add(number("/sensor/x", k, k));
      input.add(number("/chaser/camera/far/calibration", k, k));
      input.add(number("/chaser/camera/far/image", k, k));
    }
    return input;
  };
  MemoryStream input = inputs();
  MemorySink sink;
  ReplayOptions options;
  options.graph_files = {writeGraph("relay", kRelay)};
  options.remaps = {parseRemap("relay.x=/sensor/x").value()};
  ASSERT_OK(replay(input, sink, options).status());
  EXPECT_EQ(sink.messages("/chaser/camera/far/calibration").size(), 3u);
  EXPECT_TRUE(sink.messages("/chaser/camera/far/image").empty());

  MemorySink only_images;
  options.passthrough_prefixes = {"/chaser/*/image"};
  MemoryStream again = inputs();
  ASSERT_OK(replay(again, only_images, options).status());
  EXPECT_EQ(only_images.messages("/chaser/camera/far/image").size(), 3u);
  EXPECT_TRUE(only_images.messages("/chaser/camera/far/calibration").empty());
}

TEST(Replay, RunsGraphFilesWithRemappedChannelsAndCopiesTheTruth) {
  MemoryStream input;
  for (int k = 0; k < 4; ++k) {
    input.add(number("/sensor/x", k, k));
    input.add(number("/truth/x", k, k));
    input.add(number("/in/x", k, 100));  // the graph's own channel: not used after the remap
  }
  MemorySink sink;
  ReplayOptions options;
  options.graph_files = {writeGraph("relay", kRelay)};
  options.remaps = {parseRemap("relay.x=/sensor/x").value()};
  int progress_calls = 0;
  options.progress = [&](const RunProgress&) { ++progress_calls; };
  Result<ReplayResult> result = replay(input, sink, options);
  ASSERT_OK(result.status());
  EXPECT_EQ(testing::values(sink, "/cdff/relay/y"), (std::vector<double>{0.5, 1.5, 2.5, 3.5}));
  EXPECT_EQ(sink.messages("/truth/x").size(), 4u);
  EXPECT_TRUE(sink.messages("/in/x").empty());
  EXPECT_EQ(sink.timings().size(), 4u);
  EXPECT_EQ(sink.events(EventType::kStarted).size(), 1u);
  EXPECT_EQ(progress_calls, 12);
  EXPECT_EQ(result->summary.messages, 12u);
  ASSERT_EQ(result->dfpcs.size(), 1u);
  EXPECT_EQ(result->dfpcs[0].messages, 4u);
}

TEST(Replay, RefusesBadRemapsAndBadGraphsBeforeRunning) {
  MemoryStream input({number("/in/x", 0, 1)});
  MemorySink sink;
  ReplayOptions options;
  options.graph_files = {writeGraph("relay", kRelay)};
  options.remaps = {{"relay.z", "/sensor/z"}};
  EXPECT_NE(replay(input, sink, options)
                .status()
                .message()
                .find("no DFPC input 'relay.z'; expected one of {relay.x}"),
            std::string::npos);
  EXPECT_FALSE(parseRemap("x").isOk());
  EXPECT_FALSE(parseRemap("=/a").isOk());
  options.remaps.clear();
  options.graph_files = {writeGraph("bad", "name: bad\nnodes:\n  a: {dfn: Nope, dfi: X}\n")};
  const Status bad = replay(input, sink, options).status();
  EXPECT_NE(bad.message().find("cdff_replay_bad.yaml:3:12: instance 'a': unknown DFN 'Nope'"),
            std::string::npos)
      << bad.message();
  EXPECT_TRUE(sink.messages().empty());
}

TEST(Replay, TheProgressBarShowsTheFractionStreamTimeAndMessages) {
  RunProgress p;
  p.messages = 4517;
  p.stamp = fromSeconds(112.3);
  p.range = std::make_pair(fromSeconds(100.0), fromSeconds(123.65));
  EXPECT_EQ(ProgressBar::render(p, 10),
            "[#####.....]  52.0 %  t = 12.30 s of 23.65 s  4517 messages");
  p.range.reset();
  EXPECT_EQ(ProgressBar::render(p, 10), "t = 112.30 s  4517 messages");
  std::FILE* file = std::tmpfile();
  ASSERT_NE(file, nullptr);
  ProgressBar bar(file, true, 0.0);
  bar.update(p);
  bar.finish();
  std::rewind(file);
  char buffer[256] = {};
  const std::size_t n = std::fread(buffer, 1, sizeof(buffer) - 1, file);
  std::fclose(file);
  EXPECT_EQ(std::string(buffer, n), "\rt = 112.30 s  4517 messages\rt = 112.30 s  4517 messages\n");
  ProgressBar off(stderr, false);
  off.update(p);  // draws nothing when not on a terminal
  off.finish();
}

}  // namespace
}  // namespace cdff::dfpc
