// End to end: dfpcs/visual_tracking.yaml with a model that is not the simulated target's own and
// with calibrations that are not the simulator's own (issue 16). The graph file is not edited:
// only the tracker's model file changes (the second procedural target's committed export, or a
// perturbed copy of the first target), or the simulator publishes a perturbed camera calibration
// (visual_demo::ModelVariant, simulated_approach.hpp).
//
// Each case runs a whole approach at 2 Hz on the first CI draw of the evaluation set
// (data/evaluation/draws.yaml: its simulator seed and its Gaussian initial error of RMS 5 % of
// the range and 5 degrees with an unknown twist, sigmas 0.3 m/s and 0.1 rad/s, stamped at the
// first image, which is not tracked). The figures are those of the valid frames (TRACKING or
// DEGRADED) of the pose product in the servicer frame against /truth/target_pose: a calibration
// error shows there, where the camera's mounting and intrinsics turn the tracker's measurement
// into the product.
//
// Asserted per case: acquired within 2 s (issue 16's acquisition goal), no valid frame off by
// more than 5 % of the range or 10 degrees (a wrong track), no loss once tracked, no DFN error;
// the position and angle p95 within the goals of the first target's tests (close range 10 mm and
// 0.5 degree, mid range 1 % of the range and 1 degree) for the second target, within twice the
// goals with model or calibration errors (issue 16: "within 2x of their goals"); and within 1.5x
// the figures measured on 2026-12-04 (docs/visual-tracking.md), so that a regression fails. With
// model or calibration errors the graph is told their sizes (its `consider` node's parameters, as
// `cdff run --set` sets them) and the filtered pose's NEES mean must be within twice 6 (issue 16's
// honest covariance); the second target's model is its own, and nothing is stated.
// Where a goal is not met today, the case says why, asserts the regression bound alone for that
// figure (and, where the track is lost today, a floor under the valid fraction instead of no
// loss), and docs/visual-tracking.md ("Another target, model errors and calibration errors")
// states the limit.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "simulated_approach.hpp"
#include "support/synthetic.hpp"

namespace cdff::visual_demo {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct Bounds {
  double position_m = 0;    // p95, m; 0: not asserted
  double position_pct = 0;  // p95, % of the range; 0: not asserted
  double angle_deg = 0;     // p95
};

Bounds scaled(const Bounds& b, double f) {
  return {f * b.position_m, f * b.position_pct, f * b.angle_deg};
}

struct Case {
  std::string scenario;
  ModelVariant variant;
  /// The goals (second target) or twice the goals (model or calibration errors) at this range;
  /// a figure whose goal is not met today is 0 (not asserted).
  Bounds bound;
  Bounds today;  // the p95s measured on 2026-12-04; 1.5x is asserted
  /// 0: no loss once tracked; else the track is lost today and the valid fraction (valid frames
  /// over frames) must stay above this floor, today's less about five frames.
  double min_valid = 0;
  /// The errors' sizes stated to the graph (the consider node's parameters, as a user sets them
  /// with `cdff run --set`); none for the second target, whose model is its own.
  std::vector<std::string> stated;
  /// Bound on the filtered pose's NEES mean over the valid frames; 0: not asserted.
  double max_nees = 0;
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << toString(c.variant) << " " << c.scenario;
}

std::string caseName(const ::testing::TestParamInfo<Case>& info) {
  return std::string(toString(info.param.variant)) + "_" + info.param.scenario;
}

const Bounds kCloseRangeGoal{.position_m = 0.010, .angle_deg = 0.5};
const Bounds kMidRangeGoal{.position_pct = 1.0, .angle_deg = 1.0};
const Bounds kTwiceCloseRangeGoal = scaled(kCloseRangeGoal, 2);
const Bounds kTwiceMidRangeGoal = scaled(kMidRangeGoal, 2);

// The errors' sizes the graph is told (its `consider` node; visual_demo::statedErrors).
const std::vector<std::string> kModelStated = statedErrors(ModelVariant::kModelErrors);
const std::vector<std::string> kCalibrationStated = statedErrors(ModelVariant::kCalibrationErrors);

// With the errors' sizes stated, the pose NEES mean is within a factor of 2 of 6 (6 dof) or below
// (issue 16's honest covariance; a calibration error is drawn once per run, and a draw can be
// small).
constexpr double kNeesBound = 2 * 6.0;

// A scratch directory for the perturbed model files, removed with the test.
class ScratchDirectory {
 public:
  ScratchDirectory()
      : path_(std::filesystem::temp_directory_path() /
              ("cdff_visual_model_errors_" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(path_);
  }
  ~ScratchDirectory() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

double mean(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? std::nan("") : sum / static_cast<double>(v.size());
}

// The model errors' file is what the tracker is meant to get: triangles only (re-triangulated), a
// bounding box 1 % larger than the simulator's own export's (the thrusters do not bound it), and
// fewer faces than the same errors without the removal.
TEST(VisualModelErrors, TheWrongModelFileHasTheStatedErrors) {
  ScratchDirectory scratch;
  ApproachOptions o;
  o.scenario = "close_range_approach";
  const std::filesystem::path own = scratch.path() / "own.cao",
                              wrong = scratch.path() / "wrong.cao",
                              kept = scratch.path() / "kept.cao";
  ASSERT_OK(writePerturbedModel(o, {}, own));
  ASSERT_OK(writePerturbedModel(o, modelErrors(), wrong));
  egse::ModelPerturbation without_removal = modelErrors();
  without_removal.remove_parts.clear();
  ASSERT_OK(writePerturbedModel(o, without_removal, kept));
  Result<PolygonModel> a = loadCao(own.string()), b = loadCao(wrong.string()),
                       c = loadCao(kept.string());
  ASSERT_OK(a.status());
  ASSERT_OK(b.status());
  ASSERT_OK(c.status());
  for (const PolygonModel::Face& f : b->faces) ASSERT_EQ(f.points.size(), 3u);
  EXPECT_GT(b->faces.size(), a->faces.size());  // the polygons' triangles
  EXPECT_LT(b->faces.size(), c->faces.size());  // the thrusters' are gone
  const Eigen::AlignedBox3d box = a->bounds(), larger = b->bounds();
  EXPECT_LT((larger.min() - 1.01 * box.min()).cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_LT((larger.max() - 1.01 * box.max()).cwiseAbs().maxCoeff(), 1e-5);
}

class ModelAndCalibrationErrors : public ::testing::TestWithParam<Case> {};

TEST_P(ModelAndCalibrationErrors, TheTrackStaysWithinTheBounds) {
  const Case& c = GetParam();
  Result<eval::DrawSets> sets = drawSets();
  ASSERT_OK(sets.status());
  const std::vector<eval::Draw> draws = sets->ciDraws();
  ASSERT_FALSE(draws.empty());
  ScratchDirectory scratch;
  Result<ApproachOptions> o =
      withVariant(drawOptions(draws.front(), c.scenario, std::nullopt, 0.05, 5 * kDeg, 0.3, 0.1),
                  c.variant, scratch.path());
  ASSERT_OK(o.status());
  o->graph_settings = c.stated;
  Result<ApproachResult> r = runApproach(*o);
  ASSERT_OK(r.status());
  const AcquisitionOutcome a = acquisitionOutcome(*r);
  ASSERT_TRUE(a.tracked);
  const double mm = 1e3 * eval::ErrorStatistics::of(a.position_error_m).p95;
  const double pct = eval::ErrorStatistics::of(a.position_error_pct).p95;
  const double deg = eval::ErrorStatistics::of(a.angle_error_deg).p95;
  const double valid = static_cast<double>(a.valid_frames) / static_cast<double>(a.frames);
  const std::string line = fmt::format(
      "{} {}, draw {}: position p95 {:.2f} mm ({:.3f} % of range), angle p95 {:.3f} deg, valid "
      "{}/{} ({:.3f}), tracked at {:.1f} s, NEES mean {:.2f} (filtered pose, valid frames), "
      "{:.2f} (measurement), slowest frame {:.0f} ms CPU",
      toString(c.variant), c.scenario, draws.front().number, mm, pct, deg, a.valid_frames, a.frames,
      valid, a.time_to_track_s, mean(a.nees), r->measurement.covariance.nees_mean,
      1e3 * r->cpu_per_frame_s.max);
  std::printf("%s\n", line.c_str());
  ::testing::Test::RecordProperty("figures", line);
  if (r->lost > 0)
    for (const std::string& w : r->warnings) std::printf("  warning: %s\n", w.c_str());

  EXPECT_LE(a.time_to_track_s, 2.0);
  EXPECT_EQ(a.wrong_frames, 0u);
  if (c.min_valid > 0) {
    EXPECT_GE(valid, c.min_valid);
  } else {
    EXPECT_EQ(a.lost_after_track, 0u);
  }
  EXPECT_EQ(r->dfn_errors, 0u);
  if (c.max_nees > 0) {
    EXPECT_LE(mean(a.nees), c.max_nees);
  }
  for (const Bounds& b : {c.bound, scaled(c.today, 1.5)}) {
    if (b.position_m > 0) {
      EXPECT_LE(mm, 1e3 * b.position_m);
    }
    if (b.position_pct > 0) {
      EXPECT_LE(pct, b.position_pct);
    }
    if (b.angle_deg > 0) {
      EXPECT_LE(deg, b.angle_deg);
    }
  }
}

// Close range: the second target is tracked within the goals, but from 36 s the inlier ratio
// falls as the servicer's capture probe (in view, not in the tracker's model) comes in front of
// the apogee engine's nozzle, which is most of what the camera sees there; the track is lost at
// 41 s and not re-acquired (79 of 119 frames valid; without the servicer mock-up in view all but
// the acquisition frame are valid). With model errors the position goal is not met: a model 1 %
// larger is seen by one camera exactly as the target 1 % farther away, so the position is off by
// about 1 % of the camera's range (26 mm p95 at 2-3 m, against 20 mm); the part missing and the
// re-triangulation alone give 2.4 mm. Mid range: the second target is tracked DEGRADED 2-4
// degrees and 0.1-0.3 m off from 17 m down to 8 m (an alignment off in attitude that later
// frames keep), then within about 1 mm and 0.06 degree; 12 frames LOST or ACQUIRING after the
// first valid one (166 of 179 valid). Its p95 misses both goals (1.17 % of the range, 3.0
// degrees).
INSTANTIATE_TEST_SUITE_P(Variants, ModelAndCalibrationErrors,
                         ::testing::Values(Case{"close_range_approach",
                                                ModelVariant::kSecondTarget,
                                                kCloseRangeGoal,
                                                {.position_m = 0.00150, .angle_deg = 0.088},
                                                0.62,
                                                {},
                                                0},
                                           Case{"close_range_approach",
                                                ModelVariant::kModelErrors,
                                                {.angle_deg = kTwiceCloseRangeGoal.angle_deg},
                                                {.position_m = 0.0263, .angle_deg = 0.219},
                                                0,
                                                kModelStated,
                                                kNeesBound},
                                           Case{"close_range_approach",
                                                ModelVariant::kCalibrationErrors,
                                                kTwiceCloseRangeGoal,
                                                {.position_m = 0.00952, .angle_deg = 0.239},
                                                0,
                                                kCalibrationStated,
                                                kNeesBound},
                                           Case{"mid_range_approach",
                                                ModelVariant::kSecondTarget,
                                                {},
                                                {.position_pct = 1.166, .angle_deg = 3.0},
                                                0.9,
                                                {},
                                                0},
                                           Case{"mid_range_approach",
                                                ModelVariant::kModelErrors,
                                                kTwiceMidRangeGoal,
                                                {.position_pct = 1.319, .angle_deg = 0.328},
                                                0,
                                                kModelStated,
                                                kNeesBound},
                                           Case{"mid_range_approach",
                                                ModelVariant::kCalibrationErrors,
                                                kTwiceMidRangeGoal,
                                                {.position_pct = 0.743, .angle_deg = 0.247},
                                                0,
                                                kCalibrationStated,
                                                kNeesBound}),
                         caseName);

}  // namespace
}  // namespace cdff::visual_demo
