// End to end: the visual tracking DFPC on the simulator's approaches (1624x1234 cameras, the
// procedural target satellite, its .cao export as the model), through the Orchestrator, from the
// true pose perturbed by 5 % of the range and 5 degrees, evaluated with src/cdff/eval. The camera
// runs at 2 Hz instead of 10 to keep the simulation affordable in CI (the tracker's frame-to-frame
// motion is then five times larger than at 10 Hz, which only makes the test harder).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "cdff/eval/draws.hpp"
#include "simulated_approach.hpp"
#include "support/synthetic.hpp"

namespace cdff::visual_demo {
namespace {

void record(const std::string& tag, const ApproachResult& r) {
  ::testing::Test::RecordProperty(tag + "_frames", std::to_string(r.frames));
  ::testing::Test::RecordProperty(tag + "_lost", std::to_string(r.lost));
  ::testing::Test::RecordProperty(tag + "_degraded", std::to_string(r.degraded));
  ::testing::Test::RecordProperty(tag + "_position_p95_mm",
                                  std::to_string(r.filtered.position_error_m.p95 * 1e3));
  ::testing::Test::RecordProperty(tag + "_position_p95_pct_range",
                                  std::to_string(r.filtered.position_error_pct_range.p95));
  ::testing::Test::RecordProperty(tag + "_angle_p95_deg",
                                  std::to_string(r.filtered.angle_error_deg.p95));
  ::testing::Test::RecordProperty(tag + "_cpu_per_frame_ms",
                                  std::to_string(r.mean_cpu_per_frame_s * 1e3));
  std::printf("%s\n", summaryLine(tag, r).c_str());
  const eval::CovarianceConsistency& m = r.measurement.covariance;
  const eval::CovarianceConsistency& f = r.filtered.covariance;
  std::printf(
      "  NEES mean (6 if honest): measurement %.2f (position %.2f, attitude %.2f, %.1f %% "
      "within the 95 %% bound), filtered pose %.2f (%.1f %%)\n",
      m.nees_mean, m.position_nees_mean, m.attitude_nees_mean, 100 * m.within_95_fraction,
      f.nees_mean, 100 * f.within_95_fraction);
  std::printf("  CPU per frame: max %.1f ms (usually the acquisition frame)\n",
              r.cpu_per_frame_s.max * 1e3);
  if (r.lost > 0)  // why frames were lost: the DFNs' first warnings
    for (const std::string& w : r.warnings) std::printf("  warning: %s\n", w.c_str());
}

// Tracked throughout (no frame LOST, no divergence left unreported, no DFN error) over at least
// `min_frames` frames, within the mid-range goals: position p95 <= 1 % of the range, angle p95 <=
// 1 degree.
void expectTrackedWithinTheMidRangeGoals(const ApproachResult& r, std::size_t min_frames) {
  EXPECT_GE(r.frames, min_frames);
  EXPECT_EQ(r.lost, 0u);
  EXPECT_EQ(r.unreported_divergence, 0u);
  EXPECT_LE(r.filtered.position_error_pct_range.p95, 1.0);
  EXPECT_LE(r.filtered.angle_error_deg.p95, 1.0);
  EXPECT_EQ(r.dfn_errors, 0u);
}

// The covariance's goal (docs/visual-tracking.md, "Covariance"): a pose NEES mean within a factor
// 2 of 6 (honest: 6), for the tracker's measurement and the filtered pose; and a regression
// bound, 1.5 x `measured` (the largest measured on 2026-12-04: of the evaluation draws in the draw
// tests).
void expectHonestCovariance(const ApproachResult& r, double measured) {
  for (const eval::CovarianceConsistency* c : {&r.measurement.covariance, &r.filtered.covariance}) {
    EXPECT_GT(c->count, 0u);
    EXPECT_GE(c->nees_mean, 3.0);
    EXPECT_LE(c->nees_mean, 12.0);
    EXPECT_LE(c->nees_mean, 1.5 * measured);
  }
}

// Close range, 2 m -> 0.5 m from the adapter ring (issue: position p95 <= 10 mm, angle p95 <=
// 0.5 deg).
TEST(VisualTrackingSimulated, CloseRangeApproachMono) {
  ApproachOptions o;
  o.scenario = "close_range_approach";
  Result<ApproachResult> r = runApproach(o);
  ASSERT_OK(r.status());
  record("close_range_mono", *r);
  EXPECT_GE(r->frames, 100u);
  EXPECT_EQ(r->lost, 0u);
  EXPECT_EQ(r->unreported_divergence, 0u);
  EXPECT_LE(r->filtered.position_error_m.p95, 0.010);
  EXPECT_LE(r->filtered.angle_error_deg.p95, 0.5);
  EXPECT_EQ(r->dfn_errors, 0u);
  expectHonestCovariance(*r, 4.2);
}

// Mid range, 17 m -> 2 m, from the prescribed 5 % / 5 degree initial error (issue: position p95
// <= 1 % of the range; angle p95 <= 1 degree, the edge-tracking goal of the Castle-simu test). At
// 17 m that error moves the model's image beyond the edge searches; the DFI's coarse alignment
// (acquisition_coarse_search, an oriented chamfer search over image shift and scale) brings it
// within them, and the whole approach is then tracked without a loss.
TEST(VisualTrackingSimulated, MidRangeApproachFromAPerturbedPoseIsAcquiredAndTracked) {
  ApproachOptions o;
  o.scenario = "mid_range_approach";
  o.camera_rate = 2.0;
  // On in dfpcs/visual_tracking.yaml too; set here so that the test keeps asking for it.
  o.dfi_parameters = "{acquisition_coarse_search: true}";
  Result<ApproachResult> r = runApproach(o);
  ASSERT_OK(r.status());
  record("mid_range_mono_5pct_full", *r);
  expectTrackedWithinTheMidRangeGoals(*r, 170u);
  expectHonestCovariance(*r, 4.4);
}

// The same acquisition through the stereo graph (acquisition_coarse_search on there too: the
// search aligns the left image's edges, the acquisition passes below full resolution use the left
// camera, those at full resolution both): the first 20 s of the mid-range approach (17 m -> about
// 16 m, where the 5 % / 5 degree error moves the model farthest beyond the edge searches) at
// 2 Hz, 0 lost, within the mid-range goals. Not the whole approach: rendering both cameras
// doubles the simulation, and the tracking after the acquisition is that of the mono test.
TEST(VisualTrackingSimulated, MidRangeStereoApproachFromAPerturbedPoseIsAcquired) {
  ApproachOptions o;
  o.scenario = "mid_range_approach";
  o.stereo = true;
  o.camera_rate = 2.0;
  o.duration = 20;
  Result<ApproachResult> r = runApproach(o);
  ASSERT_OK(r.status());
  record("mid_range_stereo_5pct", *r);
  expectTrackedWithinTheMidRangeGoals(*r, 38u);
}

// Mid range from 5 % / 5 degrees at 2 Hz: after two lost frames the prediction's covariance has
// grown enough for the gate to admit a wrong acquisition (1.19 m, 7 % of the range, and 16.6
// degrees off at 1.5 s, with an inlier ratio above 0.5), which was reported TRACKING. No frame
// reported TRACKING may be off by more than 10 % of the range or 10 degrees: the harness's own
// divergence bound (`unreported_divergence`), ten times the mid-range goal of 1 % of the range, so
// that only a wrong alignment, not an inaccurate track, fails it.
TEST(VisualTrackingSimulated, MidRangeWrongAcquisitionIsNotReportedTracking) {
  ApproachOptions o;
  o.scenario = "mid_range_approach";
  o.camera_rate = 2.0;
  o.duration = 8;
  Result<ApproachResult> r = runApproach(o);
  ASSERT_OK(r.status());
  record("mid_range_mono_5pct_2hz", *r);
  ASSERT_EQ(r->position_error_m.size(), r->status.size());
  for (std::size_t i = 0; i < r->status.size(); ++i) {
    if (r->status[i] != 0) continue;
    EXPECT_LE(r->position_error_m[i], 0.1 * r->range_m[i])
        << "TRACKING at " << r->stamps_s[i] << " s";
    EXPECT_LE(r->angle_error_deg[i], 10.0) << "TRACKING at " << r->stamps_s[i] << " s";
  }
  EXPECT_EQ(r->dfn_errors, 0u);
}

// Mid range once acquired: from a start within the tracker's own accuracy (0.2 % of the range and
// 0.2 degrees) the whole approach, 17 m -> 2 m in 90 s at 2 Hz, is tracked without a loss within
// the mid-range goal (position p95 <= 1 % of the range; angle p95 <= 1 degree, the
// edge-tracking goal of the Castle-simu test). The approach's minimum-jerk profile accelerates at
// up to 10/sqrt(3) * 15 m / (90 s)^2 = 0.011 m/s^2, which the filter's process noise (1e-3 m^2/s^3:
// 0.022 m/s of velocity per 0.5 s frame, against 0.005 m/s from the acceleration) admits.
TEST(VisualTrackingSimulated, MidRangeApproachIsTrackedOnceAcquired) {
  ApproachOptions o;
  o.scenario = "mid_range_approach";
  o.camera_rate = 2.0;
  o.initial_range_fraction = 0.002;
  o.initial_angle = 0.2 * M_PI / 180;
  Result<ApproachResult> r = runApproach(o);
  ASSERT_OK(r.status());
  record("mid_range_mono_acquired", *r);
  expectTrackedWithinTheMidRangeGoals(*r, 170u);
  expectHonestCovariance(*r, 4.4);
}

// One camera of the stereo pair dark for 4 s, then dropping frames: tracking carries on with the
// other, degraded, without a jump and without losing the track.
TEST(VisualTrackingSimulated, CloseRangeStereoCarriesOnWhenACameraFails) {
  ApproachOptions o;
  o.scenario = "close_range_approach";
  o.stereo = true;
  o.duration = 30;
  o.overrides = {
      "faults=[{type: camera_failure, sensor: camera_right, start: 8, end: 12}, "
      "{type: dropped_frames, sensor: camera_right, start: 16, end: 22, probability: 0.5}]"};
  Result<ApproachResult> r = runApproach(o);
  ASSERT_OK(r.status());
  record("close_range_stereo_right_fails", *r);
  EXPECT_EQ(r->lost, 0u);
  EXPECT_EQ(r->unreported_divergence, 0u);
  std::size_t degraded_in_failure = 0;
  for (std::size_t i = 0; i < r->status.size(); ++i)
    if (r->stamps_s[i] >= 8.2 && r->stamps_s[i] < 12) degraded_in_failure += r->status[i] == 1;
  EXPECT_GE(degraded_in_failure, 6u);  // the dark camera is noticed and left out
  // No jump: the error changes between consecutive frames by less than the close-range goal.
  for (std::size_t i = 1; i < r->position_error_m.size(); ++i)
    EXPECT_LT(std::abs(r->position_error_m[i] - r->position_error_m[i - 1]), 0.010)
        << "at " << r->stamps_s[i] << " s";
  EXPECT_LE(r->filtered.position_error_m.p95, 0.010);
  expectHonestCovariance(*r, 4.8);
}

// The seed's two lighting boundary conditions: degradation is allowed, divergence without a LOST
// status is not. Back-lit, the target's visible side is unlit against black space: its outline
// has no contrast at all (even from a nearly true pose and with the contrast-adaptive threshold,
// fewer than 10 % of the samples find an edge), so LOST is the right answer.
TEST(VisualTrackingSimulated, UnderIlluminatedTargetDoesNotDivergeSilently) {
  ApproachOptions o;
  o.scenario = "under_illuminated";
  o.duration = 10;
  Result<ApproachResult> r = runApproach(o);
  ASSERT_OK(r.status());
  record("under_illuminated", *r);
  EXPECT_EQ(r->unreported_divergence, 0u);
}

// Glare: acquired from 5 % / 5 degrees at 8 m (the lateral-first acquisition hypothesis) and
// tracked, degraded (the saturated wing and the Earth behind the bus cost inliers), within the
// mid-range goal of 1 % of the range.
TEST(VisualTrackingSimulated, SpecularGlareIsTrackedDegraded) {
  ApproachOptions o;
  o.scenario = "specular_glare";
  o.duration = 10;
  Result<ApproachResult> r = runApproach(o);
  ASSERT_OK(r.status());
  record("specular_glare", *r);
  EXPECT_EQ(r->unreported_divergence, 0u);
  EXPECT_EQ(r->lost, 0u);
  EXPECT_LE(r->filtered.position_error_pct_range.p95, 1.0);
  EXPECT_LE(r->filtered.angle_error_deg.p95, 1.0);
}

// The evaluation draws of data/evaluation/draws.yaml a draw test runs: the first `ci` of them, or
// the first N with CDFF_VT_DRAWS=N (the figures of docs/visual-tracking.md).
std::vector<eval::Draw> evaluationDraws() {
  Result<eval::DrawSets> sets =
      eval::loadDrawSets(std::string(CDFF_SOURCE_DIR) + "/data/evaluation/draws.yaml");
  EXPECT_OK(sets.status());
  if (!sets) return {};
  const char* n = std::getenv("CDFF_VT_DRAWS");
  return sets->evaluationDraws(n ? std::strtoull(n, nullptr, 10) : 2);
}

// Runs `o` on each evaluation draw (its simulator seed and its initial error's seed); prints each
// draw's row and the NEES over all of them; returns the runs.
std::vector<ApproachResult> runDraws(ApproachOptions o, const std::string& tag) {
  std::vector<ApproachResult> runs;
  double measurement = 0, filtered = 0;
  for (const eval::Draw& d : evaluationDraws()) {
    o.seed = d.simulator_seed;
    o.initial_seed = static_cast<std::uint32_t>(d.initial_error_seed);
    Result<ApproachResult> r = runApproach(o);
    EXPECT_OK(r.status());
    if (!r) continue;
    record(tag + "_draw_" + std::to_string(d.number), *r);
    measurement += r->measurement.covariance.nees_mean;
    filtered += r->filtered.covariance.nees_mean;
    runs.push_back(std::move(r).value());
  }
  if (!runs.empty())
    std::printf("%s over %zu draws: NEES mean measurement %.2f, filtered pose %.2f\n", tag.c_str(),
                runs.size(), measurement / runs.size(), filtered / runs.size());
  return runs;
}

// The draw tests start from within the tracker's own accuracy (0.2 % of the range and 0.2 degrees
// in a direction drawn with the draw) and measure the covariance over the track. The acquisition
// from 5 % / 5 degrees on independent draws is issue 16's separate item: on the first four
// evaluation draws it locks onto a wrong alignment on two at close range, before and after the
// covariance's change (docs/visual-tracking.md, "Covariance").
ApproachOptions trackedFromTheStart(const std::string& scenario) {
  ApproachOptions o;
  o.scenario = scenario;
  o.initial_range_fraction = 0.002;
  o.initial_angle = 0.2 * M_PI / 180;
  return o;
}

// The close-range approach (2 m -> 0.5 m), at 2 Hz: no loss, within the close-range goals
// (position p95 <= 10 mm, angle p95 <= 0.5 degree), an honest covariance.
TEST(VisualTrackingSimulatedDraws, CloseRangeCovarianceIsHonest) {
  for (const ApproachResult& r :
       runDraws(trackedFromTheStart("close_range_approach"), "close_range_mono")) {
    EXPECT_EQ(r.lost, 0u);
    EXPECT_EQ(r.unreported_divergence, 0u);
    EXPECT_LE(r.filtered.position_error_m.p95, 0.010);
    EXPECT_LE(r.filtered.angle_error_deg.p95, 0.5);
    expectHonestCovariance(r, 4.2);
  }
}

// Stereo, the first 30 s of the close-range approach (both cameras working).
TEST(VisualTrackingSimulatedDraws, CloseRangeStereoCovarianceIsHonest) {
  ApproachOptions o = trackedFromTheStart("close_range_approach");
  o.stereo = true;
  o.duration = 30;
  for (const ApproachResult& r : runDraws(o, "close_range_stereo")) {
    EXPECT_EQ(r.lost, 0u);
    EXPECT_EQ(r.unreported_divergence, 0u);
    EXPECT_LE(r.filtered.position_error_m.p95, 0.010);
    EXPECT_LE(r.filtered.angle_error_deg.p95, 0.5);
    expectHonestCovariance(r, 4.8);
  }
}

// Mid range (17 m -> 2 m), the whole approach at 2 Hz, within the mid-range goals.
TEST(VisualTrackingSimulatedDraws, MidRangeCovarianceIsHonest) {
  for (const ApproachResult& r :
       runDraws(trackedFromTheStart("mid_range_approach"), "mid_range_mono_acquired")) {
    expectTrackedWithinTheMidRangeGoals(r, 170u);
    expectHonestCovariance(r, 4.8);
  }
}

}  // namespace
}  // namespace cdff::visual_demo
