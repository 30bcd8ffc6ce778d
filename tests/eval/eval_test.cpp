// The evaluation library against series whose errors are known by construction.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/eval/report.hpp"
#include "cdff/eval/requirements.hpp"

namespace cdff::eval {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Truth: the target approaches along x from 17 m to 2 m in 150 s while turning about z at
// 1 deg/s; sampled at 100 Hz.
Transform truthPose(Timestamp t) {
  const double s = toSeconds(t);
  Transform pose;
  pose.stamp = t;
  pose.parent_frame = "servicer";
  pose.child_frame = "target";
  pose.translation = {17.0 - 0.1 * s, 0.5, 0.0};
  pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(s * kDegToRad, Eigen::Vector3d::UnitZ()));
  return pose;
}

std::vector<Transform> truthSeries(double duration_s = 150.0, double rate_hz = 100.0) {
  std::vector<Transform> truth;
  for (Timestamp t = 0; t <= fromSeconds(duration_s); t += fromSeconds(1.0 / rate_hz))
    truth.push_back(truthPose(t));
  return truth;
}

// An estimate off by exactly `position_error` metres (along y) and `angle_error_deg` (about x).
EstimateSample estimateAt(Timestamp t, double position_error, double angle_error_deg) {
  EstimateSample e;
  e.pose = truthPose(t);
  e.pose.translation.y() += position_error;
  e.pose.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(angle_error_deg * kDegToRad, Eigen::Vector3d::UnitX())) *
      e.pose.rotation;
  return e;
}

TEST(ErrorStatistics, RmsePercentileAndMaxOfAKnownSet) {
  std::vector<double> values;
  for (int i = 1; i <= 100; ++i) values.push_back(i);
  const ErrorStatistics s = ErrorStatistics::of(values);
  EXPECT_EQ(s.count, 100u);
  EXPECT_NEAR(s.rmse, std::sqrt(100.0 * 101.0 * 201.0 / 6.0 / 100.0), 1e-9);
  EXPECT_NEAR(s.p95, 95.05, 1e-9);  // linear interpolation between the 95th and 96th values
  EXPECT_EQ(s.max, 100.0);
  EXPECT_TRUE(std::isnan(ErrorStatistics::of({}).p95));
}

TEST(TruthAt, InterpolatesBetweenSamplesAndRefusesGaps) {
  const std::vector<Transform> truth = truthSeries(10.0, 10.0);
  PoseEvaluationOptions options;
  const std::optional<Transform> mid = truthAt(truth, fromSeconds(2.05), options);
  ASSERT_TRUE(mid);
  const Transform expected = truthPose(fromSeconds(2.05));
  EXPECT_NEAR((mid->translation - expected.translation).norm(), 0.0, 1e-9);
  EXPECT_NEAR(angularDistance(mid->rotation, expected.rotation), 0.0, 1e-9);
  EXPECT_FALSE(truthAt(truth, fromSeconds(10.5), options));  // after the last sample
  options.max_truth_gap_s = 0.05;                            // samples are 0.1 s apart
  EXPECT_FALSE(truthAt(truth, fromSeconds(2.05), options));
  EXPECT_TRUE(truthAt(truth, fromSeconds(2.0), options));  // an exact sample needs no bracket
}

TEST(EvaluatePoses, RecoversConstructedErrorsRateAndTrackedFraction) {
  const std::vector<Transform> truth = truthSeries();
  std::vector<EstimateSample> estimates;
  // 10 Hz estimates between 0.05 s and 149.95 s, off the truth sampling grid; every 10th is
  // invalid (the DFPC reported LOST), so the tracked fraction is 0.9 and the worst gap 0.2 s.
  for (int i = 0; i < 1500; ++i) {
    const Timestamp t = fromSeconds(0.05 + 0.1 * i);
    EstimateSample e = estimateAt(t, 0.02, 0.5);
    e.valid = i % 10 != 9;
    e.latency_s = 0.004;
    estimates.push_back(e);
  }
  const Result<PoseEvaluation> result = evaluatePoses(estimates, truth);
  ASSERT_TRUE(result.isOk()) << result.status().toString();
  const PoseEvaluation& p = *result;
  EXPECT_EQ(p.frames, 1500u);
  EXPECT_EQ(p.valid_frames, 1350u);
  EXPECT_EQ(p.matched_frames, 1350u);
  EXPECT_NEAR(p.tracked_fraction, 0.9, 1e-12);
  EXPECT_NEAR(p.position_error_m.rmse, 0.02, 1e-9);
  EXPECT_NEAR(p.position_error_m.max, 0.02, 1e-9);
  EXPECT_NEAR(p.angle_error_deg.p95, 0.5, 1e-6);
  // The largest relative error is at the closest valid estimate, t = 149.85 s.
  EXPECT_NEAR(p.position_error_pct_range.max, 100.0 * 0.02 / std::hypot(17.0 - 14.985, 0.5), 1e-9);
  EXPECT_NEAR(p.min_rate_hz, 5.0, 1e-9);
  EXPECT_NEAR(p.rate_hz, 1349.0 / (149.85 - 0.05), 1e-6);
  EXPECT_NEAR(p.latency_s.max, 0.004, 1e-12);
}

TEST(EvaluatePoses, RejectsMismatchedFramesAndUnorderedSeries) {
  const std::vector<Transform> truth = truthSeries(2.0);
  std::vector<EstimateSample> estimates = {estimateAt(fromSeconds(0.5), 0, 0)};
  estimates[0].pose.child_frame = "other";
  Result<PoseEvaluation> r = evaluatePoses(estimates, truth);
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("servicer_T_other"), std::string::npos);

  estimates = {estimateAt(fromSeconds(1.0), 0, 0), estimateAt(fromSeconds(0.5), 0, 0)};
  r = evaluatePoses(estimates, truth);
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("time order"), std::string::npos);

  estimates = {estimateAt(fromSeconds(1.0), 0, 0)};
  estimates[0].pose.translation.x() = std::nan("");
  r = evaluatePoses(estimates, truth);
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("t = 1000000 us"), std::string::npos);
}

TEST(EvaluatePoses, EstimatesWithoutTruthAreUnmatchedNotErrors) {
  const std::vector<Transform> truth = truthSeries(1.0);
  const std::vector<EstimateSample> estimates = {estimateAt(fromSeconds(0.5), 0.01, 0),
                                                 estimateAt(fromSeconds(5.0), 0.01, 0)};
  const Result<PoseEvaluation> r = evaluatePoses(estimates, truth);
  ASSERT_TRUE(r.isOk());
  EXPECT_EQ(r->valid_frames, 2u);
  EXPECT_EQ(r->matched_frames, 1u);
}

std::vector<EstimateSample> approach(double position_error, double angle_error_deg) {
  std::vector<EstimateSample> estimates;
  for (int i = 0; i < 150; ++i)
    estimates.push_back(estimateAt(fromSeconds(0.5 + i), position_error, angle_error_deg));
  return estimates;
}

const RequirementVerdict& find(const std::vector<RequirementVerdict>& verdicts,
                               const std::string& id, const std::string& quantity) {
  for (const RequirementVerdict& v : verdicts)
    if (v.id == id && v.quantity == quantity) return v;
  throw std::runtime_error("no verdict " + id + " " + quantity);
}

TEST(Requirements, MidRangeVerdictsFollowTheSeedThresholds) {
  const std::vector<Transform> truth = truthSeries();
  // 0.9 m and 9 deg: inside SR_DFPC_0100 (< 1 m, < 10 deg) at 17..2 m.
  Result<PoseEvaluation> good = evaluatePoses(approach(0.9, 9.0), truth);
  ASSERT_TRUE(good.isOk());
  std::vector<RequirementVerdict> verdicts = checkRequirements(*good);
  EXPECT_EQ(find(verdicts, "SR_DFPC_0100", "position_error_m").verdict, Verdict::kPass);
  EXPECT_NEAR(find(verdicts, "SR_DFPC_0100", "position_error_m").measured, 0.9, 1e-9);
  EXPECT_EQ(find(verdicts, "SR_DFPC_0100", "angle_error_deg").verdict, Verdict::kPass);
  // The approach ends at 2 m: nothing in the close-range band.
  EXPECT_EQ(find(verdicts, "SR_DFPC_0101", "position_error_m").verdict, Verdict::kNotApplicable);
  EXPECT_EQ(find(verdicts, "SR_DFPC_0102", "update_rate_hz").verdict, Verdict::kPass);
  EXPECT_NEAR(find(verdicts, "SR_DFPC_0102", "update_rate_hz").measured, 1.0, 1e-9);

  Result<PoseEvaluation> bad = evaluatePoses(approach(1.1, 11.0), truth);
  ASSERT_TRUE(bad.isOk());
  verdicts = checkRequirements(*bad);
  EXPECT_EQ(find(verdicts, "SR_DFPC_0100", "position_error_m").verdict, Verdict::kFail);
  EXPECT_EQ(find(verdicts, "SR_DFPC_0100", "angle_error_deg").verdict, Verdict::kFail);
}

TEST(Requirements, P95ToleratesRareOutliersMaxDoesNot) {
  const std::vector<Transform> truth = truthSeries();
  std::vector<EstimateSample> estimates = approach(0.1, 1.0);
  for (int i = 0; i < 150; i += 50) estimates[i] = estimateAt(estimates[i].pose.stamp, 2.0, 1.0);
  const Result<PoseEvaluation> r = evaluatePoses(estimates, truth);
  ASSERT_TRUE(r.isOk());
  EXPECT_EQ(
      find(checkRequirements(*r, Statistic::kP95), "SR_DFPC_0100", "position_error_m").verdict,
      Verdict::kPass);
  EXPECT_EQ(
      find(checkRequirements(*r, Statistic::kMax), "SR_DFPC_0100", "position_error_m").verdict,
      Verdict::kFail);
}

TEST(Requirements, ATrackLossLongerThanTenSecondsFailsTheUpdateRate) {
  const std::vector<Transform> truth = truthSeries();
  std::vector<EstimateSample> estimates = approach(0.01, 0.1);
  for (int i = 40; i < 52; ++i) estimates[i].valid = false;  // 13 s between valid estimates
  const Result<PoseEvaluation> r = evaluatePoses(estimates, truth);
  ASSERT_TRUE(r.isOk());
  const RequirementVerdict& rate = find(checkRequirements(*r), "SR_DFPC_0102", "update_rate_hz");
  EXPECT_EQ(rate.verdict, Verdict::kFail);
  EXPECT_NEAR(rate.measured, 1.0 / 13.0, 1e-9);
}

TEST(Report, JsonHasTheDocumentedKeysAndHtmlIsSelfContained) {
  const std::vector<Transform> truth = truthSeries();
  Result<PoseEvaluation> r = evaluatePoses(approach(0.02, 0.3), truth);
  ASSERT_TRUE(r.isOk());
  EvaluationReport report;
  report.input = "run.mcap";
  r->channel = "/cdff/lidar_tracking/pose";
  r->truth_channel = "/truth/target_pose";
  report.requirements = checkRequirements(*r);
  report.products.push_back(*r);

  const nlohmann::json json = toJson(report);
  const nlohmann::json& product = json.at("products").at(0);
  EXPECT_EQ(product.at("channel"), "/cdff/lidar_tracking/pose");
  for (const char* key : {"position_error_m", "position_error_pct_range", "angle_error_deg"})
    for (const char* stat : {"rmse", "p95", "max"})
      EXPECT_TRUE(product.at(key).at(stat).is_number()) << key << "." << stat;
  EXPECT_TRUE(product.at("tracked_fraction").is_number());
  EXPECT_TRUE(product.at("rate_hz").is_number());
  EXPECT_TRUE(product.at("latency_ms").at("p95").is_null());  // no latency was recorded
  for (const nlohmann::json& v : json.at("requirements")) {
    for (const char* key : {"id", "verdict", "measured", "threshold"})
      EXPECT_TRUE(v.contains(key)) << key;
  }
  EXPECT_TRUE(json.at("all_pass").get<bool>());

  const std::string html = toHtml(report);
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_NE(html.find("SR_DFPC_0100"), std::string::npos);
  EXPECT_EQ(html.find("http://"), html.find("http://www.w3.org/2000/svg"));  // no remote asset
  EXPECT_EQ(html.find("<script src"), std::string::npos);
  EXPECT_NE(toText(report).find("SR_DFPC_0102"), std::string::npos);
}

}  // namespace
}  // namespace cdff::eval
