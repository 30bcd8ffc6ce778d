// End to end: dfpcs/lidar_tracking.yaml with a model that is not the simulated target's own
// mesh and with calibrations that are not the simulator's own (issue 16). The graph is not
// edited: only the model file changes (the second procedural target's committed export, or a
// perturbed copy of the first target), or the simulator publishes a perturbed LIDAR mounting.
// The bounds are the LIDAR tracking goals of the first target's tests (mid range 0.5 % of range
// and 1 degree, close range 1 cm and 0.5 degree, the tumbling target twice those), and for model
// and calibration errors twice the goals (the "within 2x of their goals").
#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <filesystem>
#include <iostream>

#include "cdff/egse/model_io.hpp"
#include "cdff/egse/model_perturbation.hpp"
#include "cdff/egse/procedural.hpp"
#include "lidar_tracking_support.hpp"
#include "support/synthetic.hpp"

namespace cdff::lidar_tracking {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kSettle = 1.0;  // s of acquisition not counted (as in lidar_tracking_test)

const std::string kDroppedScans =
    "faults:\n  - {type: dropped_frames, sensor: lidar, start: 0, end: 1000, probability: 0.2}";

eval::Draw firstCiDraw() {
  const std::vector<eval::Draw> draws = drawSets().ciDraws();
  return draws.empty() ? eval::Draw{} : draws.front();
}

void print(const std::string& name, const TrackingResult& r) {
  const eval::PoseEvaluation& e = r.evaluation;
  const std::string line = fmt::format(
      "{}: position p95 {:.4f} m ({:.3f} % of range), angle p95 {:.3f} deg, max {:.4f} m / {:.3f} "
      "deg, tracked {}/{}, NEES mean {:.2f}",
      name, e.position_error_m.p95, e.position_error_pct_range.p95, e.angle_error_deg.p95,
      e.position_error_m.max, e.angle_error_deg.max, r.accepted, r.scans, e.covariance.nees_mean);
  ::testing::Test::RecordProperty(name, line);
  std::cout << line << "\n";
  for (const dfpc::Event& ev : r.events)
    if (ev.type == dfpc::EventType::kTrackStateChanged)
      std::cout << "  " << toSeconds(ev.stamp) << " s: track " << ev.message << "\n";
}

std::filesystem::path sourceFile(const std::string& relative) {
  return std::filesystem::path(CDFF_SOURCE_DIR) / relative;
}

// The first CI draw of `scenario` with `overrides`, tracked with the model `mesh_file` (empty:
// the simulator's own mesh).
Result<TrackingResult> trackDraw(const std::string& scenario, const std::string& extra_yaml,
                                 const std::vector<std::string>& overrides,
                                 const std::filesystem::path& mesh_file,
                                 const GraphEdit& edit = {}) {
  Result<DrawnRun> d =
      simulateDraw(firstCiDraw(), scenario, 0, 0.10, 10.0 * kDeg, extra_yaml, overrides);
  if (!d) return d.status();
  if (!mesh_file.empty()) d->run.mesh_file = mesh_file;
  return track(d->run, d->run.messages, d->initial, kSettle, edit);
}

// The graph told the sizes of the errors it runs with (`consider`'s parameters, as a user states
// the calibration's and the model's accuracy with `cdff run --set`).
GraphEdit stating(double extrinsic_angle_deg, double extrinsic_position_m, double model_scale) {
  return [=](dfpc::GraphSpec& spec) {
    for (dfpc::InstanceSpec& instance : spec.instances)
      if (instance.name == "consider") {
        instance.parameters["extrinsic_angle_sigma"] = extrinsic_angle_deg;
        instance.parameters["extrinsic_position_sigma"] = extrinsic_position_m;
        instance.parameters["model_scale_sigma"] = model_scale;
      }
  };
}

// With the errors' sizes stated, the pose NEES mean is within a factor of 2 of 6 (6 dof) or
// below (the errors are drawn once per run: one draw of a systematic error can be small).
constexpr double kNeesBound = 2 * 6.0;

struct Goal {
  double position_pct = 0, position_m = 0, angle_deg = 0;  // p95 bounds; 0: not asserted
};

void expectWithin(const TrackingResult& r, const Goal& goal) {
  if (goal.position_pct > 0) {
    EXPECT_LE(r.evaluation.position_error_pct_range.p95, goal.position_pct);
  }
  if (goal.position_m > 0) {
    EXPECT_LE(r.evaluation.position_error_m.p95, goal.position_m);
  }
  EXPECT_LE(r.evaluation.angle_error_deg.p95, goal.angle_deg);
  EXPECT_GE(r.tracked_fraction, 0.99);
}

const std::string kSecondTarget = "target.procedural.kind=hexagonal";
const char* kSecondTargetModel = "data/models/hexagonal_target.ply";

// A scenario of the first target's tests and its goals there.
struct Case {
  std::string scenario;
  std::string extra_yaml;
  Goal goal;
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << c.scenario;
}

std::vector<Case> cases() {
  return {{"mid_range_approach", "", {.position_pct = 0.5, .angle_deg = 1.0}},
          {"close_range_approach", "", {.position_m = 0.01, .angle_deg = 0.5}},
          // The tumbling target's goals are twice the others (its acquisition from 15 m).
          {"tumbling_target", kDroppedScans, {.position_pct = 2 * 0.5, .angle_deg = 2 * 1.0}}};
}

Goal twice(const Goal& g) {
  return {2 * g.position_pct, 2 * g.position_m, 2 * g.angle_deg};
}

// The tumbling target's goals are already twice the others'; with model or calibration errors
// every scenario gets twice the mid-range or close-range goals.
Goal withErrors(const Case& c) {
  return c.scenario == "tumbling_target" ? c.goal : twice(c.goal);
}

class ScenarioCase : public ::testing::TestWithParam<Case> {};

std::string caseName(const ::testing::TestParamInfo<Case>& info) {
  return info.param.scenario;
}

using SecondTarget = ScenarioCase;

TEST_P(SecondTarget, IsTrackedWithOnlyTheModelFileChanged) {
  const Case& c = GetParam();
  Result<TrackingResult> r =
      trackDraw(c.scenario, c.extra_yaml, {kSecondTarget}, sourceFile(kSecondTargetModel));
  ASSERT_OK(r.status());
  print("second_target_" + c.scenario, *r);
  expectWithin(*r, c.goal);
}

INSTANTIATE_TEST_SUITE_P(Scenarios, SecondTarget, ::testing::ValuesIn(cases()), caseName);

// Acquisition on the tumbling second target, on every CI draw of the evaluation set (its own
// simulator seed and initial error; 30 s, 15 -> 11.7 m, 20 % of the scans dropped), with the
// tumbling goals of the first target's draws.
class SecondTargetTumblingDraws : public ::testing::TestWithParam<std::uint64_t> {};

TEST_P(SecondTargetTumblingDraws, EachDrawIsTrackedWithinTheGoals) {
  Result<DrawnRun> d = simulateDraw(eval::drawOf(GetParam()), "tumbling_target", 30, 0.10,
                                    10.0 * kDeg, kDroppedScans, {kSecondTarget});
  ASSERT_OK(d.status());
  d->run.mesh_file = sourceFile(kSecondTargetModel);
  Result<TrackingResult> r = track(d->run, d->run.messages, d->initial, kSettle);
  ASSERT_OK(r.status());
  print(fmt::format("second_target_tumbling_draw_{}", GetParam()), *r);
  expectWithin(*r, {.position_pct = 2 * 0.5, .angle_deg = 2 * 1.0});
}

std::vector<std::uint64_t> ciDrawNumbers() {
  std::vector<std::uint64_t> out;
  for (const eval::Draw& d : drawSets().ciDraws()) out.push_back(d.number);
  return out;
}

INSTANTIATE_TEST_SUITE_P(EvaluationDraws, SecondTargetTumblingDraws,
                         ::testing::ValuesIn(ciDrawNumbers()));

// The first target's model 1 % too large, without its antenna, re-triangulated (diagonals
// flipped, edges split to 10 cm): every model error of the issue at once.
using ModelErrors = ScenarioCase;

Result<TrackingResult> trackWithModelErrors(const Case& c) {
  Result<egse::TargetModel> target = egse::makeTargetSatellite();
  if (!target) return target.status();
  egse::ModelPerturbation p;
  p.scale_error = Eigen::Vector3d::Constant(0.01);
  p.remove_parts = {"antenna"};
  p.flip_diagonals = true;
  p.max_edge = 0.1;
  Result<egse::TargetModel> wrong = egse::perturbModel(*target, p);
  if (!wrong) return wrong.status();
  const auto file = std::filesystem::temp_directory_path() /
                    ("cdff_wrong_model_" + std::to_string(::getpid()) + ".ply");
  CDFF_RETURN_IF_ERROR(egse::writePly(*wrong, file));
  // Scale 1 % too large: model_scale_sigma 0.01 (the part removed and the re-triangulation are
  // not a scale error; what they cost shows in the NEES).
  Result<TrackingResult> r = trackDraw(c.scenario, c.extra_yaml, {}, file, stating(0, 0, 0.01));
  std::filesystem::remove(file);
  return r;
}

TEST_P(ModelErrors, AWrongModelKeepsTheTrackWithinTwiceTheGoals) {
  const Case& c = GetParam();
  Result<TrackingResult> r = trackWithModelErrors(c);
  ASSERT_OK(r.status());
  print("model_errors_" + c.scenario, *r);
  expectWithin(*r, withErrors(c));
  EXPECT_LE(r->evaluation.covariance.nees_mean, kNeesBound);
}

INSTANTIATE_TEST_SUITE_P(Scenarios, ModelErrors, ::testing::Values(cases()[0], cases()[1]),
                         caseName);

// The tumbling target with every model error at once: its accuracy is within the goals, but the
// registrations' covariance does not include the model error, so the EKF gates out a
// registration now and then: 697/705 (98.9 %) tracked today (docs/lidar-tracking.md, "Another
// target, model errors and calibration errors"). Asserted: the accuracy goals, and the tracked
// fraction against a regression below today's (98 %, about 7 scans of slack).
TEST(ModelErrorsTumbling, TheAccuracyHoldsAndTheTrackedFractionKeepsTodaysFigure) {
  const Case c = cases()[2];  // a copy: cases() returns a temporary
  Result<TrackingResult> r = trackWithModelErrors(c);
  ASSERT_OK(r.status());
  print("model_errors_" + c.scenario, *r);
  EXPECT_LE(r->evaluation.position_error_pct_range.p95, c.goal.position_pct);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, c.goal.angle_deg);
  EXPECT_GE(r->tracked_fraction, 0.98);
}

// The LIDAR's published mounting off by the 0.2 degrees and 2 mm (Gaussian, RMS sizes,
// drawn from the draw's simulator seed).
using CalibrationErrors = ScenarioCase;

TEST_P(CalibrationErrors, ALidarMountingOffKeepsTheTrackWithinTwiceTheGoals) {
  const Case& c = GetParam();
  Result<TrackingResult> r =
      trackDraw(c.scenario, c.extra_yaml,
                {"calibration_error.extrinsic_angle_deg=0.2",
                 "calibration_error.extrinsic_position=0.002", "calibration_error.sensors=[lidar]"},
                {}, stating(0.2, 0.002, 0));
  ASSERT_OK(r.status());
  print("calibration_errors_" + c.scenario, *r);
  expectWithin(*r, withErrors(c));
  EXPECT_LE(r->evaluation.covariance.nees_mean, kNeesBound);
}

INSTANTIATE_TEST_SUITE_P(Scenarios, CalibrationErrors, ::testing::ValuesIn(cases()), caseName);

}  // namespace
}  // namespace cdff::lidar_tracking
