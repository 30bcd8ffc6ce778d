// Bearing products (far-range tracking) against truth whose errors are known by construction:
// the angle and its pixels, the 2-dof NEES, the range error and its NEES, validity, the
// far-range verdicts, and where the focal length comes from.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "cdff/eval/bearing_evaluation.hpp"
#include "cdff/eval/recording_evaluation.hpp"
#include "cdff/io/recorder.hpp"

namespace cdff::eval {
namespace {

namespace fs = std::filesystem;
constexpr double kAngleErrorRad = 50e-6;  // every bearing's error, across the direction
constexpr double kRangeErrorFraction = 0.005;
constexpr double kFocalPx = 5000.0;

#define ASSERT_OK_STATUS(expr)                               \
  do {                                                       \
    const ::cdff::Status s_ = (expr);                        \
    ASSERT_TRUE(s_.isOk()) << #expr << ": " << s_.message(); \
  } while (0)

// The target 2 km ahead closing at 5 m/s and drifting sideways: servicer_T_target.
Transform truthAt(double t) {
  Transform pose = Transform::identity("servicer", "target", fromSeconds(t));
  pose.translation = {2000.0 - 5.0 * t, 20.0 + 0.3 * t, -10.0};
  return pose;
}

// A bearing off the truth by kAngleErrorRad about an axis across it, with an isotropic sigma of
// that size across the direction (each NEES is then 1), and a range off by kRangeErrorFraction
// with that as its sigma (each range NEES 1).
Bearing bearingAt(double t) {
  const Transform truth = truthAt(t);
  const Eigen::Vector3d u = truth.translation.normalized();
  const Eigen::Vector3d axis = u.unitOrthogonal();
  Bearing b;
  b.stamp = truth.stamp;
  b.frame_id = "servicer";
  b.direction = Eigen::AngleAxisd(kAngleErrorRad, axis) * u;
  b.covariance = kAngleErrorRad * kAngleErrorRad *
                 (Eigen::Matrix3d::Identity() - b.direction * b.direction.transpose());
  const double range = truth.translation.norm();
  b.range = range * (1.0 + kRangeErrorFraction);
  b.range_variance = std::pow(range * kRangeErrorFraction, 2);
  b.designation = "automatic";
  return b;
}

std::vector<Transform> truthSeries() {
  std::vector<Transform> truth;
  for (int k = 0; k <= 600; ++k) truth.push_back(truthAt(0.1 * k));
  return truth;
}

TEST(BearingEvaluation, AngleInPixelsNeesAndRangeOfKnownErrors) {
  std::vector<BearingSample> estimates;
  for (int k = 0; k <= 60; ++k) {
    BearingSample s;
    s.bearing = bearingAt(k);
    s.valid = k < 20 || k > 24;               // LOST from 20 s to 24 s: 5 bearings left out
    if (k == 40) s.bearing.direction *= 2.0;  // not unit: not a bearing the DFPC stands by
    s.latency_s = 1e-3;
    estimates.push_back(s);
  }
  Result<BearingEvaluation> r = evaluateBearings(estimates, truthSeries(), kFocalPx);
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r->frames, 61u);
  EXPECT_EQ(r->valid_frames, 55u);
  EXPECT_EQ(r->matched_frames, 55u);
  EXPECT_EQ(r->ranged_frames, 55u);
  EXPECT_NEAR(r->angle_urad.max, kAngleErrorRad * 1e6, 1e-6);
  EXPECT_NEAR(r->angle_urad.rmse, kAngleErrorRad * 1e6, 1e-6);
  EXPECT_NEAR(r->pixels.max, kAngleErrorRad * kFocalPx, 1e-9);
  EXPECT_NEAR(r->range_error_pct.max, 100 * kRangeErrorFraction, 1e-9);
  EXPECT_EQ(r->covariance.count, 55u);
  EXPECT_NEAR(r->covariance.nees_mean, 1.0, 1e-6);
  EXPECT_NEAR(r->covariance.range_nees_mean, 1.0, 1e-9);
  EXPECT_NEAR(r->covariance.within_95_fraction, 1.0, 1e-12);
  EXPECT_NEAR(r->latency_s.max, 1e-3, 1e-12);
  // The worst interval is the loss: 19 s to 25 s.
  EXPECT_NEAR(r->min_rate_hz, 1.0 / 6.0, 1e-9);
  EXPECT_NEAR(r->min_range_m, truthAt(60).translation.norm(), 1e-9);

  // Without a focal length: no pixels, the angle all the same.
  r = evaluateBearings(estimates, truthSeries());
  ASSERT_TRUE(r.isOk());
  EXPECT_EQ(r->pixels.count, 0u);
  EXPECT_EQ(r->angle_urad.count, 55u);

  // The verdicts: 0.25 px < 1 px, 0.5 % < 1 %, but a 6 s loss is under 1 Hz.
  r = evaluateBearings(estimates, truthSeries(), kFocalPx);
  ASSERT_TRUE(r.isOk());
  for (const RequirementVerdict& v : checkRequirements(*r, Statistic::kMax)) {
    SCOPED_TRACE(v.id);
    EXPECT_EQ(v.verdict, v.id == "UC1_RATE" ? Verdict::kFail : Verdict::kPass);
  }
}

TEST(BearingEvaluation, BadInputIsAnErrorThatSaysWhat) {
  std::vector<BearingSample> estimates(2);
  estimates[0].bearing = bearingAt(2);
  estimates[1].bearing = bearingAt(1);
  Result<BearingEvaluation> r = evaluateBearings(estimates, truthSeries(), kFocalPx);
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("older than the one before"), std::string::npos);

  estimates.resize(1);
  estimates[0].bearing.frame_id = "camera";
  r = evaluateBearings(estimates, truthSeries(), kFocalPx);
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("'camera'"), std::string::npos);
  EXPECT_NE(r.status().message().find("servicer_T_target"), std::string::npos);

  // A covariance of rank 1 across the direction is not usable: counted, no NEES.
  estimates[0].bearing = bearingAt(1);
  estimates[0].bearing.covariance = estimates[0].bearing.direction.unitOrthogonal() *
                                    estimates[0].bearing.direction.unitOrthogonal().transpose();
  r = evaluateBearings(estimates, truthSeries(), kFocalPx);
  ASSERT_TRUE(r.isOk());
  EXPECT_EQ(r->covariance.rejected, 1u);
  EXPECT_EQ(r->covariance.count, 0u);
}

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "cdff_bearing_evaluation_test";
  fs::create_directories(dir);
  return dir / name;
}

CameraModel camera(double focal_px) {
  CameraModel c;
  c.width = c.height = 1024;
  c.fx = c.fy = focal_px;
  c.cx = c.cy = 511.5;
  return c;
}

// A far-range run: truth at 10 Hz, a bearing per second, the camera's calibration (and a second
// camera's when `second_camera`), the track acquired at 3 s.
void writeFarRangeRun(const fs::path& path, bool second_camera) {
  io::Recorder rec;
  ASSERT_OK_STATUS(rec.open(path.string()));
  for (const Transform& t : truthSeries())
    ASSERT_OK_STATUS(rec.write("/truth/target_pose", PoseWithCovariance{t, {}}));
  ASSERT_OK_STATUS(rec.writeCalibration("/chaser/camera/far/calibration", camera(kFocalPx), 0,
                                        "camera_far_optical"));
  if (second_camera)
    ASSERT_OK_STATUS(rec.writeCalibration("/chaser/camera/wide/calibration", camera(800.0), 0,
                                          "camera_wide_optical"));
  ASSERT_OK_STATUS(rec.writeJson("/cdff/events", fromSeconds(3),
                                 {{"level", "info"},
                                  {"type", "track_state_changed"},
                                  {"dfpc", "far"},
                                  {"message", "UNINITIALISED -> TRACKING"}}));
  for (int k = 4; k <= 60; ++k) ASSERT_OK_STATUS(rec.write("/cdff/far/bearing", bearingAt(k)));
  ASSERT_OK_STATUS(rec.close());
}

TEST(RecordingEvaluation, BearingProductsInPixelsOfTheRecordedCamera) {
  const fs::path run = scratch("far.mcap");
  writeFarRangeRun(run, false);
  Result<EvaluationReport> report = evaluateRecording({run.string()});
  ASSERT_TRUE(report.isOk()) << report.status().message();
  EXPECT_TRUE(report->products.empty());
  ASSERT_EQ(report->bearings.size(), 1u);
  const BearingEvaluation& b = report->bearings[0];
  EXPECT_EQ(b.channel, "/cdff/far/bearing");
  EXPECT_EQ(b.truth_channel, "/truth/target_pose");
  EXPECT_EQ(b.camera_channel, "/chaser/camera/far/calibration");
  EXPECT_EQ(b.focal_px, kFocalPx);
  EXPECT_EQ(b.valid_frames, 57u);
  EXPECT_NEAR(b.pixels.p95, kAngleErrorRad * kFocalPx, 1e-9);
  ASSERT_EQ(report->requirements.size(), 3u);
  EXPECT_TRUE(report->allPass());
  EXPECT_EQ(toJson(*report)["bearings"][0]["bearing_error_px"]["max"].get<double>(), b.pixels.max);
  EXPECT_NE(toText(*report).find("UC1_BEARING"), std::string::npos);
  EXPECT_NE(toHtml(*report).find("Bearing error over range"), std::string::npos);
}

TEST(RecordingEvaluation, TwoCamerasNeedOneChosen) {
  const fs::path run = scratch("far_two_cameras.mcap");
  writeFarRangeRun(run, true);
  RecordingEvaluationNotes notes;
  Result<EvaluationReport> report = evaluateRecording({run.string()}, {}, &notes);
  ASSERT_TRUE(report.isOk()) << report.status().message();
  ASSERT_EQ(report->bearings.size(), 1u);
  EXPECT_EQ(report->bearings[0].pixels.count, 0u);
  EXPECT_EQ(report->requirements[0].verdict, Verdict::kNotApplicable);
  ASSERT_EQ(notes.notes.size(), 1u);
  EXPECT_NE(notes.notes[0].find("/chaser/camera/wide/calibration"), std::string::npos);

  RecordingEvaluationOptions options;
  options.camera_channel = "/chaser/camera/wide/calibration";
  report = evaluateRecording({run.string()}, options);
  ASSERT_TRUE(report.isOk());
  EXPECT_NEAR(report->bearings[0].pixels.max, kAngleErrorRad * 800.0, 1e-9);

  options.camera_channel.clear();
  options.focal_px = 1000.0;
  report = evaluateRecording({run.string()}, options);
  ASSERT_TRUE(report.isOk());
  EXPECT_NEAR(report->bearings[0].pixels.max, kAngleErrorRad * 1000.0, 1e-9);

  options.focal_px = std::numeric_limits<double>::quiet_NaN();
  options.camera_channel = "/chaser/camera/none/calibration";
  report = evaluateRecording({run.string()}, options);
  ASSERT_FALSE(report.isOk());
  EXPECT_NE(report.status().message().find("/chaser/camera/none/calibration"), std::string::npos);
  EXPECT_NE(report.status().message().find("/chaser/camera/far/calibration"), std::string::npos);
}

}  // namespace
}  // namespace cdff::eval
