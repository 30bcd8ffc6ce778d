// EstimationFilter's position measurements (far range: a bearing and a radar range, attitude not
// observed): on a synthetic approach the position-only filter must converge with an honest
// covariance (NEES within the 95 % chi-square bounds over Monte Carlo runs) while saying that
// the attitude is not observed; the first pose measurement must take the attitude over without
// a jump of the position beyond its covariance, and the filter must be consistent from there;
// the 3-dof gate sits at the 6-dof gate's probability; bad inputs leave the filter unchanged.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "EstimationFilter.gen.hpp"
#include "cdff/types/statistics.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<EstimationFilter> make(const std::string& yaml = "{}") {
  return testing::makeDfn<EstimationFilter>("EstimationFilter", "ExtendedKalman", yaml);
}

// A target 300 m ahead closing at 2 m/s and tumbling at 2 deg/s in the servicer frame.
struct Truth {
  Eigen::Vector3d p0{300.0, 12.0, -8.0};
  Eigen::Vector3d v{-2.0, 0.05, 0.03};
  Eigen::Quaterniond q0 = expSO3(Eigen::Vector3d(0.3, -1.2, 2.0));
  Eigen::Vector3d w = Eigen::Vector3d(1, 2, 0.5).normalized() * (2.0 * M_PI / 180.0);

  Eigen::Vector3d position(double t) const { return p0 + v * t; }
  Eigen::Quaterniond attitude(double t) const { return expSO3(w * t) * q0; }
};

constexpr double kRangeSigma = 1.0;     // m, along the line of sight (the radar)
constexpr double kAcrossSigma = 0.5;    // m, across it (the bearing times the range)
constexpr double kPoseSigmaP = 0.03;    // m, per axis (a LIDAR registration)
constexpr double kPoseSigmaR = 0.01;    // rad, per axis
constexpr double kGate = 22.457744484;  // chi-square 6 dof, 0.999

// A far-range position: anisotropic noise, tight across the line of sight, loose along it.
PoseWithCovariance positionSample(const Truth& truth, double t, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d p = truth.position(t);
  const Eigen::Vector3d d = p.normalized();
  const Eigen::Matrix3d along = d * d.transpose();
  const Eigen::Matrix3d cov = kRangeSigma * kRangeSigma * along +
                              kAcrossSigma * kAcrossSigma * (Eigen::Matrix3d::Identity() - along);
  const Eigen::Matrix3d l = cov.llt().matrixL();
  PoseWithCovariance z;
  z.pose = Transform::identity("servicer", "target", fromSeconds(t));
  z.pose.translation = p + l * Eigen::Vector3d(n(rng), n(rng), n(rng));
  z.covariance.topLeftCorner<3, 3>() = cov;
  z.covariance.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * M_PI * M_PI;
  return z;
}

PoseWithCovariance poseSample(const Truth& truth, double t, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  PoseWithCovariance z;
  z.pose = Transform::identity("servicer", "target", fromSeconds(t));
  z.pose.translation = truth.position(t) + kPoseSigmaP * Eigen::Vector3d(n(rng), n(rng), n(rng));
  z.pose.rotation =
      expSO3(kPoseSigmaR * Eigen::Vector3d(n(rng), n(rng), n(rng))) * truth.attitude(t);
  z.covariance.diagonal() << Eigen::Vector3d::Constant(kPoseSigmaP * kPoseSigmaP),
      Eigen::Vector3d::Constant(kPoseSigmaR * kPoseSigmaR);
  return z;
}

double nees(const Eigen::VectorXd& e, const Eigen::MatrixXd& p) {
  return e.dot(p.ldlt().solve(e));
}

struct Bounds {
  double low, high;
};
// The 95 % interval of the averaged NEES of `runs` independent runs of `dof` dof each.
Bounds aneesBounds(int runs, int dof) {
  return {chiSquareQuantile(0.025, runs * dof) / runs, chiSquareQuantile(0.975, runs * dof) / runs};
}

TEST(EstimationFilterPosition, PositionOnlyCorrectionsConvergeWithAnHonestCovariance) {
  // The truth has a constant velocity, so the process noise is set near zero: the model is
  // exact and the position covariance must describe the actual errors.
  constexpr int kRuns = 50;
  const Truth truth;
  double sum_nees = 0, sum_e2 = 0;
  long samples = 0;
  for (int run = 0; run < kRuns; ++run) {
    // No gate (its own test's subject): a 0.999 gate would drop 1 in 1000 at random.
    auto ekf = make("{linear_acceleration_psd: 1.0e-12, angular_acceleration_psd: 1.0e-12}");
    std::mt19937 rng(500 + run);
    double run_nees = 0;
    int run_samples = 0;
    for (int k = 0; k <= 120; ++k) {  // 1 Hz, 2 minutes
      const double t = k;
      ekf->in.position_measurement.set(positionSample(truth, t, rng));
      ASSERT_OK(ekf->process());
      const RigidBodyState& s = *ekf->out.state;
      ASSERT_TRUE(*ekf->out.measurement_accepted) << "run " << run << " t " << t;
      ASSERT_EQ(*ekf->out.track_state, TrackState::kTracking);
      // Not observed: the attitude keeps at least its initial uncertainty (pi per axis).
      const double attitude_variance = s.covariance.block<3, 3>(3, 3).diagonal().minCoeff();
      ASSERT_GE(attitude_variance, (1 - 1e-12) * M_PI * M_PI);
      ASSERT_EQ(s.pose.rotation.coeffs(), Eigen::Quaterniond::Identity().coeffs());
      if (t < 20.0) continue;
      const Eigen::Vector3d e = s.pose.translation - truth.position(t);
      run_nees += nees(e, s.covariance.topLeftCorner<3, 3>());
      sum_e2 += e.squaredNorm();
      ++run_samples, ++samples;
    }
    sum_nees += run_nees / run_samples;
  }
  const double anees = sum_nees / kRuns;
  const Bounds b = aneesBounds(kRuns, 3);
  const double rmse = std::sqrt(sum_e2 / samples);
  const double measured = std::sqrt(kRangeSigma * kRangeSigma + 2 * kAcrossSigma * kAcrossSigma);
  RecordProperty("position_rmse_m", fmt::format("{:.3f} (measurements {:.3f})", rmse, measured));
  RecordProperty("anees_3dof", fmt::format("{:.3f} in [{:.3f}, {:.3f}]", anees, b.low, b.high));
  EXPECT_GT(anees, b.low) << "position ANEES " << anees << ": pessimistic";
  EXPECT_LT(anees, b.high) << "position ANEES " << anees << ": overconfident";
  // Averaging 20 to 120 measurements of a constant-velocity track: well below one measurement.
  EXPECT_LT(rmse, 0.5 * measured) << "position RMSE " << rmse;
}

// Position-only for 300 s (the rendezvous's far leg), then pose measurements for 30 s. The
// position must not jump beyond its covariance at the hand-over, the attitude must be the
// measured one at once (within the measurement's noise), the angular velocity never
// overconfident while it settles, and the filter consistent (pose NEES) from 5 s after the
// hand-over. (With attitude_takeover_sigma out of the way, a plain 6-dof update, the same runs
// give the same pose ANEES, 5.98, and a worst rate NEES of 20.5 against 15.9: the update from a
// huge attitude covariance is hardly degraded here; the take-over does not rest on the
// placeholder's correlation with the angular velocity.)
TEST(EstimationFilterPosition, APoseMeasurementTakesTheAttitudeOverCleanly) {
  constexpr int kRuns = 30;
  constexpr double kHandOver = 300.0, kEnd = 330.0, kSettle = 5.0;
  const Truth truth;
  double worst_jump = 0, worst_first = 0, sum_nees = 0, worst_rate = 0;
  for (int run = 0; run < kRuns; ++run) {
    // No gate (its own test's subject): a 0.999 gate would drop 1 in 1000 at random.
    auto ekf = make("{linear_acceleration_psd: 1.0e-12, angular_acceleration_psd: 1.0e-12}");
    std::mt19937 rng(900 + run);
    RigidBodyState before;
    double run_nees = 0;
    int run_samples = 0;
    for (int k = 0; k <= static_cast<int>(kEnd * 10); ++k) {
      const double t = k / 10.0;
      const bool far = t < kHandOver;
      if (far && k % 10 != 0) continue;  // positions at 1 Hz, poses at 10 Hz
      if (t == kHandOver) {              // the prediction to the first pose's time, to compare with
        ekf->in.time.set(fromSeconds(t));
        ASSERT_OK(ekf->process());
        before = *ekf->out.state;
      }
      if (far) ekf->in.position_measurement.set(positionSample(truth, t, rng));
      if (!far) ekf->in.pose_measurement.set(poseSample(truth, t, rng));
      ASSERT_OK(ekf->process());
      const RigidBodyState& s = *ekf->out.state;
      ASSERT_TRUE(*ekf->out.measurement_accepted) << "run " << run << " t " << t;
      if (far) continue;
      if (t == kHandOver) {
        // The jump against the predicted covariance, the attitude error against the
        // measurement's.
        const Eigen::Vector3d jump = s.pose.translation - before.pose.translation;
        worst_jump = std::max(worst_jump, nees(jump, before.covariance.topLeftCorner<3, 3>()));
        worst_first = std::max(worst_first,
                               angularDistance(s.pose.rotation, truth.attitude(t)) / kPoseSigmaR);
      }
      if (t < kHandOver + kSettle) {
        const Eigen::Vector3d rate_error = s.twist.angular - truth.w;
        worst_rate = std::max(worst_rate, nees(rate_error, s.covariance.block<3, 3>(9, 9)));
        continue;
      }
      Eigen::Matrix<double, 6, 1> e;
      e.head<3>() = s.pose.translation - truth.position(t);
      e.tail<3>() = logSO3(s.pose.rotation * truth.attitude(t).conjugate());
      run_nees += nees(e, s.covariance.topLeftCorner<6, 6>());
      ++run_samples;
    }
    sum_nees += run_nees / run_samples;
  }
  const double anees = sum_nees / kRuns;
  const Bounds b = aneesBounds(kRuns, 6);
  RecordProperty("handover_worst_jump_nees", fmt::format("{:.3f}", worst_jump));
  RecordProperty("first_attitude_error_sigmas", fmt::format("{:.3f}", worst_first));
  RecordProperty("settling_worst_rate_nees", fmt::format("{:.3f}", worst_rate));
  RecordProperty("anees_6dof_after",
                 fmt::format("{:.3f} in [{:.3f}, {:.3f}]", anees, b.low, b.high));
  // 3 sigma in 3 dof (the 0.997 quantile) for every one of the runs.
  EXPECT_LT(worst_jump, chiSquareQuantile(0.9973, 3)) << "a hand-over jumped beyond 3 sigma";
  // The measured attitude's error is kPoseSigmaR per axis: its angle below 4.5 sigma (the
  // 3-dof chi-square 0.9999 quantile's root) in every run.
  EXPECT_LT(worst_first, std::sqrt(chiSquareQuantile(0.9999, 3)));
  // While the angular velocity settles (the attitude taken over, the rate restarted from its
  // prior), never overconfident: below the 3-dof 0.9999 quantile at every step of every run.
  EXPECT_LT(worst_rate, chiSquareQuantile(0.9999, 3)) << "angular velocity overconfident";
  EXPECT_GT(anees, b.low) << "pose ANEES " << anees << " after the hand-over: pessimistic";
  EXPECT_LT(anees, b.high) << "pose ANEES " << anees << " after the hand-over: overconfident";
}

// Gate between the 3-dof (16.27) and the 6-dof (22.46) quantiles: the position gate is the
// 3-dof one. A known state and a measurement at its time give NIS = r^2 / (P + R) on one axis.
TEST(EstimationFilterPosition, ThePositionGateIsTheThreeDofQuantileAtTheSameProbability) {
  RigidBodyState s0;
  s0.pose = Transform::identity("servicer", "target", 1'000'000);
  s0.pose.translation = {100.0, 0.0, 0.0};
  s0.covariance = Matrix12d::Identity() * 1e-2;
  const double r = 0.03;  // measurement variance per axis
  for (const double target_nis : {15.0, 19.0}) {
    auto ekf = make(fmt::format("{{innovation_gate: {}}}", kGate));
    ekf->in.initial_state.set(s0);
    ASSERT_OK(ekf->process());
    PoseWithCovariance z;
    z.pose = s0.pose;
    z.pose.translation.x() += std::sqrt(target_nis * (1e-2 + r));
    z.covariance.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * r;
    ekf->in.position_measurement.set(z);
    ASSERT_OK(ekf->process());
    EXPECT_NEAR(*ekf->out.innovation_nis, target_nis, 1e-9 * target_nis);
    EXPECT_EQ(*ekf->out.measurement_accepted, target_nis < chiSquareQuantile(0.999, 3))
        << "NIS " << target_nis;
    EXPECT_EQ(*ekf->out.track_state, target_nis < chiSquareQuantile(0.999, 3)
                                         ? TrackState::kTracking
                                         : TrackState::kAcquiring);
  }
}

// Lost on positions: the next position re-initialises the position only (reacquire); a pose
// then takes over the attitude exactly (its covariance, the measurement's attitude block).
TEST(EstimationFilterPosition, LostPositionsReacquireAndAPoseTakesTheAttitudeOver) {
  auto ekf = make(fmt::format("{{innovation_gate: {}, lost_after: 1.0, reacquire: true}}", kGate));
  const Truth truth;
  std::mt19937 rng(3);
  ekf->in.position_measurement.set(positionSample(truth, 0.0, rng));
  ASSERT_OK(ekf->process());
  EXPECT_EQ(*ekf->out.track_state, TrackState::kTracking);
  ekf->in.time.set(fromSeconds(1.5));
  ASSERT_OK(ekf->process());
  EXPECT_EQ(*ekf->out.track_state, TrackState::kLost);
  const Matrix12d coasted = ekf->out.state->covariance;
  PoseWithCovariance z = positionSample(truth, 2.0, rng);
  z.pose.translation += Eigen::Vector3d(0, 50.0, 0);  // far beyond the gate
  ekf->in.position_measurement.set(z);
  ASSERT_OK(ekf->process());
  EXPECT_EQ(*ekf->out.track_state, TrackState::kTracking);
  const RigidBodyState s = *ekf->out.state;
  EXPECT_EQ(s.pose.translation, z.pose.translation);
  EXPECT_EQ(Eigen::Matrix3d(s.covariance.topLeftCorner<3, 3>()),
            Eigen::Matrix3d(z.covariance.topLeftCorner<3, 3>()));
  EXPECT_TRUE((s.covariance.block<3, 9>(0, 3).isZero(0.0)));
  // The attitude and twist blocks as predicted to 2 s (0.5 s on from `coasted`): still unknown.
  EXPECT_GE(s.covariance(3, 3), coasted(3, 3));

  // A pose near the reacquired position (within its covariance), with the true attitude.
  PoseWithCovariance pose = poseSample(truth, 2.1, rng);
  pose.pose.translation = s.pose.translation + Eigen::Vector3d(0.2, -0.1, 0.1);
  ekf->in.pose_measurement.set(pose);
  ASSERT_OK(ekf->process());
  ASSERT_TRUE(*ekf->out.measurement_accepted);
  const RigidBodyState& taken = *ekf->out.state;
  EXPECT_EQ(taken.pose.rotation.coeffs(), pose.pose.rotation.coeffs());
  EXPECT_EQ(Eigen::Matrix3d(taken.covariance.block<3, 3>(3, 3)),
            Eigen::Matrix3d(pose.covariance.block<3, 3>(3, 3)));
  EXPECT_EQ(taken.twist.angular, Eigen::Vector3d::Zero());
  // The position is a 3-dof update: between the prediction and the measurement.
  EXPECT_LT((taken.pose.translation - pose.pose.translation).norm(),
            (s.pose.translation - pose.pose.translation).norm());
  // From now on the attitude is observed: the next pose is an ordinary 6-dof update.
  ekf->in.pose_measurement.set(poseSample(truth, 2.2, rng));
  ASSERT_OK(ekf->process());
  EXPECT_NE(ekf->out.state->pose.rotation.coeffs(), pose.pose.rotation.coeffs());
  EXPECT_LT(angularDistance(ekf->out.state->pose.rotation, truth.attitude(2.2)), 5 * kPoseSigmaR);
}

TEST(EstimationFilterPosition, BadPositionMeasurementsAreReportedAndLeaveTheFilterUnchanged) {
  auto ekf = make(), reference = make();
  const Truth truth;
  std::mt19937 rng(8), rng_ref(8);
  ekf->in.position_measurement.set(positionSample(truth, 1.0, rng));
  reference->in.position_measurement.set(positionSample(truth, 1.0, rng_ref));
  ASSERT_OK(ekf->process());
  ASSERT_OK(reference->process());

  PoseWithCovariance z = positionSample(truth, 2.0, rng);
  z.pose.translation.y() = std::nan("");
  ekf->in.position_measurement.set(z);
  testing::expectRejected(*ekf, "input 'position_measurement' translation");

  z = positionSample(truth, 2.0, rng);
  z.covariance(1, 1) = -0.25;
  ekf->in.position_measurement.set(z);
  testing::expectRejected(*ekf, "not symmetric positive definite (diagonal");

  z = positionSample(truth, 2.0, rng);
  z.covariance(0, 2) += 0.1;  // asymmetric
  ekf->in.position_measurement.set(z);
  testing::expectRejected(*ekf, "not symmetric positive definite");

  z = positionSample(truth, 2.0, rng);
  z.covariance(2, 2) = std::numeric_limits<double>::infinity();
  ekf->in.position_measurement.set(z);
  testing::expectRejected(*ekf, "non-finite");

  z = positionSample(truth, 0.5, rng);
  ekf->in.position_measurement.set(z);
  testing::expectRejected(*ekf, "input 'position_measurement' at t = 500000 us is older");

  z = positionSample(truth, 2.0, rng);
  z.pose.child_frame = "debris";
  ekf->in.position_measurement.set(z);
  testing::expectRejected(*ekf,
                          "input 'position_measurement' is servicer_T_debris; expected "
                          "servicer_T_target");

  // The rejected calls changed nothing: the same measurement gives the reference's state.
  const PoseWithCovariance good = positionSample(truth, 2.0, rng);
  for (auto* f : {ekf.get(), reference.get()}) {
    f->in.position_measurement.set(good);
    ASSERT_OK(f->process());
  }
  EXPECT_EQ(ekf->out.state->pose.translation, reference->out.state->pose.translation);
  EXPECT_EQ(ekf->out.state->covariance, reference->out.state->covariance);

  // Made from the estimate that a reset replaces: not used, with a warning.
  const RigidBodyState reset = *ekf->out.state;
  ekf->in.initial_state.set(reset);
  ekf->in.position_measurement.set(positionSample(truth, 3.0, rng));
  const auto warnings = ekf->diagnostics().warning_count;
  ASSERT_OK(ekf->process());
  EXPECT_EQ(ekf->diagnostics().warning_count, warnings + 1);
  EXPECT_FALSE(*ekf->out.measurement_accepted);
  EXPECT_EQ(ekf->out.state->pose.translation, reset.pose.translation);
}

// Another filter's estimates adopted as this one's (far range, then the LIDAR): each replaces
// the estimate as a fix, nothing is fused twice; without them the filter coasts and is LOST after
// lost_after; a pose measurement then reacquires the pose, attitude included.
RigidBodyState referenceAt(const Truth& truth, double t) {
  RigidBodyState s;
  s.pose = Transform::identity("servicer", "target", fromSeconds(t));
  s.pose.translation = truth.position(t);
  s.twist.linear = truth.v;
  s.covariance = Matrix12d::Identity() * 0.01;
  s.covariance.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * M_PI * M_PI;  // unobserved
  return s;
}

TEST(EstimationFilterPosition, AReferenceStateIsAdoptedNotFused) {
  const Truth truth;
  auto filter = make("{lost_after: 1.0, reacquire: true}");
  for (int k = 0; k < 5; ++k) {
    const RigidBodyState reference = referenceAt(truth, 1.0 * k);
    filter->in.reference_state.set(reference);
    ASSERT_OK(filter->process());
    EXPECT_EQ(*filter->out.track_state, TrackState::kTracking);
    // The estimate is the reference, its covariance too: five adoptions are not five fusions.
    EXPECT_LT((filter->out.state->pose.translation - reference.pose.translation).norm(), 1e-12);
    EXPECT_LT((filter->out.state->covariance - reference.covariance).norm(), 1e-12);
  }
  filter->in.time.set(fromSeconds(5.5));
  ASSERT_OK(filter->process());
  EXPECT_NEAR((filter->out.state->pose.translation - truth.position(5.5)).norm(), 0.0, 1e-9);
  filter->in.time.set(fromSeconds(6.5));  // 2.5 s after the last reference
  ASSERT_OK(filter->process());
  EXPECT_EQ(*filter->out.track_state, TrackState::kLost);
  std::mt19937 rng(5);
  filter->in.pose_measurement.set(poseSample(truth, 7.0, rng));
  ASSERT_OK(filter->process());
  EXPECT_EQ(*filter->out.track_state, TrackState::kTracking);
  EXPECT_LT(angularDistance(filter->out.state->pose.rotation, truth.attitude(7.0)),
            5 * kPoseSigmaR * std::sqrt(3.0));
}

TEST(EstimationFilterPosition, BadReferenceStatesAreReportedAndLeaveTheFilterUnchanged) {
  const Truth truth;
  auto filter = make();
  filter->in.reference_state.set(referenceAt(truth, 2.0));
  ASSERT_OK(filter->process());
  const RigidBodyState before = *filter->out.state;
  filter->in.reference_state.set(referenceAt(truth, 1.0));  // older: not adopted, a warning
  ASSERT_OK(filter->process());
  EXPECT_EQ(filter->out.state->pose.stamp, before.pose.stamp);
  ASSERT_FALSE(filter->diagnostics().warnings.empty());
  EXPECT_NE(filter->diagnostics().warnings.back().find("not adopted"), std::string::npos);
  RigidBodyState singular = referenceAt(truth, 3.0);
  singular.covariance.block<3, 3>(9, 9).setZero();
  filter->in.reference_state.set(singular);
  testing::expectRejected(*filter, "not positive definite");
  RigidBodyState other = referenceAt(truth, 3.0);
  other.pose.child_frame = "marker";
  filter->in.reference_state.set(other);
  testing::expectRejected(*filter, "expected servicer_T_target");
  filter->in.time.set(fromSeconds(2.0));
  ASSERT_OK(filter->process());
  EXPECT_LT((filter->out.state->pose.translation - before.pose.translation).norm(), 1e-12);
}

TEST(EstimationFilterPosition, BadAttitudeParametersAreRejected) {
  auto node = Registry::instance().create("EstimationFilter", "ExtendedKalman");
  ASSERT_TRUE(node.isOk());
  for (const char* yaml : {"{unknown_attitude_sigma: 0.5}", "{attitude_takeover_sigma: 0}"}) {
    const Status s = node.value()->configure(YAML::Load(yaml));
    EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << yaml;
    EXPECT_NE(s.message().find(std::string(yaml).substr(1, 12)), std::string::npos) << s.message();
  }
}

}  // namespace
}  // namespace cdff::dfn
