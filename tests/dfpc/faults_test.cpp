// Fault detection and recovery: a DFN error, a call over its time budget, a divergence flag, no
// product for N seconds of stream time; re-initialisation, waking a sleeping instance, switching
// to a fallback DFI, setting the track state. Every fault and recovery is an event in the sink.
#include <gtest/gtest.h>

#include "dfpc_probe/probe_clock.hpp"
#include "test_helpers.hpp"

namespace cdff::dfpc {
namespace {

using testing::number;
using testing::runningOrchestrator;
using testing::values;

std::vector<std::pair<EventType, Timestamp>> faultsAndRecoveries(const MemorySink& sink) {
  std::vector<std::pair<EventType, Timestamp>> out;
  for (const Event& e : sink.events())
    if (e.kind() == EventKind::kFault || e.kind() == EventKind::kRecovery)
      out.emplace_back(e.type, e.stamp);
  return out;
}
using Timeline = std::vector<std::pair<EventType, Timestamp>>;

std::vector<int> ints(const MemorySink& sink, const std::string& channel) {
  std::vector<int> out;
  for (const Message& m : sink.messages(channel)) out.push_back(*m.as<int>());
  return out;
}

TEST(Faults, AnInjectedDfnErrorIsAnEventAndReinitialisationRecovers) {
  const std::string graph = R"(name: guarded
inputs: [{name: x, type: Double, channel: /in/x}]
outputs:
  - {name: y, type: Double}
  - {name: calls, type: Int}
nodes:
  relay:
    dfn: ProbeRelay
    dfi: Plain
    parameters: {fail_above: 10}
    on_fault: {error: {after: 2, do: [reinitialise]}}
connections: [x -> relay.a, relay.result -> y, relay.calls -> calls]
)";
  MemorySink sink;
  auto o = runningOrchestrator(graph, sink);
  ASSERT_TRUE(o);
  const std::vector<double> inputs{1, 2, 20, 3, 30, 40, 4};
  for (std::size_t k = 0; k < inputs.size(); ++k)
    ASSERT_OK(o->process(number("/in/x", static_cast<double>(k), inputs[k])));
  // A failed call publishes nothing; one error alone is tolerated (after: 2); two in a row
  // re-create the instance, whose call count restarts.
  EXPECT_EQ(values(sink, "/cdff/guarded/y"), (std::vector<double>{1, 2, 3, 4}));
  EXPECT_EQ(ints(sink, "/cdff/guarded/calls"), (std::vector<int>{1, 2, 3, 1}));
  EXPECT_EQ(faultsAndRecoveries(sink), (Timeline{{EventType::kDfnError, fromSeconds(2)},
                                                 {EventType::kDfnError, fromSeconds(4)},
                                                 {EventType::kDfnError, fromSeconds(5)},
                                                 {EventType::kReinitialise, fromSeconds(5)}}));
  const Event error = sink.events(EventType::kDfnError)[0];
  EXPECT_EQ(error.dfpc, "guarded");
  EXPECT_EQ(error.instance, "relay");
  EXPECT_NE(error.message.find("a = 20 is above fail_above = 10"), std::string::npos)
      << error.message;
  const DfpcStatus status = o->status("guarded").value();
  EXPECT_EQ(status.faults, 3u);
  EXPECT_EQ(status.recoveries, 1u);
  EXPECT_NE(status.last_fault.find("error at t = 5000000 us in relay"), std::string::npos)
      << status.last_fault;
  // The timing records carry the failed calls' status.
  std::size_t failed = 0;
  for (const auto& t : sink.timings()) failed += t.status != StatusCode::kOk;
  EXPECT_EQ(failed, 3u);
}

TEST(Faults, ACallOverItsBudgetSwitchesToTheFallbackDfi) {
  const std::string graph = R"(name: budgeted
inputs: [{name: x, type: Double, channel: /in/x}]
outputs: [{name: y, type: Double}]
nodes:
  relay:
    dfn: ProbeRelay
    dfi: Plain
    parameters: {duration_s: 0.025}
    budget_s: 0.010
    fallback: {dfi: Alternative, parameters: {duration_s: 0.004}}
    on_fault: {over_budget: [switch_dfi]}
connections: [x -> relay.a, relay.result -> y]
)";
  MemorySink sink;
  OrchestratorOptions options;
  options.execution_clock = &testing::probeExecutionClock();
  auto o = runningOrchestrator(graph, sink, options);
  ASSERT_TRUE(o);
  for (int k = 0; k < 3; ++k) ASSERT_OK(o->process(number("/in/x", k, 1.0)));
  // The late result is still valid and published; then the fallback (offset 1000) takes over.
  EXPECT_EQ(values(sink, "/cdff/budgeted/y"), (std::vector<double>{1, 1001, 1001}));
  EXPECT_EQ(faultsAndRecoveries(sink),
            (Timeline{{EventType::kOverBudget, 0}, {EventType::kSwitchDfi, 0}}));
  EXPECT_EQ(sink.events(EventType::kOverBudget)[0].message,
            "call took 25.000 ms; budget 10.000 ms");
  EXPECT_EQ(sink.events(EventType::kSwitchDfi)[0].message,
            "ProbeRelay/Plain -> ProbeRelay/Alternative");
  const auto timings = sink.timings();
  ASSERT_EQ(timings.size(), 3u);
  EXPECT_DOUBLE_EQ(timings[0].wall_s, 0.025);
  EXPECT_EQ(timings[0].dfi, "Plain");
  EXPECT_DOUBLE_EQ(timings[1].wall_s, 0.004);
  EXPECT_EQ(timings[1].dfi, "Alternative");
  const InstanceStatus relay = o->status("budgeted")->instances[0];
  EXPECT_TRUE(relay.on_fallback);
  EXPECT_EQ(relay.dfi, "Alternative");
}

TEST(Faults, AFallbackThatIsAlsoTooSlowIsARecoveryFailure) {
  const std::string graph = R"(name: budgeted
inputs: [{name: x, type: Double, channel: /in/x}]
outputs: [{name: y, type: Double}]
nodes:
  relay:
    dfn: ProbeRelay
    dfi: Plain
    parameters: {duration_s: 0.025}
    budget_s: 0.010
    fallback: {dfi: Alternative, parameters: {duration_s: 0.020}}
    on_fault: {over_budget: [switch_dfi]}
connections: [x -> relay.a, relay.result -> y]
)";
  MemorySink sink;
  OrchestratorOptions options;
  options.execution_clock = &testing::probeExecutionClock();
  auto o = runningOrchestrator(graph, sink, options);
  ASSERT_TRUE(o);
  for (int k = 0; k < 2; ++k) ASSERT_OK(o->process(number("/in/x", k, 1.0)));
  EXPECT_EQ(faultsAndRecoveries(sink), (Timeline{{EventType::kOverBudget, 0},
                                                 {EventType::kSwitchDfi, 0},
                                                 {EventType::kOverBudget, fromSeconds(1)},
                                                 {EventType::kRecoveryFailed, fromSeconds(1)}}));
  EXPECT_EQ(sink.events(EventType::kRecoveryFailed)[0].message,
            "switch_dfi: already on its fallback Alternative");
}

TEST(Faults, TheFallbackMayBeAFlavourOfTheSameDfi) {
  const std::string graph = R"(name: flavoured
inputs: [{name: x, type: Double, channel: /in/x}]
outputs: [{name: y, type: Double}]
nodes:
  relay:
    dfn: ProbeRelay
    dfi: Plain
    parameters: {fail_above: 10}
    fallback: {dfi: Plain, parameters: {offset: 7, fail_above: 100}}
    on_fault: {error: [switch_dfi]}
connections: [x -> relay.a, relay.result -> y]
)";
  MemorySink sink;
  auto o = runningOrchestrator(graph, sink);
  ASSERT_TRUE(o);
  for (double x : {1.0, 20.0, 20.0}) ASSERT_OK(o->process(number("/in/x", x, x)));
  EXPECT_EQ(values(sink, "/cdff/flavoured/y"), (std::vector<double>{1, 27}));
  EXPECT_EQ(sink.events(EventType::kSwitchDfi)[0].message, "ProbeRelay/Plain -> ProbeRelay/Plain");
  EXPECT_TRUE(o->status("flavoured")->instances[0].on_fallback);
}

// A tracker whose estimate runs away: the divergence recovery declares the track lost and
// re-initialises the tracker, which wakes the detector through the track state.
const std::string kDiverging = R"(name: tracking
inputs: [{name: frame, type: Double, channel: /camera/frame}]
outputs: [{name: pose, type: Double}]
track_state: {from: tracker.status}
nodes:
  detector:
    dfn: ProbeDetector
    dfi: Oracle
    active_when: track_state in [LOST, UNINITIALISED]
  tracker:
    dfn: ProbeTracker
    dfi: Gated
    parameters: {gate: 1000}
    trigger: {on: [measurement]}
    diverged_when: tracker.estimate > 100
    on_fault: {divergence: [set_track_state: LOST, reinitialise]}
connections:
  - frame -> detector.measurement
  - frame -> tracker.measurement
  - detector.detection -> tracker.initial
  - tracker.estimate -> pose
)";

TEST(Faults, ADivergenceFlagIsRecoveredByLosingTheTrackAndWakingTheDetector) {
  MemorySink sink;
  auto o = runningOrchestrator(kDiverging, sink);
  ASSERT_TRUE(o);
  const std::vector<double> frames{1, 50, 99, 150, 2, 3};
  for (std::size_t k = 0; k < frames.size(); ++k)
    ASSERT_OK(o->process(number("/camera/frame", static_cast<double>(k), frames[k])));
  // 150 is never published; the detector re-acquires the target at frame 4.
  EXPECT_EQ(values(sink, "/cdff/tracking/pose"), (std::vector<double>{1, 50, 99, 2, 3}));
  EXPECT_EQ(faultsAndRecoveries(sink), (Timeline{{EventType::kDivergence, fromSeconds(3)},
                                                 {EventType::kSetTrackState, fromSeconds(3)},
                                                 {EventType::kReinitialise, fromSeconds(3)}}));
  std::vector<std::pair<EventType, Timestamp>> detector;
  for (const Event& e : sink.events())
    if (e.kind() == EventKind::kActivation) detector.emplace_back(e.type, e.stamp);
  EXPECT_EQ(detector, (Timeline{{EventType::kDeactivated, fromSeconds(1)},
                                {EventType::kActivated, fromSeconds(4)},
                                {EventType::kDeactivated, fromSeconds(5)}}));
  EXPECT_EQ(o->status("tracking")->track_state, TrackState::kTracking);
}

TEST(Faults, NoProductForTooLongIsAFaultInStreamTime) {
  const std::string graph = R"(name: watched
inputs: [{name: x, type: Double, channel: /in/x}]
outputs:
  - name: y
    type: Double
    timeout_s: 1.0
    on_timeout: [{reinitialise: relay}, {set_track_state: LOST}]
nodes:
  relay: {dfn: ProbeRelay, dfi: Plain}
connections: [x -> relay.a, relay.result -> y]
)";
  MemorySink sink;
  auto o = runningOrchestrator(graph, sink);
  ASSERT_TRUE(o);
  ASSERT_OK(o->process(number("/in/x", 0.0, 1)));
  ASSERT_OK(o->process(number("/in/x", 0.5, 1)));
  // The input goes silent; other channels still move stream time for every DFPC.
  for (double t : {1.0, 1.5, 1.6, 2.0, 2.5, 2.7, 2.8})
    ASSERT_OK(o->process(number("/other", t, 0)));
  EXPECT_EQ(faultsAndRecoveries(sink), (Timeline{{EventType::kNoProduct, fromSeconds(1.6)},
                                                 {EventType::kReinitialise, fromSeconds(1.6)},
                                                 {EventType::kSetTrackState, fromSeconds(1.6)},
                                                 {EventType::kNoProduct, fromSeconds(2.7)},
                                                 {EventType::kReinitialise, fromSeconds(2.7)},
                                                 {EventType::kSetTrackState, fromSeconds(2.7)}}));
  EXPECT_EQ(sink.events(EventType::kNoProduct)[0].message,
            "output 'y' produced nothing for 1.100 s (timeout 1 s)");
  // A product re-arms the watchdog.
  ASSERT_OK(o->process(number("/in/x", 3.0, 1)));
  ASSERT_OK(o->process(number("/other", 3.9, 0)));
  EXPECT_EQ(sink.events(EventType::kNoProduct).size(), 2u);
}

TEST(Faults, WakeRunsASleepingInstanceUntilItCompletesARun) {
  const std::string graph = R"(name: woken
inputs: [{name: frame, type: Double, channel: /camera/frame}]
outputs: [{name: detection, type: Double}]
nodes:
  detector:
    dfn: ProbeDetector
    dfi: Oracle
    active_when: track_state == DEGRADED  # never: no track state is declared
  tracker:
    dfn: ProbeTracker
    dfi: Gated
    trigger: {on: [measurement]}
    diverged_when: tracker.status == UNINITIALISED
    on_fault: {divergence: [{wake: detector}]}
connections:
  - frame -> detector.measurement
  - frame -> tracker.measurement
  - detector.detection -> detection
)";
  MemorySink sink;
  auto o = runningOrchestrator(graph, sink);
  ASSERT_TRUE(o);
  for (int k = 0; k < 4; ++k) ASSERT_OK(o->process(number("/camera/frame", k, 7.0 + k)));
  // Frame 0: detector asleep, tracker uninitialised (divergence) -> wake. Frame 1: the woken
  // detector runs once (and the tracker, still uninitialised, wakes it again), and so on.
  EXPECT_EQ(values(sink, "/cdff/woken/detection"), (std::vector<double>{8, 9, 10}));
  EXPECT_EQ(sink.events(EventType::kWake).size(), 4u);
  const auto activation = sink.events(EventType::kActivated);
  ASSERT_FALSE(activation.empty());
  EXPECT_EQ(activation[0].stamp, fromSeconds(1));
  EXPECT_NE(activation[0].message.find("woken"), std::string::npos);
}

}  // namespace
}  // namespace cdff::dfpc
