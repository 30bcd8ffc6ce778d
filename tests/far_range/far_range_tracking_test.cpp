// dfpcs/far_range_tracking.yaml end to end, as a user runs it: `cdff sim far_range_approach`
// (the first CI draws of the evaluation set, data/evaluation/draws.yaml), `cdff run` with no
// initial state (the target designated automatically, or by --roi), the products read back and
// compared with the truth. Two segments of the approach: its start at 2 km and its end from 400 to
// 100 m. Bounds: the goals where they are met (range within 1 % with the radar, every
// image processed), and regression bounds near today's figures where they are not (the bearing
// against the centre of mass, docs/far-range-tracking.md says why).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "far_range_evaluation.hpp"
#include "support/command.hpp"

namespace cdff::far_range {
namespace {

constexpr int kCiDraws = 3;
constexpr std::uint64_t kFirstEvaluationSeed = 900001;

struct Segment {
  const char* name;
  const char* settings;  // cdff sim options
};
const Segment kStart{"start", "--duration 90"};
const Segment kEnd{"end",
                   "--duration 120 --set servicer.trajectory.start=[0,-400,0] "
                   "--set servicer.trajectory.end=[0,-100,0]"};

/// Simulates and runs one draw; `tracking_at_end` says whether the DFPC ended TRACKING.
Evaluation runDraw(const Segment& segment, std::uint64_t seed, const std::string& run_options,
                   bool* tracking_at_end = nullptr) {
  const std::filesystem::path dir = testing::scratchDirectory("far_range");
  const std::string sim = (dir / fmt::format("{}_{}.mcap", segment.name, seed)).string();
  const std::string out = (dir / fmt::format("{}_{}_out.mcap", segment.name, seed)).string();
  const testing::CommandResult s = testing::runCdff(
      fmt::format("sim far_range_approach -q --seed {} {} -o {}", seed, segment.settings, sim));
  EXPECT_EQ(s.status, 0) << s.output;
  const testing::CommandResult r =
      testing::runCdff(fmt::format("run {}/dfpcs/far_range_tracking.yaml -q -i {} -o {} {}",
                                   CDFF_SOURCE_DIR, sim, out, run_options));
  EXPECT_EQ(r.status, 0) << r.output;
  if (tracking_at_end) *tracking_at_end = r.output.find("(track TRACKING)") != std::string::npos;
  Result<Evaluation> e = evaluateFarRange(out);
  EXPECT_TRUE(e.isOk()) << e.status().toString();
  std::filesystem::remove(sim);
  std::filesystem::remove(out);
  return e.isOk() ? *e : Evaluation{};
}

struct Figures {
  double bearing_rms_px, nees, range_p95_pct, range_nees, tracked_rms_px, matched_fraction;
};

Figures figuresOf(const Evaluation& e) {
  return {e.bearing.pixels.rmse,
          e.bearing.covariance.nees_mean,
          e.bearing.range_error_pct.p95,
          e.bearing.covariance.range_nees_mean,
          rms(e.tracked_point_px),
          e.images ? static_cast<double>(e.tracked_point_px.size()) / e.images : 0.0};
}

/// Regression bounds of one segment, near today's figures on the CI draws
/// (docs/far-range-tracking.md has them and the reasons they are far from the goals).
struct Bounds {
  double designated_s, bearing_px, tracked_px, matched;
};

void expectTracking(const Segment& segment, const Bounds& bounds) {
  for (int k = 0; k < kCiDraws; ++k) {
    const std::uint64_t seed = kFirstEvaluationSeed + k;
    bool tracking = false;
    const Evaluation e = runDraw(segment, seed, "", &tracking);
    EXPECT_TRUE(tracking) << "draw " << seed << ": the track did not hold to the end";
    ASSERT_TRUE(e.designated) << "draw " << seed << ": nothing designated";
    EXPECT_EQ(e.designation, "automatic");
    EXPECT_LT(*e.designated * 1e-6, bounds.designated_s) << "draw " << seed;
    const Figures f = figuresOf(e);
    std::printf(
        "%s draw %lu: designated at %.0f s (%.2f m from the centre), bearing %.2f px RMS, NEES "
        "%.2f, range p95 %.3f %% (NEES %.2f), tracked point %.2f px RMS, %.0f %% of images "
        "matched\n",
        segment.name, static_cast<unsigned long>(seed), *e.designated * 1e-6, e.centre_offset_m,
        f.bearing_rms_px, f.nees, f.range_p95_pct, f.range_nees, f.tracked_rms_px,
        100 * f.matched_fraction);
    EXPECT_LT(f.range_p95_pct, 1.0) << "draw " << seed;  // the goal with a radar
    EXPECT_LT(f.nees, 8.0) << "draw " << seed;           // honest within a factor 4 of 2
    EXPECT_LT(f.range_nees, 8.0) << "draw " << seed;     // of 1: the radar ranges the surface
    EXPECT_LT(f.bearing_rms_px, bounds.bearing_px) << "draw " << seed;
    EXPECT_LT(f.tracked_rms_px, bounds.tracked_px) << "draw " << seed;
    EXPECT_GT(f.matched_fraction, bounds.matched) << "draw " << seed;
  }
}

TEST(FarRangeTracking, AtTheStartOfTheApproachTheTargetIsFoundAndFollowedWithNoInitialState) {
  // Today: designated after 2-61 s (the target shows as glints in some images only), bearing
  // 1.6-2.1 px RMS, tracked point 1.5-1.9 px RMS, 62-70 % of the images matched.
  expectTracking(kStart, {80.0, 3.5, 3.0, 0.5});
}

TEST(FarRangeTracking, AtTheEndOfTheApproachTheTrackHolds) {
  // Today: designated after 12-43 s, bearing 11.7-12.1 px RMS (the designated point is 0.7 m from
  // the centre of mass: 11-45 px at 400-100 m), tracked point 2.1-2.4 px RMS, 73-84 % matched.
  expectTracking(kEnd, {60.0, 16.0, 3.5, 0.6});
}

TEST(FarRangeTracking, AUsersDesignationStartsTheTrack) {
  // A 40-pixel box around the image's centre, where the servicer points, 2 s into the run.
  const Evaluation e = runDraw(kStart, kFirstEvaluationSeed, "--roi 492,492,40,40@2");
  ASSERT_TRUE(e.designated);
  EXPECT_EQ(e.designation, "user");
  EXPECT_EQ(*e.designated, 2'000'000);
  EXPECT_GT(e.bearing.matched_frames, 0u);
}

}  // namespace
}  // namespace cdff::far_range
