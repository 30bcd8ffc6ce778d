// DFPC control: triggers, periodic ticks in stream time, synchronisation, delays, conditional
// activation (the seed's Fig. 8 detector/tracker), routing between DFPCs, life cycle, replays.
#include <gtest/gtest.h>

#include "test_helpers.hpp"

namespace cdff::dfpc {
namespace {

using testing::number;
using testing::runningOrchestrator;
using testing::stamps;
using testing::values;

const std::string kChain = R"(name: chain
inputs:
  - {name: x, type: Double, channel: /in/x}
  - {name: z, type: Double, channel: /in/z, optional: true}
outputs:
  - {name: y, type: Double}
nodes:
  first: {dfn: ProbeRelay, dfi: Plain}
  second:
    dfn: ProbeRelay
    dfi: Plain
    parameters: {offset: 1}
    trigger: {on: [a]}
connections:
  - x -> first.a
  - first.result -> second.a
  - z -> second.b
  - second.result -> y
)";

TEST(Triggers, ArrivalRunsTheChainInTopologicalOrderOncePerStep) {
  MemorySink sink;
  auto o = runningOrchestrator(kChain, sink);
  ASSERT_TRUE(o);
  for (int k = 0; k < 3; ++k) ASSERT_OK(o->process(number("/in/x", 0.1 * k, 10.0 * k)));
  EXPECT_EQ(values(sink, "/cdff/chain/y"), (std::vector<double>{1, 11, 21}));
  EXPECT_EQ(stamps(sink, "/cdff/chain/y"), (std::vector<Timestamp>{0, 100000, 200000}));
  const auto timings = sink.timings();
  ASSERT_EQ(timings.size(), 6u);
  for (std::size_t i = 0; i < timings.size(); ++i)
    EXPECT_EQ(timings[i].instance, i % 2 ? "second" : "first");
}

TEST(Triggers, OnlyTheListedPortsTriggerAndOtherInputsKeepTheirLatestValue) {
  MemorySink sink;
  auto o = runningOrchestrator(kChain, sink);
  ASSERT_TRUE(o);
  ASSERT_OK(o->process(number("/in/z", 0.0, 100)));  // b of second: not a trigger
  EXPECT_TRUE(sink.messages("/cdff/chain/y").empty());
  ASSERT_OK(o->process(number("/in/x", 0.1, 5)));
  ASSERT_OK(o->process(number("/in/z", 0.2, 200)));
  ASSERT_OK(o->process(number("/in/x", 0.3, 6)));
  EXPECT_EQ(values(sink, "/cdff/chain/y"), (std::vector<double>{106, 207}));
}

TEST(Triggers, PeriodicTicksFollowStreamTimeAndWriteTheTickTime) {
  const std::string graph = R"(name: ticking
inputs: [{name: v, type: Double, channel: /in/v}]
outputs:
  - {name: ticks, type: Int}
  - {name: when, type: Timestamp}
nodes:
  ticker:
    dfn: ProbeTicker
    dfi: Counter
    trigger: {on: [], period_s: 0.1, time_input: time, tick_when: ticker.ticks < 5 or ticker.ticks == unset}
connections:
  - v -> ticker.value
  - ticker.ticks -> ticks
  - ticker.time_seen -> when
)";
  MemorySink sink;
  auto o = runningOrchestrator(graph, sink);
  ASSERT_TRUE(o);
  ASSERT_OK(o->process(number("/in/v", 1.0, 0)));   // stream time starts at 1 s
  ASSERT_OK(o->process(number("/in/v", 1.25, 0)));  // ticks at 1.0, 1.1, 1.2
  std::vector<Timestamp> when;
  for (const Message& m : sink.messages("/cdff/ticking/when")) when.push_back(*m.as<Timestamp>());
  EXPECT_EQ(when, (std::vector<Timestamp>{1000000, 1100000, 1200000}));
  EXPECT_EQ(stamps(sink, "/cdff/ticking/when"), when);
  ASSERT_OK(o->process(number("/in/v", 3.0, 0)));  // tick_when stops the ticks after 5
  EXPECT_EQ(sink.messages("/cdff/ticking/ticks").size(), 5u);
}

TEST(Triggers, PeriodicTicksDoNotCatchUpTheTimeSpentStopped) {
  const std::string graph = R"(name: ticking
inputs: [{name: v, type: Double, channel: /in/v}]
outputs: [{name: when, type: Timestamp}]
nodes:
  ticker: {dfn: ProbeTicker, dfi: Counter, trigger: {on: [], period_s: 0.5, time_input: time}}
connections: [v -> ticker.value, ticker.time_seen -> when]
)";
  MemorySink sink;
  auto o = runningOrchestrator(graph, sink);
  ASSERT_TRUE(o);
  ASSERT_OK(o->process(number("/in/v", 0.0, 0)));
  ASSERT_OK(o->process(number("/in/v", 1.0, 0)));  // ticks at 0, 0.5, 1.0
  ASSERT_OK(o->stop("ticking"));
  ASSERT_OK(o->process(number("/in/v", 5.0, 0)));
  ASSERT_OK(o->start("ticking"));
  ASSERT_OK(o->process(number("/in/v", 10.2, 0)));  // ticks again from 10.2
  ASSERT_OK(o->process(number("/in/v", 10.8, 0)));  // and at 10.7
  EXPECT_EQ(testing::stamps(sink, "/cdff/ticking/when"),
            (std::vector<Timestamp>{0, 500000, 1000000, 10200000, 10700000}));
}

const std::string kPair = R"(name: pairing
inputs:
  - {name: camera, type: Double, channel: /camera}
  - {name: imu, type: Double, channel: /imu}
outputs:
  - {name: left, type: Double}
  - {name: right, type: Double}
nodes:
  pair:
    dfn: ProbePair
    dfi: Echo
    trigger: {on: [left, right], SYNC}
connections:
  - camera -> pair.left
  - imu -> pair.right
  - pair.left_seen -> left
  - pair.right_seen -> right
)";

std::string pairGraph(const std::string& sync) {
  std::string g = kPair;
  g.replace(g.find("SYNC"), 4, sync);
  return g;
}

// Messages whose value is their own stamp in seconds (+100 for the IMU), so that a test sees
// which messages were paired.
void feed(Orchestrator& o, const std::vector<std::pair<const char*, double>>& messages) {
  for (const auto& [channel, t] : messages)
    ASSERT_OK(o.process(number(channel, t, t + (std::string(channel) == "/imu" ? 100 : 0))));
}

TEST(Sync, ExactPairsEqualStampsAndReportsWhatItDrops) {
  MemorySink sink;
  auto o = runningOrchestrator(pairGraph("sync: exact"), sink);
  ASSERT_TRUE(o);
  feed(*o, {{"/camera", 0.0}, {"/imu", 0.0}, {"/camera", 0.1}, {"/camera", 0.2}, {"/imu", 0.2}});
  ASSERT_OK(o->finish());
  EXPECT_EQ(values(sink, "/cdff/pairing/left"), (std::vector<double>{0.0, 0.2}));
  EXPECT_EQ(values(sink, "/cdff/pairing/right"), (std::vector<double>{100.0, 100.2}));
  EXPECT_EQ(stamps(sink, "/cdff/pairing/left"), (std::vector<Timestamp>{0, 200000}));
  const auto drops = sink.events(EventType::kSyncDropped);
  ASSERT_EQ(drops.size(), 1u);
  EXPECT_NE(drops[0].message.find("input 'left': message at t = 100000 us dropped (no partner "
                                  "with the same stamp)"),
            std::string::npos)
      << drops[0].message;
  EXPECT_EQ(o->status("pairing")->instances[0].sync_dropped, 1u);
}

TEST(Sync, NearestWaitsForTheBestPartnerWithinTheTolerance) {
  MemorySink sink;
  auto o = runningOrchestrator(pairGraph("sync: nearest, tolerance_s: 0.005"), sink);
  ASSERT_TRUE(o);
  feed(*o, {{"/camera", 0.0},
            {"/imu", 0.003},
            {"/imu", 0.097},
            {"/camera", 0.1},  // waits: a nearer IMU message may still come
            {"/imu", 0.104},   // now 0.097 (3 ms) is known to be the nearest
            {"/camera", 0.2},
            {"/imu", 0.3}});  // 0.2 has no partner within 5 ms
  ASSERT_OK(o->finish());
  EXPECT_EQ(values(sink, "/cdff/pairing/left"), (std::vector<double>{0.0, 0.1}));
  EXPECT_EQ(values(sink, "/cdff/pairing/right"), (std::vector<double>{100.003, 100.097}));
  EXPECT_EQ(stamps(sink, "/cdff/pairing/left"), (std::vector<Timestamp>{0, 100000}));
  std::vector<std::string> dropped;
  for (const Event& e : sink.events(EventType::kSyncDropped)) dropped.push_back(e.message);
  ASSERT_EQ(dropped.size(), 3u);
  EXPECT_NE(dropped[0].find("'right': message at t = 104000 us"), std::string::npos) << dropped[0];
  EXPECT_NE(dropped[1].find("'left': message at t = 200000 us"), std::string::npos) << dropped[1];
  EXPECT_NE(dropped[2].find("'right': message at t = 300000 us dropped (unmatched at the end of "
                            "the stream)"),
            std::string::npos)
      << dropped[2];
}

TEST(Sync, QueuesAreBounded) {
  MemorySink sink;
  auto o = runningOrchestrator(pairGraph("sync: nearest, tolerance_s: 0.01, queue: 2"), sink);
  ASSERT_TRUE(o);
  feed(*o, {{"/imu", 0.0}, {"/imu", 0.001}, {"/imu", 0.002}, {"/imu", 0.003}, {"/camera", 0.003}});
  EXPECT_EQ(values(sink, "/cdff/pairing/right"), (std::vector<double>{100.003}));
  std::size_t full = 0;
  for (const Event& e : sink.events(EventType::kSyncDropped))
    full += e.message.find("queue full") != std::string::npos;
  EXPECT_EQ(full, 2u);
}

TEST(Delay, AValueReachesItsTargetAtTheNextStep) {
  const std::string graph = R"(name: sum
inputs: [{name: x, type: Double, channel: /in/x}]
outputs: [{name: total, type: Double}]
nodes:
  add: {dfn: ProbeRelay, dfi: Plain, trigger: {on: [a]}}
  keep: {dfn: ProbeRelay, dfi: Plain}
connections:
  - x -> add.a
  - add.result -> keep.a
  - {from: keep.result, to: add.b, delay: 1}
  - keep.result -> total
)";
  MemorySink sink;
  auto o = runningOrchestrator(graph, sink);
  ASSERT_TRUE(o);
  for (int k = 0; k < 4; ++k) ASSERT_OK(o->process(number("/in/x", k, 1.0)));
  EXPECT_EQ(values(sink, "/cdff/sum/total"), (std::vector<double>{1, 2, 3, 4}));
}

// The seed's Fig. 8: the detector sleeps while the tracker tracks and wakes when it loses the
// target (or has never had it).
const std::string kVisualTracking = R"(name: visual_tracking
inputs: [{name: frame, type: Double, channel: /camera/frame}]
outputs: [{name: pose, type: Double, role: ""}]
track_state: {from: tracker.status, initial: UNINITIALISED}
nodes:
  detector:
    dfn: ProbeDetector
    dfi: Oracle
    active_when: track_state in [LOST, UNINITIALISED]
  tracker:
    dfn: ProbeTracker
    dfi: Gated
    trigger: {on: [measurement]}
connections:
  - frame -> detector.measurement
  - frame -> tracker.measurement
  - detector.detection -> tracker.initial
  - tracker.estimate -> pose
)";

TEST(Activation, DetectorWakesOnLossAndSleepsWhileTracking) {
  MemorySink sink;
  auto o = runningOrchestrator(kVisualTracking, sink);
  ASSERT_TRUE(o);
  const double nan = std::nan("");
  const std::vector<double> frames{1.0, 1.1, 1.2, 5.0, 5.1, 5.2, nan, nan, 5.3, 5.4};
  for (std::size_t k = 0; k < frames.size(); ++k)
    ASSERT_OK(o->process(number("/camera/frame", static_cast<double>(k), frames[k])));

  // Tracked: frames 0-2; lost at 3 (jump); re-detected at 4; lost at 6 (not visible); the
  // detector finds nothing at 7; re-detected at 8.
  EXPECT_EQ(values(sink, "/cdff/visual_tracking/pose"),
            (std::vector<double>{1.0, 1.1, 1.2, 5.1, 5.2, 5.3, 5.4}));
  std::vector<std::pair<EventType, Timestamp>> activation;
  for (const Event& e : sink.events())
    if (e.kind() == EventKind::kActivation && e.instance == "detector")
      activation.emplace_back(e.type, e.stamp);
  using P = std::pair<EventType, Timestamp>;
  EXPECT_EQ(activation, (std::vector<P>{{EventType::kDeactivated, fromSeconds(1)},
                                        {EventType::kActivated, fromSeconds(4)},
                                        {EventType::kDeactivated, fromSeconds(5)},
                                        {EventType::kActivated, fromSeconds(7)},
                                        {EventType::kDeactivated, fromSeconds(9)}}));
  const DfpcStatus status = o->status("visual_tracking").value();
  EXPECT_EQ(status.track_state, TrackState::kTracking);
  const InstanceStatus& detector = status.instances[0];
  EXPECT_EQ(detector.name, "detector");
  EXPECT_EQ(detector.calls, 4u);  // frames 0, 4, 7, 8
  EXPECT_EQ(detector.skipped, 6u);
  EXPECT_FALSE(detector.active);
  ASSERT_EQ(sink.events(EventType::kDfnWarning).size(), 1u);
  EXPECT_EQ(sink.events(EventType::kDfnWarning)[0].stamp, fromSeconds(7));
  std::vector<std::string> states;
  for (const Event& e : sink.events(EventType::kTrackStateChanged)) states.push_back(e.message);
  EXPECT_EQ(states, (std::vector<std::string>{
                        "UNINITIALISED -> TRACKING", "TRACKING -> LOST", "LOST -> TRACKING",
                        "TRACKING -> LOST", "LOST -> UNINITIALISED", "UNINITIALISED -> TRACKING"}));
}

TEST(Routing, TheProductsOfOneDfpcFeedAnother) {
  const std::string consumer = R"(name: consumer
inputs: [{name: y, type: Double, channel: /cdff/chain/y}]
outputs: [{name: w, type: Double}]
nodes:
  scale: {dfn: ProbeRelay, dfi: Plain, parameters: {offset: 1000}}
connections: [y -> scale.a, scale.result -> w]
)";
  MemorySink sink;
  auto o = runningOrchestrator(kChain, sink);
  ASSERT_TRUE(o);
  ASSERT_OK(o->add(testing::makeDfpc(consumer)));
  ASSERT_OK(o->start("consumer"));
  ASSERT_OK(o->process(number("/in/x", 0.5, 2)));
  EXPECT_EQ(values(sink, "/cdff/consumer/w"), (std::vector<double>{1003}));
  EXPECT_EQ(stamps(sink, "/cdff/consumer/w"), (std::vector<Timestamp>{500000}));
  // Both products are in the shared Data Product Manager.
  EXPECT_EQ(*o->products().latestAs<double>("consumer/w").value(), 1003);
  EXPECT_EQ(*o->products().latestAs<double>("chain/y").value(), 3);
}

TEST(Lifecycle, AStoppedDfpcIgnoresItsInputsAndResetClearsItsState) {
  const std::string graph = R"(name: counting
inputs: [{name: x, type: Double, channel: /in/x}]
outputs: [{name: calls, type: Int}]
nodes:
  relay: {dfn: ProbeRelay, dfi: Plain}
connections: [x -> relay.a, relay.calls -> calls]
)";
  MemorySink sink;
  auto o = runningOrchestrator(graph, sink);
  ASSERT_TRUE(o);
  auto calls = [&] {
    std::vector<int> out;
    for (const Message& m : sink.messages("/cdff/counting/calls")) out.push_back(*m.as<int>());
    return out;
  };
  ASSERT_OK(o->process(number("/in/x", 0, 1)));
  ASSERT_OK(o->process(number("/in/x", 1, 1)));
  ASSERT_OK(o->stop("counting"));
  EXPECT_FALSE(o->stop("counting").isOk());  // not running
  ASSERT_OK(o->process(number("/in/x", 2, 1)));
  EXPECT_EQ(o->status("counting")->ignored_messages, 1u);
  ASSERT_OK(o->start("counting"));
  ASSERT_OK(o->process(number("/in/x", 3, 1)));
  EXPECT_EQ(calls(), (std::vector<int>{1, 2, 3}));  // state kept across stop/start
  ASSERT_OK(o->reset("counting"));
  EXPECT_EQ(o->status("counting")->state, DfpcState::kRunning);
  ASSERT_OK(o->process(number("/in/x", 4, 1)));
  EXPECT_EQ(calls(), (std::vector<int>{1, 2, 3, 1}));  // a fresh instance
  EXPECT_FALSE(o->init("counting").isOk());            // running: stop first
  EXPECT_EQ(o->start("nothing").code(), StatusCode::kNotFound);
  std::vector<EventType> lifecycle;
  for (const Event& e : sink.events())
    if (e.kind() == EventKind::kLifecycle && e.type != EventType::kTrackStateChanged)
      lifecycle.push_back(e.type);
  EXPECT_EQ(lifecycle,
            (std::vector<EventType>{EventType::kStarted, EventType::kStopped, EventType::kStarted,
                                    EventType::kInitialised, EventType::kReset}));
}

TEST(Inputs, AMessageOfTheWrongTypeIsRejectedAndReported) {
  MemorySink sink;
  auto o = runningOrchestrator(kChain, sink);
  ASSERT_TRUE(o);
  const Status s = o->process(Message::of<int>("/in/x", 0, 3));
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("input 'x' (channel /in/x) takes Double; got Int"), std::string::npos)
      << s.message();
  EXPECT_EQ(sink.events(EventType::kInputRejected).size(), 1u);
}

TEST(Streams, MergedStreamsInterleaveByStampKeepingInputOrderOnTies) {
  std::vector<std::unique_ptr<InputStream>> inputs;
  inputs.push_back(std::make_unique<MemoryStream>(
      std::vector<Message>{number("/a", 0.0, 1), number("/a", 0.2, 2), number("/a", 0.2, 3)}));
  inputs.push_back(std::make_unique<MemoryStream>(
      std::vector<Message>{number("/b", 0.1, 4), number("/b", 0.2, 5)}));
  MergedStream merged(std::move(inputs));
  EXPECT_EQ(merged.channels().size(), 2u);
  EXPECT_EQ(merged.timeRange()->second, fromSeconds(0.2));
  std::vector<double> order;
  for (;;) {
    auto m = merged.next();
    ASSERT_OK(m.status());
    if (!m.value()) break;
    order.push_back(*m.value()->as<double>());
  }
  EXPECT_EQ(order, (std::vector<double>{1, 4, 2, 3, 5}));
}

TEST(Replay, RunCopiesGroundTruthThroughAndReportsProgress) {
  MemorySink sink;
  OrchestratorOptions options;
  options.passthrough_prefixes = {"/truth/"};
  auto o = runningOrchestrator(kChain, sink, options);
  ASSERT_TRUE(o);
  MemoryStream input;
  for (int k = 0; k < 10; ++k) {
    input.add(number("/in/x", 0.1 * k, k));
    input.add(number("/truth/x", 0.1 * k, k));
  }
  std::vector<double> fractions;
  RunOptions run;
  run.progress = [&](const RunProgress& p) { fractions.push_back(p.fraction()); };
  Result<RunSummary> summary = o->run(input, run);
  ASSERT_OK(summary.status());
  EXPECT_EQ(summary->messages, 20u);
  EXPECT_EQ(summary->passed_through, 10u);
  EXPECT_EQ(summary->products, 10u);
  EXPECT_EQ(sink.messages("/truth/x").size(), 10u);
  EXPECT_EQ(sink.messages("/cdff/chain/y").size(), 10u);
  EXPECT_EQ(sink.timings().size(), 20u);
  ASSERT_EQ(fractions.size(), 20u);
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
}

TEST(Replay, RealTimePacingFollowsTheClock) {
  MemorySink sink;
  auto o = runningOrchestrator(kChain, sink);
  ASSERT_TRUE(o);
  MemoryStream input;
  for (int k = 0; k < 5; ++k) input.add(number("/in/x", 10.0 + 0.5 * k, k));
  SimulatedClock clock(fromSeconds(100), SimulatedClock::Mode::kAutoAdvance);
  std::vector<Timestamp> processed_at;
  RunOptions run;
  run.realtime = true;
  run.speed = 2.0;
  run.clock = &clock;
  run.progress = [&](const RunProgress&) { processed_at.push_back(clock.now()); };
  ASSERT_OK(o->run(input, run).status());
  // Stream time 10.0 .. 12.0 s at twice real time: clock 100.0 .. 101.0 s.
  EXPECT_EQ(processed_at,
            (std::vector<Timestamp>{100000000, 100250000, 100500000, 100750000, 101000000}));
}

TEST(Replay, ChannelsAreCheckedBeforeRunning) {
  MemorySink sink;
  auto o = runningOrchestrator(kChain, sink);
  ASSERT_TRUE(o);
  MemoryStream wrong_type({Message::of<int>("/in/x", 0, 1), number("/in/z", 0, 1)});
  Status s = o->run(wrong_type).status();
  EXPECT_NE(s.message().find("DFPC 'chain' input 'x' takes Double; channel '/in/x' holds Int"),
            std::string::npos)
      << s.message();
  MemoryStream missing({number("/in/z", 0, 1)});
  s = o->run(missing).status();
  EXPECT_NE(s.message().find("input 'x' needs channel '/in/x' (Double), which the input does not "
                             "have"),
            std::string::npos)
      << s.message();
}

}  // namespace
}  // namespace cdff::dfpc
