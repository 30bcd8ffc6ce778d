// What `cdff run` does without files: graphs loaded, channels remapped, ground truth copied,
// products, events and timings written, progress reported.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "cdff/dfpc/replay.hpp"
#include "cdff/dfpc/run_set.hpp"
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

// A run set: two graphs, a remap, a setting and a rule in one file, as `cdff run` would take
// them on its command line; the second graph runs only while the first's product is above 1,
// and gets its latched configuration (/config/offset) when it starts, however late.
const std::string kGated = R"(name: gated
inputs:
  - {name: x, type: Double, channel: /in/x}
  - {name: offset, type: Double, channel: /config/offset, latched: true}
outputs: [{name: y, type: Double}]
nodes:
  add: {dfn: ProbeRelay, dfi: Plain, trigger: {on: [a]}}
connections: [x -> add.a, offset -> add.b, add.result -> y]
)";

TEST(RunSet, RunsItsGraphsWithItsMapsSettingsAndRules) {
  const std::string relay = writeGraph("set_relay", kRelay),
                    gated = writeGraph("set_gated", kGated);
  const std::string set =
      writeGraph("set", fmt::format(R"(name: both
doc: the relay, and the gated relay while the relay's output is above 1
graphs: [{}, {}]
map: [relay.x=/sensor/x, gated.x=/sensor/x]
set: [relay/add.offset=0.25]
run_while: ["gated: relay.y > 1"]
)",
                                    std::filesystem::path(relay).filename().string(), gated));
  Result<RunSet> loaded = loadRunSet(set);
  ASSERT_OK(loaded.status());
  EXPECT_EQ(loaded->name, "both");
  EXPECT_EQ(loaded->graph_files, (std::vector<std::string>{relay, gated}));
  EXPECT_TRUE(isRunSetFile(set));
  EXPECT_FALSE(isRunSetFile(relay));

  MemoryStream input({number("/config/offset", 0, 10), number("/sensor/x", 1, 0.5),
                      number("/sensor/x", 2, 1.0), number("/sensor/x", 3, 2.0)});
  MemorySink sink;
  ReplayOptions options;
  options.graph_files = {set};
  options.parameter_settings = {"relay/add.offset=0.5"};  // the command line's wins
  ASSERT_OK(replay(input, sink, options).status());
  EXPECT_EQ(testing::values(sink, "/cdff/relay/y"), (std::vector<double>{1.0, 1.5, 2.5}));
  // relay.y = 1.5 > 1 from t = 2 on: gated runs from t = 3 with the offset it missed at t = 0.
  EXPECT_EQ(testing::values(sink, "/cdff/gated/y"), (std::vector<double>{12.0}));
  EXPECT_TRUE(checkRun(options).isOk());
}

TEST(RunSet, BadRunSetsAreRefusedAtTheirLine) {
  const std::string relay = writeGraph("set_relay", kRelay);
  const auto error = [&](const std::string& name, const std::string& text) {
    return loadRunSet(writeGraph(name, text)).status().toString();
  };
  EXPECT_NE(error("set_key", fmt::format("graphs: [{}]\nrun_whilst: []\n", relay))
                .find("cdff_replay_set_key.yaml:2:1: run_whilst: unknown key"),
            std::string::npos)
      << error("set_key", fmt::format("graphs: [{}]\nrun_whilst: []\n", relay));
  EXPECT_NE(error("set_nofile", "graphs: [nowhere.yaml]\n").find("no file"), std::string::npos);
  EXPECT_NE(error("set_empty", "graphs: []\n").find("graphs = []: empty"), std::string::npos)
      << error("set_empty", "graphs: []\n");
  const std::string bad_rule = fmt::format("graphs: [{}]\nrun_while:\n  - 'relay: y >'\n", relay);
  EXPECT_NE(error("set_rule", bad_rule).find("cdff_replay_set_rule.yaml:3:5"), std::string::npos)
      << error("set_rule", bad_rule);
  const std::string bad_map = fmt::format("graphs: [{}]\nmap: [relay.x]\n", relay);
  EXPECT_NE(error("set_map", bad_map).find("expected DFPC.INPUT=/channel"), std::string::npos)
      << error("set_map", bad_map);
  // Names are checked against the loaded graphs, before anything runs.
  ReplayOptions options;
  options.graph_files = {writeGraph(
      "set_names", fmt::format("graphs: [{}]\nrun_while: ['relay: nobody.y > 1']\n", relay))};
  EXPECT_NE(checkRun(options).message().find("no DFPC 'nobody'"), std::string::npos)
      << checkRun(options).message();
}

}  // namespace
}  // namespace cdff::dfpc
