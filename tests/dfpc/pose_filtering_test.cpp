// End to end: dfpcs/pose_filtering.yaml on a simulated relative trajectory with ground truth,
// through the Orchestrator, with a divergence (the measurements jump) and its recovery.
#include <gtest/gtest.h>

#include <random>

#include <fmt/format.h>

#include "cdff/types/statistics.hpp"
#include "test_helpers.hpp"

namespace cdff::dfpc {
namespace {

const std::string kGraph = std::string(CDFF_SOURCE_DIR) + "/dfpcs/pose_filtering.yaml";

// A target 10 m ahead drifting at 5 cm/s and tumbling at 2 deg/s in the servicer frame; from
// t = jump_at its measured position is offset by `jump` (the tracker locked onto another part).
struct Scenario {
  Eigen::Vector3d p0{1.0, -0.5, 10.0};
  Eigen::Vector3d v{0.05, -0.02, 0.01};
  Eigen::Vector3d w = Eigen::Vector3d(1, 2, 0.5).normalized() * (2.0 * M_PI / 180.0);
  double sigma_p = 0.05, sigma_r = 1.0 * M_PI / 180.0;
  double jump_at = 1e9;
  Eigen::Vector3d jump = Eigen::Vector3d::Zero();

  Eigen::Vector3d position(double t) const {
    return p0 + v * t + (t >= jump_at ? jump : Eigen::Vector3d::Zero());
  }
  Eigen::Quaterniond rotation(double t) const { return expSO3(w * t); }
};

MemoryStream measurements(const Scenario& s, double duration, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  MemoryStream stream;
  for (int k = 0; 0.1 * k <= duration + 1e-9; ++k) {
    const double t = 0.1 * k;
    PoseWithCovariance z;
    z.pose = Transform::identity("servicer", "target", fromSeconds(t));
    z.pose.translation = s.position(t) + s.sigma_p * Eigen::Vector3d(n(rng), n(rng), n(rng));
    z.pose.rotation = expSO3(s.sigma_r * Eigen::Vector3d(n(rng), n(rng), n(rng))) * s.rotation(t);
    z.covariance.diagonal() << Eigen::Vector3d::Constant(s.sigma_p * s.sigma_p),
        Eigen::Vector3d::Constant(s.sigma_r * s.sigma_r);
    stream.add(Message::of("/chaser/target_pose_measurement", z.pose.stamp, z));
    PoseWithCovariance truth{Transform::identity("servicer", "target", fromSeconds(t)),
                             Matrix6d::Zero()};
    truth.pose.translation = s.position(t);
    truth.pose.rotation = s.rotation(t);
    stream.add(Message::of("/truth/target_pose", truth.pose.stamp, truth));
  }
  return stream;
}

struct Errors {
  double position_rmse = 0, attitude_rmse = 0, mean_nees = 0;
  int samples = 0;
};

// Errors of the state products in [from, to) s against the truth.
Errors errors(const MemorySink& sink, const Scenario& s, double from, double to) {
  Errors e;
  double p2 = 0, r2 = 0, nees = 0;
  for (const Message& m : sink.messages("/cdff/pose_filtering/state")) {
    const double t = toSeconds(m.stamp);
    if (t < from || t >= to) continue;
    const RigidBodyState& x = *m.as<RigidBodyState>();
    Vector6d err;
    err.head<3>() = x.pose.translation - s.position(t);
    err.tail<3>() = logSO3(x.pose.rotation * s.rotation(t).conjugate());
    p2 += err.head<3>().squaredNorm();
    r2 += err.tail<3>().squaredNorm();
    nees += err.dot(x.covariance.topLeftCorner<6, 6>().ldlt().solve(err));
    ++e.samples;
  }
  e.position_rmse = std::sqrt(p2 / e.samples);
  e.attitude_rmse = std::sqrt(r2 / e.samples);
  e.mean_nees = nees / e.samples;
  return e;
}

TEST(PoseFilteringDfpc, FiltersMeasurementsAtASteadyRateWithConsistentUncertainty) {
  const Scenario scenario;
  MemoryStream input = measurements(scenario, 30.0, 7);
  MemorySink sink;
  OrchestratorOptions options;
  options.sink = &sink;
  options.passthrough_prefixes = {"/truth/"};
  Orchestrator o(options);
  ASSERT_OK(o.addGraphFile(kGraph));
  ASSERT_OK(o.startAll());
  Result<RunSummary> summary = o.run(input);
  ASSERT_OK(summary.status());
  // No fault, except that a call may overrun its 20 ms budget when the machine preempts the
  // test (an EKF step takes tens of microseconds): tolerated on 1 % of the calls.
  std::size_t over_budget = 0;
  for (const Event& e : sink.events()) {
    if (e.type == EventType::kOverBudget)
      ++over_budget;
    else
      EXPECT_NE(e.kind(), EventKind::kFault) << toString(e.type) << ": " << e.message;
  }
  EXPECT_LT(over_budget, sink.timings().size() / 100);

  // 301 measurements, and a prediction every 50 ms in between: a state every 1/30 s or so.
  const auto states = sink.messages("/cdff/pose_filtering/state");
  EXPECT_EQ(states.size(), 301u + 600u);
  EXPECT_EQ(sink.messages("/truth/target_pose").size(), 301u);
  for (std::size_t i = 1; i < states.size(); ++i)
    ASSERT_LE(states[i].stamp - states[i - 1].stamp, fromSeconds(0.05));

  // After 5 s of convergence: well below the measurement noise (5 cm, 1 deg per axis: an RMS of
  // 8.7 cm and 1.7 deg over the three axes), and a NEES near its 6 degrees of freedom.
  const Errors e = errors(sink, scenario, 5.0, 31.0);
  RecordProperty("position_rmse_mm", std::to_string(e.position_rmse * 1e3));
  RecordProperty("attitude_rmse_deg", std::to_string(e.attitude_rmse * 180 / M_PI));
  RecordProperty("mean_nees", std::to_string(e.mean_nees));
  EXPECT_LT(e.position_rmse, 0.5 * std::sqrt(3.0) * scenario.sigma_p);
  EXPECT_LT(e.attitude_rmse, 0.5 * std::sqrt(3.0) * scenario.sigma_r);
  EXPECT_GT(e.mean_nees, 2.0);
  EXPECT_LT(e.mean_nees, 12.0);

  // The Data Product Manager holds the latest 600 states; its interpolation between two of them
  // is as good as the states themselves.
  Result<PoseWithCovariance> mid = o.products().poseAt("pose_filtering/state", fromSeconds(25.013));
  ASSERT_OK(mid.status());
  EXPECT_LT((mid->pose.translation - scenario.position(25.013)).norm(), 0.1);
  EXPECT_EQ(o.products().history("pose_filtering/state")->size(), 600u);

  // Every call was timed.
  EXPECT_EQ(sink.timings().size(), states.size());
}

TEST(PoseFilteringDfpc, AJumpInTheMeasurementsIsADivergenceAndTheFilterRestarts) {
  Scenario scenario;
  scenario.jump_at = 15.0;
  scenario.jump = Eigen::Vector3d(0, 2.0, 0);
  MemoryStream input = measurements(scenario, 30.0, 11);
  MemorySink sink;
  OrchestratorOptions options;
  options.sink = &sink;
  Orchestrator o(options);
  ASSERT_OK(o.addGraphFile(kGraph));
  ASSERT_OK(o.startAll());
  ASSERT_OK(o.run(input).status());

  const auto divergences = sink.events(EventType::kDivergence);
  ASSERT_EQ(divergences.size(), 1u);
  EXPECT_EQ(divergences[0].stamp, fromSeconds(15.0));
  const auto recoveries = sink.events(EventType::kReinitialise);
  ASSERT_EQ(recoveries.size(), 1u);
  EXPECT_EQ(recoveries[0].stamp, fromSeconds(15.0));
  // The prediction at 15.0 s came before the jumped measurement; after it, no state is published
  // until the next measurement (15.1 s) restarts the filter.
  std::size_t in_gap = 0;
  for (const Message& m : sink.messages("/cdff/pose_filtering/state"))
    if (m.stamp > fromSeconds(15.0) && m.stamp < fromSeconds(15.1)) ++in_gap;
  EXPECT_EQ(in_gap, 0u);
  const Errors before = errors(sink, scenario, 5.0, 15.0);
  const Errors after = errors(sink, scenario, 20.0, 31.0);
  EXPECT_LT(before.position_rmse, 0.5 * std::sqrt(3.0) * scenario.sigma_p);
  EXPECT_LT(after.position_rmse, 0.5 * std::sqrt(3.0) * scenario.sigma_p);
  EXPECT_EQ(sink.events(EventType::kNoProduct).size(), 0u);
  EXPECT_EQ(sink.events(EventType::kDfnError).size(), 0u);
}

// The EKF with a chi-square gate (6 dof, 0.999): a measurement gated out is a divergence fault.
// The prediction ticks between the measurements are clean calls, so three rejections in a row
// of the measurements are never three consecutive faults of the instance; counted within a
// window of stream time they are, and the recovery re-initialises the filter, which restarts
// from the next (jumped) measurement.
std::string gatedGraph(const std::string& recovery) {
  return fmt::format(R"(name: pose_filtering
inputs: [{{name: pose, type: PoseWithCovariance, channel: /chaser/target_pose_measurement}}]
outputs: [{{name: state, type: RigidBodyState}}]
nodes:
  ekf:
    dfn: EstimationFilter
    dfi: ExtendedKalman
    parameters: {{angular_acceleration_psd: 1.0e-5, innovation_gate: 22.46}}
    trigger: {{on: [pose_measurement], period_s: 0.05, time_input: time, tick_when: ekf.state != unset}}
    diverged_when: ekf.measurement_accepted == false and ekf.innovation_nis > 22.46
    on_fault: {{divergence: {}}}
connections: [pose -> ekf.pose_measurement, ekf.state -> state]
)",
                     recovery);
}

std::vector<Event> runGated(const std::string& recovery, const Scenario& scenario) {
  MemoryStream input = measurements(scenario, 20.0, 12);
  MemorySink sink;
  auto o = testing::runningOrchestrator(gatedGraph(recovery), sink);
  EXPECT_TRUE(o);
  if (!o) return {};
  EXPECT_OK(o->run(input).status());
  std::vector<Event> out;
  for (const Event& e : sink.events())
    if (e.type == EventType::kDivergence || e.type == EventType::kReinitialise) out.push_back(e);
  return out;
}

TEST(PoseFilteringDfpc, RejectionsCountedWithinAWindowFireTheDivergenceRecovery) {
  // A 0.5 m jump at 15 s: 10 sigma of the measurement noise, NIS about 100, gated out (but far
  // below the 1000 of the graph's outright divergence).
  Scenario scenario;
  scenario.jump_at = 15.0;
  scenario.jump = Eigen::Vector3d(0, 0.5, 0);
  const std::vector<Event> windowed =
      runGated("{after: 3, within_s: 0.5, do: [reinitialise]}", scenario);
  std::vector<std::pair<EventType, Timestamp>> got;
  for (const Event& e : windowed) got.emplace_back(e.type, e.stamp);
  EXPECT_EQ(got, (std::vector<std::pair<EventType, Timestamp>>{
                     {EventType::kDivergence, fromSeconds(15.0)},
                     {EventType::kDivergence, fromSeconds(15.1)},
                     {EventType::kDivergence, fromSeconds(15.2)},
                     {EventType::kReinitialise, fromSeconds(15.2)}}));
  // Counted as consecutive faults, the ticks in between end every run of faults: the filter
  // does not recover: it rejects the measurements after the jump until its coasted prediction
  // has grown wide enough to take them, seconds later.
  const std::vector<Event> consecutive = runGated("{after: 3, do: [reinitialise]}", scenario);
  std::size_t divergences = 0, reinitialisations = 0;
  for (const Event& e : consecutive) {
    divergences += e.type == EventType::kDivergence;
    reinitialisations += e.type == EventType::kReinitialise;
  }
  EXPECT_EQ(reinitialisations, 0u);
  EXPECT_GE(divergences, 10u);
}

TEST(PoseFilteringDfpc, NoMeasurementsIsANoProductFault) {
  MemoryStream input;
  for (int k = 0; k <= 50; ++k) input.add(testing::number("/other/clock", 0.1 * k, 0));
  MemorySink sink;
  OrchestratorOptions options;
  options.sink = &sink;
  Orchestrator o(options);
  ASSERT_OK(o.addGraphFile(kGraph));
  ASSERT_OK(o.startAll());
  // The pose channel is missing from this input: the run refuses to start.
  EXPECT_EQ(o.run(input).status().code(), StatusCode::kNotFound);
  // Message by message (a live system), the watchdog reports the silence every 2 s.
  for (int k = 0; k <= 50; ++k) ASSERT_OK(o.process(testing::number("/other/clock", 0.1 * k, 0)));
  std::vector<Timestamp> at;
  for (const Event& e : sink.events(EventType::kNoProduct)) at.push_back(e.stamp);
  EXPECT_EQ(at, (std::vector<Timestamp>{fromSeconds(2.1), fromSeconds(4.2)}));
}

// The graph of dfpcs/pose_filtering.yaml written in C++ (docs/dfpc.md): the same products.
TEST(PoseFilteringDfpc, TheSameGraphBuiltInCppGivesTheSameProducts) {
  GraphBuilder g("pose_filtering");
  RecoveryAction reinitialise;
  reinitialise.kind = RecoveryActionKind::kReinitialise;
  g.input("pose", "PoseWithCovariance", "/chaser/target_pose_measurement");
  g.output("state", "RigidBodyState", "", "target_state");
  g.output("nis", "Double");
  g.node("ekf", "EstimationFilter", "ExtendedKalman")
      .parameters(
          "{linear_acceleration_psd: 1.0e-4, angular_acceleration_psd: 1.0e-5, "
          "max_prediction_interval: 10}")
      .on({"pose_measurement"})
      .every(0.05, "time", "ekf.state != unset")
      .divergedWhen("ekf.innovation_nis > 1000")
      .onFault(FaultKind::kDivergence, {reinitialise});
  g.connect("pose", "ekf.pose_measurement")
      .connect("ekf.state", "state")
      .connect("ekf.innovation_nis", "nis");
  Result<std::unique_ptr<Dfpc>> built = Dfpc::create(g.spec());
  ASSERT_OK(built.status());

  Scenario scenario;
  scenario.jump_at = 4.0;
  scenario.jump = Eigen::Vector3d(0, 2.0, 0);
  auto run = [&](std::unique_ptr<Dfpc> dfpc, MemorySink& sink) {
    MemoryStream input = measurements(scenario, 8.0, 3);
    OrchestratorOptions options;
    options.sink = &sink;
    options.record_timing = false;
    Orchestrator o(options);
    ASSERT_OK(o.add(std::move(dfpc)));
    ASSERT_OK(o.startAll());
    ASSERT_OK(o.run(input).status());
  };
  MemorySink from_cpp, from_yaml;
  run(std::move(built).value(), from_cpp);
  Result<GraphSpec> yaml = loadGraphFile(kGraph);
  ASSERT_OK(yaml.status());
  Result<std::unique_ptr<Dfpc>> loaded = Dfpc::create(std::move(yaml).value());
  ASSERT_OK(loaded.status());
  run(std::move(loaded).value(), from_yaml);

  const auto a = from_cpp.messages("/cdff/pose_filtering/state");
  const auto b = from_yaml.messages("/cdff/pose_filtering/state");
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 200u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].stamp, b[i].stamp);
    EXPECT_EQ(a[i].as<RigidBodyState>()->pose.translation,
              b[i].as<RigidBodyState>()->pose.translation);
  }
  EXPECT_EQ(from_cpp.events(EventType::kDivergence).size(), 1u);
  EXPECT_EQ(from_yaml.events(EventType::kDivergence).size(), 1u);
}

}  // namespace
}  // namespace cdff::dfpc
