// The evaluation library against series whose errors are known by construction.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Cholesky>

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

// A state moving at 1 m/s along x, reported every 0.1 s with a 1 cm position sigma: the steps
// predicted with its twist are nothing; a 5 cm jump at 1.0 s is 5 sigma; steps across an invalid
// estimate are not counted; a product without twists (measurements) has no steps.
TEST(Continuity, StepsUnderTheFirstEstimatesCovarianceFollowTheTwist) {
  std::vector<EstimateSample> estimates;
  for (int k = 0; k <= 20; ++k) {
    EstimateSample e;
    e.pose = Transform::identity("servicer", "target", fromSeconds(0.1 * k));
    e.pose.translation = {0.1 * k + (k >= 10 ? 0.05 : 0.0), 0, 10};
    if (k >= 15) e.pose.translation.x() += 1.0;  // after the invalid one: a fresh start
    e.covariance = Matrix6d::Identity() * 1e-4;
    e.twist = Twist{{1.0, 0, 0}, {0, 0, 0}};
    e.valid = k != 14;
    estimates.push_back(e);
  }
  const Continuity c = continuityOf(estimates);
  EXPECT_EQ(c.steps.size(), 18u);  // 20 pairs, less the two that touch the invalid estimate
  EXPECT_EQ(c.jumps, 1u);
  EXPECT_NEAR(c.max_sigma, 5.0, 1e-6);
  EXPECT_EQ(c.worst_stamp, fromSeconds(1.0));
  EXPECT_NEAR(c.maxWithin(fromSeconds(1.1), fromSeconds(2.0)), 0.0, 1e-6);
  EXPECT_TRUE(std::isnan(c.maxWithin(fromSeconds(5), fromSeconds(6))));
  // An estimate after its DFPC was started again: no step into it.
  estimates[10].restarted = true;
  const Continuity restarted = continuityOf(estimates);
  EXPECT_EQ(restarted.steps.size(), 17u);
  EXPECT_EQ(restarted.jumps, 0u);
  for (EstimateSample& e : estimates) e.twist.reset();
  EXPECT_TRUE(continuityOf(estimates).steps.empty());
}

// An estimate that states its attitude unobserved (a 180 deg sigma: far range's target state)
// has no angle error and no attitude NEES; its position error and position NEES count.
TEST(EvaluatePoses, AnUnobservedAttitudeIsNotEvaluated) {
  std::vector<Transform> truth;
  std::vector<EstimateSample> estimates;
  for (int k = 0; k < 4; ++k) {
    Transform t = Transform::identity("servicer", "target", fromSeconds(k));
    t.translation = {0, 0, 500.0 - k};
    truth.push_back(t);
    EstimateSample e;
    e.pose = t;
    e.pose.translation.x() += 2.0;  // 2 m off, with a 2 m sigma: position NEES 1
    e.pose.rotation = expSO3(Eigen::Vector3d(0, 2.0, 0));  // 115 deg off: a placeholder
    Matrix6d c = Matrix6d::Identity() * 4.0;
    c.bottomRightCorner<3, 3>() *= (k < 3 ? M_PI * M_PI : 1e-4) / 4.0;  // the last observed
    e.covariance = c;
    estimates.push_back(e);
  }
  Result<PoseEvaluation> r = evaluatePoses(estimates, truth);
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r->position_error_m.count, 4u);
  EXPECT_EQ(r->angle_error_deg.count, 1u);  // the observed one only
  EXPECT_TRUE(std::isnan(r->errors[0].angle_error_deg));
  EXPECT_NEAR(r->errors[3].angle_error_deg, 2.0 * 180.0 / M_PI, 1e-9);
  EXPECT_NEAR(r->covariance.position_nees_mean, 1.0, 1e-9);
  EXPECT_EQ(r->covariance.count, 1u);  // 6-dof NEES for the observed one only
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

// 3000 estimates at 20 Hz whose errors are drawn from N(0, covariance) (correlated across
// position and attitude), each carrying `reported` as its covariance.
std::vector<EstimateSample> drawnFrom(const Matrix6d& covariance, const Matrix6d& reported) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal;
  const Eigen::LLT<Matrix6d> llt(covariance);
  std::vector<EstimateSample> estimates;
  for (int i = 0; i < 3000; ++i) {
    Vector6d z;
    for (int k = 0; k < 6; ++k) z[k] = normal(rng);
    const Vector6d error = llt.matrixL() * z;  // truth = estimate + error (conventions)
    EstimateSample e;
    e.pose = truthPose(fromSeconds(0.025 + 0.05 * i));
    e.pose.translation -= error.head<3>();
    e.pose.rotation = (expSO3(-error.tail<3>()) * e.pose.rotation).normalized();
    e.covariance = reported;
    estimates.push_back(e);
  }
  return estimates;
}

Matrix6d correlatedCovariance() {
  Vector6d sigma;
  sigma << 0.02, 0.01, 0.03, 0.3 * kDegToRad, 0.5 * kDegToRad, 0.2 * kDegToRad;
  Matrix6d correlation = Matrix6d::Identity();
  correlation(0, 4) = correlation(4, 0) = 0.6;  // a lateral shift traded for a turn
  correlation(1, 2) = correlation(2, 1) = -0.4;
  return sigma.asDiagonal() * correlation * sigma.asDiagonal();
}

TEST(EvaluatePoses, TheNeesOfAnHonestCovarianceAveragesItsDegreesOfFreedom) {
  const Matrix6d c = correlatedCovariance();
  const Result<PoseEvaluation> honest = evaluatePoses(drawnFrom(c, c), truthSeries());
  ASSERT_TRUE(honest.isOk()) << honest.status().toString();
  const CovarianceConsistency& h = honest->covariance;
  EXPECT_EQ(h.count, 3000u);
  EXPECT_EQ(h.rejected, 0u);
  // Over 3000 chi-square(6) draws the mean has a standard deviation of sqrt(12 / 3000) = 0.06
  // and the fraction within the 95 % bound one of 0.004: the tolerances are about 5 of them.
  EXPECT_NEAR(h.nees_mean, 6.0, 0.3);
  EXPECT_NEAR(h.position_nees_mean, 3.0, 0.25);
  EXPECT_NEAR(h.attitude_nees_mean, 3.0, 0.25);
  EXPECT_NEAR(h.within_95_fraction, 0.95, 0.02);
  EXPECT_NEAR(h.nees_p95, CovarianceConsistency::kChiSquare6Dof95, 1.0);

  // Reported four times too large in variance: the NEES averages 6 / 4; four times too small:
  // 6 x 4, and most errors fall outside the bound.
  const Result<PoseEvaluation> pessimistic = evaluatePoses(drawnFrom(c, 4 * c), truthSeries());
  ASSERT_TRUE(pessimistic.isOk());
  EXPECT_NEAR(pessimistic->covariance.nees_mean, 1.5, 0.1);
  EXPECT_GT(pessimistic->covariance.within_95_fraction, 0.99);
  const Result<PoseEvaluation> optimistic = evaluatePoses(drawnFrom(c, c / 4), truthSeries());
  ASSERT_TRUE(optimistic.isOk());
  EXPECT_NEAR(optimistic->covariance.nees_mean, 24.0, 1.2);
  EXPECT_LT(optimistic->covariance.within_95_fraction, 0.4);
}

TEST(EvaluatePoses, EstimatesWithoutAUsableCovarianceAreLeftOutOfTheNees) {
  const std::vector<Transform> truth = truthSeries(10.0);
  std::vector<EstimateSample> estimates;
  for (int i = 0; i < 4; ++i) estimates.push_back(estimateAt(fromSeconds(1.0 + i), 0.01, 0.1));
  estimates[1].covariance = Matrix6d::Identity() * 1e-4;
  estimates[2].covariance = -Matrix6d::Identity();  // not positive definite
  estimates[3].covariance = Matrix6d::Identity();
  (*estimates[3].covariance)(2, 2) = std::numeric_limits<double>::quiet_NaN();
  const Result<PoseEvaluation> r = evaluatePoses(estimates, truth);
  ASSERT_TRUE(r.isOk());
  EXPECT_EQ(r->covariance.count, 1u);
  EXPECT_EQ(r->covariance.rejected, 2u);
  // 1 cm and 0.1 deg under a 1 cm / 0.57 deg sigma.
  EXPECT_NEAR(r->covariance.nees_mean, 1.0 + std::pow(0.1 * kDegToRad / 1e-2, 2), 1e-6);
  EXPECT_TRUE(std::isnan(r->errors[0].nees));

  const Result<PoseEvaluation> none = evaluatePoses({estimateAt(fromSeconds(1.0), 0, 0)}, truth);
  ASSERT_TRUE(none.isOk());
  EXPECT_EQ(none->covariance.count, 0u);
  EXPECT_TRUE(std::isnan(none->covariance.nees_mean));
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
  EXPECT_TRUE(product.at("latency_ms").at("p95").is_null());    // no latency was recorded
  EXPECT_TRUE(product.at("covariance_consistency").is_null());  // no covariance either
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
  EXPECT_EQ(toText(report).find("NEES"), std::string::npos);

  const Matrix6d c = correlatedCovariance();
  Result<PoseEvaluation> with_covariance = evaluatePoses(drawnFrom(c, c), truth);
  ASSERT_TRUE(with_covariance.isOk());
  report.products = {*with_covariance};
  const nlohmann::json with_covariance_json = toJson(report);
  const nlohmann::json& consistency =
      with_covariance_json.at("products").at(0).at("covariance_consistency");
  for (const char* key : {"nees_mean", "nees_p95", "within_95_fraction", "position_nees_mean",
                          "attitude_nees_mean", "bound_95"})
    EXPECT_TRUE(consistency.at(key).is_number()) << key;
  EXPECT_EQ(consistency.at("count"), 3000u);
  EXPECT_NE(toText(report).find("NEES mean"), std::string::npos);
  EXPECT_NE(toHtml(report).find("NEES"), std::string::npos);
}

}  // namespace
}  // namespace cdff::eval
