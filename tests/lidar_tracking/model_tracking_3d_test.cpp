// End to end: dfpcs/model_tracking_3d.yaml (every scan a detection with no prior, the poses
// filtered by the EKF) on the simulator's mid-range approach (VLP-16 scans of the procedural
// target, 15 -> 2 m), and dfpcs/model_tracking_3d_tof.yaml on the ToF camera's depth maps of the
// close-range approach, the CI draws of the evaluation set (data/evaluation/draws.yaml: each its
// own simulator seed), with no initial state. The correct pose: within 5 % of the range
// and 5 degrees; no pose product reported TRACKING may be off by more.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "lidar_tracking_support.hpp"
#include "support/synthetic.hpp"

namespace cdff::lidar_tracking {
namespace {

constexpr double kMostPct = 5.0, kMostDeg = 5.0;
/// Simulated seconds per draw: 2 s to start and as much again tracked.
constexpr double kDuration = 4.0;

/// What the CI draws of one scenario gave through one graph.
struct Tally {
  std::size_t draws = 0, tracking_draws = 0, tracking = 0, wrong = 0;
  std::size_t mostly_fused = 0;  // draws that fused at least 80 % of their sensor frames
  double worst_deg = 0, worst_pct = 0;
};

/// Runs `graph` with no initial state over the CI draws of `scenario` (with `overrides`),
/// printing one line per draw and the totals.
Tally runDraws(const std::string& scenario, const std::vector<std::string>& overrides,
               const std::string& graph) {
  Tally t;
  for (const eval::Draw& draw : drawSets().ciDraws()) {
    SCOPED_TRACE("draw " + std::to_string(draw.number));
    Result<SimulatedRun> run = simulate(scenario, kDuration, "", draw.simulator_seed, overrides);
    EXPECT_OK(run.status());
    if (!run) continue;
    Result<TrackingResult> r = trackWithoutPrior(*run, run->messages, 0, {}, graph);
    EXPECT_OK(r.status());
    if (!r) continue;
    if (std::getenv("CDFF_TEST_VERBOSE"))
      for (const dfpc::Event& e : r->events)
        if (e.kind() != dfpc::EventKind::kLifecycle ||
            e.type == dfpc::EventType::kTrackStateChanged)
          std::printf("  %s %s: %s\n", e.instance.c_str(), std::string(toString(e.type)).c_str(),
                      e.message.c_str());
    Result<ReportedTracking> reported = reportedTracking(*r, run->truth);
    EXPECT_OK(reported.status());
    if (!reported) continue;
    std::size_t draw_wrong = 0;
    for (const eval::MatchedError& m : reported->errors)
      draw_wrong +=
          m.angle_error_deg > kMostDeg || 100.0 * m.position_error_m / m.range_m > kMostPct;
    std::printf(
        "draw %llu: %zu poses TRACKING (%zu wrong), worst %.2f deg %.2f %% of range, "
        "%zu of %zu frames fused\n",
        static_cast<unsigned long long>(draw.number), reported->errors.size(), draw_wrong,
        reported->worst_deg, reported->worst_pct, r->accepted, r->scans);
    ++t.draws;
    t.tracking_draws += !reported->errors.empty();
    t.mostly_fused += r->accepted >= 0.8 * static_cast<double>(r->scans);
    t.tracking += reported->errors.size();
    t.wrong += draw_wrong;
    t.worst_deg = std::max(t.worst_deg, reported->worst_deg);
    t.worst_pct = std::max(t.worst_pct, reported->worst_pct);
  }
  std::printf(
      "%zu draws: %zu TRACKING, %zu TRACKING poses, %zu off by more than 5 %% / 5 deg; "
      "worst %.2f deg, %.2f %% of range\n",
      t.draws, t.tracking_draws, t.tracking, t.wrong, t.worst_deg, t.worst_pct);
  return t;
}

TEST(ModelTracking3d, MidRangeApproachWithNoPriorIsTrackedWithinTheCorrectPoseBounds) {
  const Tally t = runDraws("mid_range_approach", {}, "model_tracking_3d");
  ASSERT_EQ(t.draws, drawSets().ci);
  EXPECT_EQ(t.tracking_draws, t.draws);
  EXPECT_EQ(t.wrong, 0u);
  // Every draw fuses at least 80 % of its scans (today 36-39 of 41).
  EXPECT_EQ(t.mostly_fused, t.draws);
}

// dfpcs/model_tracking_3d_tof.yaml on the ToF camera's depth maps of the close-range approach
// (the LIDAR off; about 3 m from the target's centre in these 4 s, where a VLP-16 scan shows too
// little to tell the box target from its near-symmetric twin), no initial state: the dense
// depth does.
TEST(ModelTracking3d, CloseRangeApproachOnToFDepthMapsWithNoPrior) {
  const Tally t =
      runDraws("close_range_approach", {"sensors.tof.enabled=true", "sensors.lidar.enabled=false"},
               "model_tracking_3d_tof");
  ASSERT_EQ(t.draws, drawSets().ci);
  EXPECT_EQ(t.tracking_draws, t.draws);
  EXPECT_EQ(t.wrong, 0u);
  // Every draw fuses at least 80 % of its depth maps (today 39 of 41: the first two fill the
  // verification's window of 3) and stays well inside the goal (today 0.20 deg, 0.14 %).
  EXPECT_EQ(t.mostly_fused, t.draws);
  EXPECT_LT(t.worst_deg, 1.0);
  EXPECT_LT(t.worst_pct, 1.0);
}

}  // namespace
}  // namespace cdff::lidar_tracking
