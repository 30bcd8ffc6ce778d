// The visual tracking DFPCs' acquisition (mono and stereo graphs) over the CI draws (the first
// evaluation draws of data/evaluation/draws.yaml): each draw simulates the scenario with its own
// seed and starts the DFPC from its own Gaussian initial error of RMS 5 % of the range and 5
// degrees with an unknown twist (sigmas 0.3 m/s and 0.1 rad/s: the filter is told so), stamped at
// the first image, which is not tracked (as `cdff initial-state --at` and `cdff run` do it). The
// camera runs at 2 Hz, over the first 10 s of each approach (the acquisition, its confirmation and
// any recovery). All 50 evaluation draws run in bench/visual_tracking_accuracy_bench.cpp (figures
// in docs/visual-tracking.md).
//
// Asserted per draw: tracked (some frame valid: TRACKING or DEGRADED, after the confirmation), no
// valid frame off by more than 5 % of the range or 10 degrees (a wrong acquisition reported as a
// track), no loss once tracked. Over the draws, beside the goal (issue 16: >= 98 % of the draws
// acquire, a failed acquisition recovers within 2 s), bounds near today's figures on these draws
// (2026-12-04) so that a regression fails: the share of draws tracked within 2 s and of draws
// tracked at their first acquisition (one draw of slack), the slowest draw's time to track, and
// the p95 errors of the valid frames (1.5x today's).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "simulated_approach.hpp"
#include "support/synthetic.hpp"

namespace cdff::visual_demo {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct Bounds {
  double tracked_within_2s = 1.0;  // fraction of the draws, at least
  double first_confirmed = 1.0;    // fraction of the draws, at least
  double worst_time_to_track_s = 0;
  double position_p95_pct = 0;  // over all draws' valid frames
  double angle_p95_deg = 0;
};

struct Figures {
  std::size_t draws = 0, tracked = 0, within_2s = 0, first_confirmed = 0;
  double worst_time_to_track_s = 0;
  std::vector<double> pct, deg;
};

Figures runDraws(const std::string& scenario, bool stereo = false) {
  Figures f;
  Result<eval::DrawSets> sets = drawSets();
  EXPECT_OK(sets.status());
  if (!sets) return f;
  for (const eval::Draw& draw : sets->ciDraws()) {
    SCOPED_TRACE(::testing::Message()
                 << scenario << (stereo ? " (stereo)" : "") << ", draw " << draw.number);
    ApproachOptions options = drawOptions(draw, scenario, 10.0, 0.05, 5 * kDeg, 0.3, 0.1);
    options.stereo = stereo;
    Result<ApproachResult> r = runApproach(options);
    EXPECT_OK(r.status());
    if (!r) continue;
    const AcquisitionOutcome a = acquisitionOutcome(*r);
    ++f.draws;
    EXPECT_TRUE(a.tracked);
    EXPECT_EQ(a.wrong_frames, 0u);
    EXPECT_EQ(a.lost_after_track, 0u);
    EXPECT_EQ(r->dfn_errors, 0u);
    f.tracked += a.tracked;
    f.within_2s += a.tracked && a.time_to_track_s <= 2.0;
    f.first_confirmed += a.first_acquisition_confirmed;
    if (a.tracked) f.worst_time_to_track_s = std::max(f.worst_time_to_track_s, a.time_to_track_s);
    f.pct.insert(f.pct.end(), a.position_error_pct.begin(), a.position_error_pct.end());
    f.deg.insert(f.deg.end(), a.angle_error_deg.begin(), a.angle_error_deg.end());
    std::printf("%s draw %llu: time to track %.1f s%s, %zu of %zu frames valid\n", scenario.c_str(),
                static_cast<unsigned long long>(draw.number), a.time_to_track_s,
                a.first_acquisition_confirmed ? " (first acquisition confirmed)" : "",
                a.valid_frames, a.frames);
  }
  return f;
}

void expectWithin(const Figures& f, const Bounds& b) {
  ASSERT_GT(f.draws, 0u);
  ASSERT_FALSE(f.pct.empty());
  const double n = static_cast<double>(f.draws);
  const double pct = eval::ErrorStatistics::of(f.pct).p95;
  const double deg = eval::ErrorStatistics::of(f.deg).p95;
  std::printf(
      "%zu draws: %zu tracked, %zu within 2 s, %zu at the first acquisition; slowest %.1f s; "
      "p95 %.3f %% of the range, %.3f deg\n",
      f.draws, f.tracked, f.within_2s, f.first_confirmed, f.worst_time_to_track_s, pct, deg);
  ::testing::Test::RecordProperty("tracked_within_2s", std::to_string(f.within_2s / n));
  ::testing::Test::RecordProperty("worst_time_to_track_s", std::to_string(f.worst_time_to_track_s));
  EXPECT_EQ(f.tracked, f.draws);
  EXPECT_GE(f.within_2s / n, b.tracked_within_2s);
  EXPECT_GE(f.first_confirmed / n, b.first_confirmed);
  EXPECT_LE(f.worst_time_to_track_s, b.worst_time_to_track_s);
  EXPECT_LE(pct, b.position_p95_pct);
  EXPECT_LE(deg, b.angle_p95_deg);
}

// Today (2026-12-04, restarts and the anchor): all 8 draws tracked at the first acquisition
// (confirmed by the second frame, 0.5 s), no wrong frame, p95 0.036 % of the range (1.1 mm at
// 2.7-3.1 m) and 0.071 deg. One draw may need a second acquisition; the recovery bound is the
// goal's 2 s.
TEST(VisualAcquisitionDraws, CloseRange) {
  Bounds b;
  b.tracked_within_2s = 1.0;
  b.first_confirmed = 7.0 / 8;
  b.worst_time_to_track_s = 2.0;
  b.position_p95_pct = 0.054;
  b.angle_p95_deg = 0.11;
  expectWithin(runDraws("close_range_approach"), b);
}

// Today (2026-12-04, restarts and the anchor): all 8 draws tracked at the first acquisition
// (0.5 s; 6 before), no wrong frame, p95 0.42 % of the range (at 16-17 m) and 0.40 deg; the
// mid-range goal is 1 % and 1 deg. One draw may need a second acquisition.
TEST(VisualAcquisitionDraws, MidRange) {
  Bounds b;
  b.tracked_within_2s = 1.0;
  b.first_confirmed = 7.0 / 8;
  b.worst_time_to_track_s = 2.0;
  b.position_p95_pct = 0.62;
  b.angle_p95_deg = 0.6;
  expectWithin(runDraws("mid_range_approach"), b);
}

// The stereo graph (dfpcs/visual_tracking_stereo.yaml) on the same draws. Today (2026-12-05): all
// 8 close-range draws at the first acquisition, p95 0.023 % of the range (0.7 mm) and 0.053 deg;
// at mid range 7 of 8 at the first acquisition (900003 at 1.0 s), p95 0.304 % and 0.380 deg. Over
// the 50 evaluation draws the stereo mid range reports one wrong acquisition (900024, not a CI
// draw; docs/visual-tracking.md).
TEST(VisualAcquisitionDraws, CloseRangeStereo) {
  Bounds b;
  b.tracked_within_2s = 1.0;
  b.first_confirmed = 7.0 / 8;
  b.worst_time_to_track_s = 2.0;
  b.position_p95_pct = 0.035;
  b.angle_p95_deg = 0.08;
  expectWithin(runDraws("close_range_approach", true), b);
}

TEST(VisualAcquisitionDraws, MidRangeStereo) {
  Bounds b;
  b.tracked_within_2s = 1.0;
  b.first_confirmed = 6.0 / 8;
  b.worst_time_to_track_s = 2.0;
  b.position_p95_pct = 0.46;
  b.angle_p95_deg = 0.57;
  expectWithin(runDraws("mid_range_approach", true), b);
}

}  // namespace
}  // namespace cdff::visual_demo
