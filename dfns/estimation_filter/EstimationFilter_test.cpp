// EstimationFilter: on a simulated constant-twist relative trajectory observed through noisy
// pose measurements, the filtered error must be well below the measurement noise and the
// filter's covariance must be consistent with its actual errors (NEES within the 95 % chi-square
// bounds over Monte Carlo runs). Prediction must follow the constant-velocity model exactly, the
// gate must reject outliers, and bad inputs must leave the filter unchanged.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "EstimationFilter.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/types/statistics.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<EstimationFilter> make(const std::string& yaml = "{}") {
  return testing::makeDfn<EstimationFilter>("EstimationFilter", "ExtendedKalman", yaml);
}

// Target drifting at a few cm/s and tumbling at 2 deg/s in the servicer frame.
struct Truth {
  Eigen::Vector3d p0{1.0, -0.5, 10.0};
  Eigen::Quaterniond q0 = expSO3(Eigen::Vector3d(0.3, -0.2, 0.1));
  Eigen::Vector3d v{0.05, -0.02, 0.01};
  Eigen::Vector3d w = Eigen::Vector3d(1, 2, 0.5).normalized() * (2.0 * M_PI / 180.0);

  Eigen::Vector3d position(double t) const { return p0 + v * t; }
  Eigen::Quaterniond attitude(double t) const { return expSO3(w * t) * q0; }
};

constexpr double kSigmaP = 0.05;                // m, per axis
constexpr double kSigmaR = 1.0 * M_PI / 180.0;  // rad, per axis
constexpr double kRate = 10.0;                  // Hz
constexpr double kDuration = 60.0;              // s
constexpr double kSettle = 10.0;                // s, errors are counted after this

PoseWithCovariance measure(const Truth& truth, double t, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  PoseWithCovariance z;
  z.pose = Transform::identity("servicer", "target", fromSeconds(t));
  z.pose.translation = truth.position(t) + kSigmaP * Eigen::Vector3d(n(rng), n(rng), n(rng));
  z.pose.rotation = expSO3(kSigmaR * Eigen::Vector3d(n(rng), n(rng), n(rng))) * truth.attitude(t);
  z.covariance.diagonal() << Eigen::Vector3d::Constant(kSigmaP * kSigmaP),
      Eigen::Vector3d::Constant(kSigmaR * kSigmaR);
  return z;
}

// The error of a state in the filter's own error coordinates [dt, dtheta, dv, domega].
Eigen::Matrix<double, 12, 1> stateError(const RigidBodyState& s, const Truth& truth, double t) {
  Eigen::Matrix<double, 12, 1> e;
  e.segment<3>(0) = s.pose.translation - truth.position(t);
  e.segment<3>(3) = logSO3(s.pose.rotation * truth.attitude(t).conjugate());
  e.segment<3>(6) = s.twist.linear - truth.v;
  e.segment<3>(9) = s.twist.angular - truth.w;
  return e;
}

TEST(EstimationFilterExtendedKalman, FilteredErrorIsBelowTheMeasurementNoiseAndConsistent) {
  // The truth has a constant twist, so the process noise is set near zero: the model is exact
  // and the covariance must then describe the actual errors.
  constexpr int kRuns = 50;
  const Truth truth;
  double sum_p2 = 0, sum_r2 = 0;
  long samples = 0;
  double sum_pose_nees = 0, sum_state_nees = 0;  // sums of per-run time averages
  for (int run = 0; run < kRuns; ++run) {
    auto ekf = make("{linear_acceleration_psd: 1.0e-12, angular_acceleration_psd: 1.0e-12}");
    std::mt19937 rng(1000 + run);
    double run_pose_nees = 0, run_state_nees = 0;
    int run_samples = 0;
    for (int k = 0; k <= static_cast<int>(kDuration * kRate); ++k) {
      const double t = k / kRate;
      ekf->in.pose_measurement.set(measure(truth, t, rng));
      ASSERT_OK(ekf->process());
      if (t < kSettle) continue;
      const RigidBodyState& s = *ekf->out.state;
      const auto e = stateError(s, truth, t);
      sum_p2 += e.segment<3>(0).squaredNorm();
      sum_r2 += e.segment<3>(3).squaredNorm();
      ++samples;
      run_pose_nees +=
          e.head<6>().dot(s.covariance.topLeftCorner<6, 6>().ldlt().solve(e.head<6>()));
      run_state_nees += e.dot(s.covariance.ldlt().solve(e));
      ++run_samples;
    }
    sum_pose_nees += run_pose_nees / run_samples;
    sum_state_nees += run_state_nees / run_samples;
  }
  const double rmse_p = std::sqrt(sum_p2 / samples);  // 3D position error
  const double rmse_r = std::sqrt(sum_r2 / samples);  // attitude error angle
  RecordProperty("position_rmse_m", std::to_string(rmse_p));
  RecordProperty("attitude_rmse_rad", std::to_string(rmse_r));
  // A measurement's 3D error is sqrt(3) sigma; the filter averages hundreds of them.
  EXPECT_LT(rmse_p, 0.25 * std::sqrt(3.0) * kSigmaP) << "position RMSE " << rmse_p;
  EXPECT_LT(rmse_r, 0.25 * std::sqrt(3.0) * kSigmaR) << "attitude RMSE " << rmse_r;

  // Averaged NEES: the mean over runs of each run's time-averaged NEES. Runs are independent, so
  // kRuns * ANEES is at most as spread as a chi-square with kRuns * n dof (time-averaging
  // within a run only narrows it): the 95 % interval of that distribution is a valid test.
  for (const auto& [dof, sum] : {std::pair{6, sum_pose_nees}, std::pair{12, sum_state_nees}}) {
    const double anees = sum / kRuns;
    const double low = chiSquareQuantile(0.025, kRuns * dof) / kRuns;
    const double high = chiSquareQuantile(0.975, kRuns * dof) / kRuns;
    RecordProperty(fmt::format("anees_{}dof", dof),
                   fmt::format("{:.3f} in [{:.3f}, {:.3f}]", anees, low, high));
    EXPECT_GT(anees, low) << dof << "-dof ANEES " << anees << " outside [" << low << ", " << high
                          << "]: the filter is pessimistic";
    EXPECT_LT(anees, high) << dof << "-dof ANEES " << anees << " outside [" << low << ", " << high
                           << "]: the filter is overconfident";
  }
}

RigidBodyState knownState() {
  RigidBodyState s;
  s.pose = Transform::identity("servicer", "target", 1'000'000);
  s.pose.translation = {0.5, 0.2, 8.0};
  s.pose.rotation = expSO3(Eigen::Vector3d(0.1, 0.2, -0.3));
  s.twist.linear = {0.1, -0.05, 0.02};
  s.twist.angular = {0.02, 0.01, -0.03};
  s.covariance = Matrix12d::Identity() * 1e-4;
  return s;
}

TEST(EstimationFilterExtendedKalman, PredictionFollowsTheConstantTwistModelAndGrowsTheCovariance) {
  auto ekf = make();
  const RigidBodyState s0 = knownState();
  ekf->in.initial_state.set(s0);
  ekf->in.time.set(Timestamp{3'500'000});  // 2.5 s later, in the same call
  ASSERT_OK(ekf->process());
  const RigidBodyState& s = *ekf->out.state;
  const double dt = 2.5;
  EXPECT_EQ(s.pose.stamp, 3'500'000);
  EXPECT_LT((s.pose.translation - (s0.pose.translation + s0.twist.linear * dt)).norm(), 1e-12);
  EXPECT_LT(angularDistance(s.pose.rotation, expSO3(s0.twist.angular * dt) * s0.pose.rotation),
            1e-12);
  EXPECT_EQ(s.twist.linear, s0.twist.linear);
  EXPECT_GT(s.covariance.trace(), s0.covariance.trace());
  // Position uncertainty grows with the velocity uncertainty: var = p + 2 dt c + dt^2 v (c = 0).
  EXPECT_GT(s.covariance(0, 0), s0.covariance(0, 0) + dt * dt * s0.covariance(6, 6) * 0.999);
  EXPECT_FALSE(*ekf->out.measurement_accepted);
  EXPECT_TRUE(std::isnan(*ekf->out.innovation_nis));
}

TEST(EstimationFilterExtendedKalman, PredictingThenCorrectingEqualsCorrectingAtTheSameTime) {
  auto split = make(), joint = make();
  for (auto* ekf : {split.get(), joint.get()}) {
    ekf->in.initial_state.set(knownState());
    ASSERT_OK(ekf->process());
  }
  PoseWithCovariance z;
  z.pose = Transform::identity("servicer", "target", 2'000'000);
  z.pose.translation = {0.62, 0.14, 8.03};
  z.pose.rotation = expSO3(Eigen::Vector3d(0.12, 0.21, -0.33));
  split->in.time.set(Timestamp{2'000'000});
  ASSERT_OK(split->process());
  split->in.pose_measurement.set(z);
  ASSERT_OK(split->process());
  joint->in.pose_measurement.set(z);
  ASSERT_OK(joint->process());
  const RigidBodyState &a = *split->out.state, &b = *joint->out.state;
  EXPECT_LT((a.pose.translation - b.pose.translation).norm(), 1e-12);
  EXPECT_LT((a.covariance - b.covariance).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_TRUE(*split->out.measurement_accepted);
  EXPECT_GT(*split->out.innovation_nis, 0.0);
}

TEST(EstimationFilterExtendedKalman, TheInnovationGateRejectsAnOutlierAndKeepsThePrediction) {
  const double gate = chiSquareQuantile(0.999, 6);
  auto ekf = make(fmt::format("innovation_gate: {}", gate));
  ekf->in.initial_state.set(knownState());
  ASSERT_OK(ekf->process());
  PoseWithCovariance outlier;
  outlier.pose = Transform::identity("servicer", "target", 1'100'000);
  outlier.pose.translation = knownState().pose.translation + Eigen::Vector3d(3.0, 0, 0);
  outlier.pose.rotation = knownState().pose.rotation;
  ekf->in.pose_measurement.set(outlier);
  ASSERT_OK(ekf->process());
  EXPECT_FALSE(*ekf->out.measurement_accepted);
  EXPECT_GT(*ekf->out.innovation_nis, gate);
  EXPECT_EQ(ekf->diagnostics().warning_count, 1u);
  const RigidBodyState s0 = knownState();
  EXPECT_LT(
      (ekf->out.state->pose.translation - (s0.pose.translation + 0.1 * s0.twist.linear)).norm(),
      1e-12);
}

TEST(EstimationFilterExtendedKalman, TheTrackStateFollowsTheFusedMeasurementsAndLossReacquires) {
  const double gate = chiSquareQuantile(0.999, 6);
  auto ekf = make(fmt::format("{{innovation_gate: {}, lost_after: 1.0, reacquire: true}}", gate));
  const RigidBodyState s0 = knownState();  // at 1 s
  ekf->in.initial_state.set(s0);
  ASSERT_OK(ekf->process());
  EXPECT_EQ(*ekf->out.track_state, TrackState::kAcquiring);
  // While acquiring, a measurement far from the initial state re-initialises the pose (no gate)
  // and keeps the twist.
  PoseWithCovariance z;
  z.pose = Transform::identity("servicer", "target", 1'100'000);
  z.pose.translation = s0.pose.translation + Eigen::Vector3d(3.0, 0, 0);
  z.pose.rotation = s0.pose.rotation;
  z.covariance = Matrix6d::Identity() * 1e-4;
  ekf->in.pose_measurement.set(z);
  ASSERT_OK(ekf->process());
  EXPECT_TRUE(*ekf->out.measurement_accepted);
  EXPECT_EQ(*ekf->out.track_state, TrackState::kTracking);
  EXPECT_LT((ekf->out.state->pose.translation - z.pose.translation).norm(), 1e-12);
  EXPECT_EQ(ekf->out.state->twist.linear, s0.twist.linear);
  // Predictions only: TRACKING for 1 s after the last fix, LOST after.
  ekf->in.time.set(Timestamp{2'100'000});
  ASSERT_OK(ekf->process());
  EXPECT_EQ(*ekf->out.track_state, TrackState::kTracking);
  ekf->in.time.set(Timestamp{2'150'000});
  ASSERT_OK(ekf->process());
  EXPECT_EQ(*ekf->out.track_state, TrackState::kLost);
  // Lost: a measurement far from the coasted prediction re-acquires, gate or not.
  z.pose.stamp = 2'200'000;
  z.pose.translation += Eigen::Vector3d(0, 2.0, 0);
  ekf->in.pose_measurement.set(z);
  ASSERT_OK(ekf->process());
  EXPECT_EQ(*ekf->out.track_state, TrackState::kTracking);
  EXPECT_LT((ekf->out.state->pose.translation - z.pose.translation).norm(), 1e-12);
  // Tracking: the same jump is gated out again.
  z.pose.stamp = 2'300'000;
  z.pose.translation += Eigen::Vector3d(0, 2.0, 0);
  ekf->in.pose_measurement.set(z);
  ASSERT_OK(ekf->process());
  EXPECT_FALSE(*ekf->out.measurement_accepted);
  EXPECT_EQ(*ekf->out.track_state, TrackState::kTracking);
  // Without reacquire (the default), a lost filter keeps gating.
  auto plain = make(fmt::format("{{innovation_gate: {}, lost_after: 1.0}}", gate));
  plain->in.initial_state.set(s0);
  ASSERT_OK(plain->process());
  z.pose.stamp = 1'100'000;
  plain->in.pose_measurement.set(z);
  ASSERT_OK(plain->process());
  EXPECT_FALSE(*plain->out.measurement_accepted);
  EXPECT_EQ(*plain->out.track_state, TrackState::kAcquiring);
}

// An initial state that no measurement confirms (a wrong detection: the tracker's registrations
// never pass) becomes LOST after acquisition_timeout, so that the Orchestrator runs the
// detection again; without the timeout it stays ACQUIRING. A new initial state acquires again.
TEST(EstimationFilterExtendedKalman, AnUnconfirmedInitialStateIsLostAfterTheAcquisitionTimeout) {
  const RigidBodyState s0 = knownState();  // at 1 s
  auto timed = make("{acquisition_timeout: 5.0}");
  auto untimed = make("{}");
  for (auto* ekf : {timed.get(), untimed.get()}) {
    ekf->in.initial_state.set(s0);
    ASSERT_OK(ekf->process());
    EXPECT_EQ(*ekf->out.track_state, TrackState::kAcquiring);
    ekf->in.time.set(Timestamp{6'000'000});  // 5 s on: not yet over the timeout
    ASSERT_OK(ekf->process());
    EXPECT_EQ(*ekf->out.track_state, TrackState::kAcquiring);
    ekf->in.time.set(Timestamp{6'100'000});
    ASSERT_OK(ekf->process());
  }
  EXPECT_EQ(*timed->out.track_state, TrackState::kLost);
  EXPECT_EQ(*untimed->out.track_state, TrackState::kAcquiring);
  RigidBodyState again = s0;
  again.pose.stamp = 6'200'000;
  timed->in.initial_state.set(again);
  ASSERT_OK(timed->process());
  EXPECT_EQ(*timed->out.track_state, TrackState::kAcquiring);
}

// A DFPC that checks the tracked pose on a scan (SymmetryCheck) and finds a better one resets the
// filter in the same call as that scan's registration arrives: the registration was made from
// the replaced estimate, and while acquiring it would be taken as the new pose. The reset wins.
TEST(EstimationFilterExtendedKalman, AMeasurementThatComesWithAResetIsNotUsed) {
  auto ekf = make("{reacquire: true}");
  ekf->in.initial_state.set(knownState());  // tracking from here
  ASSERT_OK(ekf->process());
  RigidBodyState reset = knownState();
  reset.pose.stamp = 2'000'000;
  reset.pose.rotation = expSO3(Eigen::Vector3d(0, 0, M_PI / 3)) * reset.pose.rotation;
  PoseWithCovariance old_pose;  // the registration from the replaced estimate
  old_pose.pose = knownState().pose;
  old_pose.pose.stamp = 2'000'000;
  old_pose.covariance = Matrix6d::Identity() * 1e-4;
  ekf->in.initial_state.set(reset);
  ekf->in.pose_measurement.set(old_pose);
  ASSERT_OK(ekf->process());
  EXPECT_LT(angularDistance(ekf->out.state->pose.rotation, reset.pose.rotation), 1e-9);
  EXPECT_FALSE(*ekf->out.measurement_accepted);
  EXPECT_EQ(*ekf->out.track_state, TrackState::kAcquiring);
}

TEST(EstimationFilterExtendedKalman, MeasurementsGatedOutInARowMakeTheTrackLost) {
  // The filter is confident in a state 0.5 m from where every measurement puts the target: one
  // of the two is wrong, and after lost_after_rejections of them in a row the track is LOST so
  // that the DFPC's acquisition decides (with reacquire, its next measurement re-initialises the
  // pose); a fused measurement starts the count again. Without the parameter the filter coasts
  // on until lost_after.
  const double gate = chiSquareQuantile(0.999, 6);
  const RigidBodyState s0 = knownState();  // at 1 s
  PoseWithCovariance fix;
  fix.pose = s0.pose;
  fix.pose.stamp = 1'050'000;
  fix.pose.translation += 0.05 * s0.twist.linear;
  fix.covariance = Matrix6d::Identity() * 1e-4;
  const auto elsewhere = [&](Timestamp stamp) {
    PoseWithCovariance z = fix;
    z.pose.stamp = stamp;
    z.pose.translation = s0.pose.translation + toSeconds(stamp - s0.pose.stamp) * s0.twist.linear +
                         Eigen::Vector3d(0.5, 0, 0);
    return z;
  };
  for (int after : {3, 0}) {
    auto ekf = make(fmt::format(
        "{{innovation_gate: {}, lost_after: 1.0, reacquire: true, lost_after_rejections: {}}}",
        gate, after));
    ekf->in.initial_state.set(s0);
    ASSERT_OK(ekf->process());
    ekf->in.pose_measurement.set(fix);  // acquires: TRACKING
    ASSERT_OK(ekf->process());
    ASSERT_EQ(*ekf->out.track_state, TrackState::kTracking);
    for (int k = 1; k <= 3; ++k) {
      ekf->in.pose_measurement.set(elsewhere(1'050'000 + 100'000 * k));
      ASSERT_OK(ekf->process());
      EXPECT_FALSE(*ekf->out.measurement_accepted) << k;
      EXPECT_EQ(*ekf->out.track_state,
                after > 0 && k == 3 ? TrackState::kLost : TrackState::kTracking)
          << k;
    }
    if (after == 0) continue;
    // LOST: the next measurement re-acquires, and the count starts again.
    const PoseWithCovariance z = elsewhere(1'450'000);
    ekf->in.pose_measurement.set(z);
    ASSERT_OK(ekf->process());
    EXPECT_TRUE(*ekf->out.measurement_accepted);
    EXPECT_EQ(*ekf->out.track_state, TrackState::kTracking);
    EXPECT_LT((ekf->out.state->pose.translation - z.pose.translation).norm(), 1e-12);
  }
  auto node = Registry::instance().create("EstimationFilter", "ExtendedKalman");
  ASSERT_TRUE(node.isOk());
  const Status s = node.value()->configure(YAML::Load("{lost_after_rejections: -1}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("lost_after_rejections"), std::string::npos) << s.message();
}

TEST(EstimationFilterExtendedKalman, BadInputsAreReportedAndLeaveTheFilterUnchanged) {
  auto ekf = make("max_prediction_interval: 5");
  auto reference = make("max_prediction_interval: 5");
  // Predicting before any initialisation, then with nothing fresh.
  ekf->in.time.set(Timestamp{0});
  testing::expectRejected(*ekf, "not initialised");
  testing::expectRejected(*ekf, "no fresh input");

  for (auto* f : {ekf.get(), reference.get()}) {
    f->in.initial_state.set(knownState());
    ASSERT_OK(f->process());
  }
  const auto expect_error = [&](const std::string& fragment) {
    testing::expectRejected(*ekf, fragment);
  };
  PoseWithCovariance nan_pose;
  nan_pose.pose = Transform::identity("servicer", "target", 1'200'000);
  nan_pose.pose.translation.x() = std::nan("");
  ekf->in.pose_measurement.set(nan_pose);
  expect_error("non-finite");

  PoseWithCovariance old = nan_pose;
  old.pose.translation = {0.5, 0.2, 8.0};
  old.pose.stamp = 500'000;
  ekf->in.pose_measurement.set(old);
  expect_error("older than the filter's time");

  PoseWithCovariance wrong_frames = old;
  wrong_frames.pose.stamp = 1'200'000;
  wrong_frames.pose.parent_frame = "camera";
  ekf->in.pose_measurement.set(wrong_frames);
  expect_error("expected servicer_T_target");

  PoseWithCovariance indefinite = old;
  indefinite.pose.stamp = 1'200'000;
  indefinite.covariance(0, 0) = 1.0;  // the rest zero: singular
  ekf->in.pose_measurement.set(indefinite);
  expect_error("not positive definite");

  ekf->in.time.set(Timestamp{20'000'000});
  expect_error("max_prediction_interval");

  // After all these, the filter behaves exactly as one that never saw them.
  PoseWithCovariance good = old;
  good.pose.stamp = 1'200'000;
  for (auto* f : {ekf.get(), reference.get()}) {
    f->in.pose_measurement.set(good);
    ASSERT_OK(f->process());
  }
  EXPECT_EQ(ekf->out.state->pose.translation, reference->out.state->pose.translation);
  EXPECT_EQ(ekf->out.state->covariance, reference->out.state->covariance);
}

// --- AHRS attitude corrections ------------------------------------------------------------

constexpr double kSigmaAhrs = 0.2 * M_PI / 180.0;  // rad, per axis

// A target tumbling at a constant inertial rate, seen from a chaser whose attitude follows
// `chaser(t)`; the AHRS measures inertial_R_servicer.
struct InertialTruth {
  Eigen::Quaterniond target0 = expSO3(Eigen::Vector3d(-0.4, 0.3, 0.8));
  Eigen::Vector3d target_rate = Eigen::Vector3d(0.3, -1, 0.6).normalized() * (3.0 * M_PI / 180.0);
  Eigen::Vector3d p0{1.0, -0.5, 10.0};
  Eigen::Vector3d v{0.05, -0.02, 0.01};

  Eigen::Quaterniond target(double t) const { return expSO3(target_rate * t) * target0; }
};

PoseWithCovariance ahrsSample(const Eigen::Quaterniond& chaser, double t, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  PoseWithCovariance z;
  z.pose = Transform::identity("inertial", "servicer", fromSeconds(t));
  z.pose.rotation = expSO3(kSigmaAhrs * Eigen::Vector3d(n(rng), n(rng), n(rng))) * chaser;
  z.covariance.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * kSigmaAhrs * kSigmaAhrs;
  return z;
}

PoseWithCovariance poseSample(const Eigen::Vector3d& position, const Eigen::Quaterniond& attitude,
                              double t, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  PoseWithCovariance z;
  z.pose = Transform::identity("servicer", "target", fromSeconds(t));
  z.pose.translation = position + kSigmaP * Eigen::Vector3d(n(rng), n(rng), n(rng));
  z.pose.rotation = expSO3(kSigmaR * Eigen::Vector3d(n(rng), n(rng), n(rng))) * attitude;
  z.covariance.diagonal() << Eigen::Vector3d::Constant(kSigmaP * kSigmaP),
      Eigen::Vector3d::Constant(kSigmaR * kSigmaR);
  return z;
}

TEST(EstimationFilterExtendedKalman, AhrsCorrectionsKeepTheFilterConsistentAndImproveAttitude) {
  // The relative twist is constant (so the model is exact) and so is the target's inertial
  // rate; the chaser then turns as the two imply. Pose measurements at 1 Hz, AHRS samples at
  // 10 Hz. The filter's NEES must stay within the 95 % chi-square bounds and the attitude must
  // be better than without the AHRS.
  constexpr int kRuns = 30;
  const InertialTruth truth;
  const Eigen::Quaterniond relative0 = expSO3(Eigen::Vector3d(0.3, -0.2, 0.1));
  const Eigen::Vector3d relative_rate =
      Eigen::Vector3d(1, 2, 0.5).normalized() * (2.0 * M_PI / 180.0);
  auto relative = [&](double t) { return expSO3(relative_rate * t) * relative0; };
  auto chaser = [&](double t) { return truth.target(t) * relative(t).conjugate(); };

  const std::string quiet =
      "{linear_acceleration_psd: 1.0e-12, angular_acceleration_psd: 1.0e-12, "
      "target_angular_acceleration_psd: 1.0e-12, initial_chaser_angular_velocity_sigma: "
      "5.729577951308232}";
  double sum_nees = 0, sum_r2_ahrs = 0, sum_r2_plain = 0;
  long samples = 0;
  for (int run = 0; run < kRuns; ++run) {
    auto with_ahrs = make(quiet), plain = make(quiet);
    std::mt19937 rng(500 + run);
    double run_nees = 0;
    int run_samples = 0;
    for (int k = 0; k <= 600; ++k) {
      const double t = k / 10.0;
      const Eigen::Vector3d position = truth.p0 + truth.v * t;
      if (k % 10 == 0) {
        const PoseWithCovariance z = poseSample(position, relative(t), t, rng);
        for (auto* f : {with_ahrs.get(), plain.get()}) {
          f->in.pose_measurement.set(z);
          ASSERT_OK(f->process());
        }
      } else {
        plain->in.time.set(fromSeconds(t));
        ASSERT_OK(plain->process());
      }
      with_ahrs->in.attitude_measurement.set(ahrsSample(chaser(t), t, rng));
      ASSERT_OK(with_ahrs->process());
      if (t < kSettle) continue;
      const RigidBodyState& s = *with_ahrs->out.state;
      Eigen::Matrix<double, 12, 1> e;
      e.segment<3>(0) = s.pose.translation - position;
      e.segment<3>(3) = logSO3(s.pose.rotation * relative(t).conjugate());
      e.segment<3>(6) = s.twist.linear - truth.v;
      e.segment<3>(9) = s.twist.angular - relative_rate;
      run_nees += e.dot(s.covariance.ldlt().solve(e));
      ++run_samples;
      sum_r2_ahrs += e.segment<3>(3).squaredNorm();
      sum_r2_plain +=
          logSO3(plain->out.state->pose.rotation * relative(t).conjugate()).squaredNorm();
      ++samples;
    }
    sum_nees += run_nees / run_samples;
  }
  const double anees = sum_nees / kRuns;
  const double low = chiSquareQuantile(0.025, kRuns * 12) / kRuns;
  const double high = chiSquareQuantile(0.975, kRuns * 12) / kRuns;
  const double rmse_ahrs = std::sqrt(sum_r2_ahrs / samples);
  const double rmse_plain = std::sqrt(sum_r2_plain / samples);
  RecordProperty("anees_12dof_with_ahrs",
                 fmt::format("{:.3f} in [{:.3f}, {:.3f}]", anees, low, high));
  RecordProperty("attitude_rmse_deg", fmt::format("{:.3f} with AHRS, {:.3f} without",
                                                  rmse_ahrs * 180 / M_PI, rmse_plain * 180 / M_PI));
  EXPECT_GT(anees, low) << "ANEES " << anees << ": pessimistic";
  EXPECT_LT(anees, high) << "ANEES " << anees << ": overconfident";
  EXPECT_LT(rmse_ahrs, rmse_plain);
}

TEST(EstimationFilterExtendedKalman, AhrsAloneKeepsTheRelativeAttitudeWhileTheChaserSlews) {
  // 20 s of pose measurements with the chaser at rest, then 10 s without any (dropped scans)
  // while the chaser slews with 0.5 deg/s^2: the relative twist changes, which the constant
  // twist model cannot predict; the AHRS, through the target's inertial attitude, can. The
  // relative angular acceleration noise must allow such a change (psd ~ a^2 T), so that the
  // AHRS innovations correct the relative attitude rather than the target's inertial one.
  const InertialTruth truth;
  const Eigen::Quaterniond chaser0 = expSO3(Eigen::Vector3d(0.2, 0.1, -0.3));
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 1, 0.1).normalized();
  const double alpha = 0.5 * M_PI / 180.0;
  auto chaser = [&](double t) {
    const double s = std::max(0.0, t - 20.0);
    return expSO3(axis * 0.5 * alpha * s * s) * chaser0;
  };
  auto relative = [&](double t) { return chaser(t).conjugate() * truth.target(t); };
  const std::string yaml = "{angular_acceleration_psd: 1.0e-3}";
  auto with_ahrs = make(yaml), plain = make(yaml);
  std::mt19937 rng(77);
  double worst_ahrs = 0, worst_nees = 0, end_plain = 0;
  for (int k = 0; k <= 300; ++k) {
    const double t = k / 10.0;
    if (t < 20.0) {
      const PoseWithCovariance z = poseSample(truth.p0 + truth.v * t, relative(t), t, rng);
      for (auto* f : {with_ahrs.get(), plain.get()}) {
        f->in.pose_measurement.set(z);
        ASSERT_OK(f->process());
      }
    } else {
      plain->in.time.set(fromSeconds(t));
      ASSERT_OK(plain->process());
    }
    with_ahrs->in.attitude_measurement.set(ahrsSample(chaser(t), t, rng));
    ASSERT_OK(with_ahrs->process());
    if (t >= 20.0) {
      const RigidBodyState& s = *with_ahrs->out.state;
      const Eigen::Vector3d e = logSO3(s.pose.rotation * relative(t).conjugate());
      worst_ahrs = std::max(worst_ahrs, e.norm());
      worst_nees = std::max(worst_nees, e.dot(s.covariance.block<3, 3>(3, 3).ldlt().solve(e)));
      end_plain = angularDistance(plain->out.state->pose.rotation, relative(t));
    }
  }
  RecordProperty("gap_attitude_error_deg",
                 fmt::format("{:.3f} with AHRS (worst), {:.2f} without (end)",
                             worst_ahrs * 180 / M_PI, end_plain * 180 / M_PI));
  // The slew turns the chaser by 25 deg. With the AHRS the error stays at what the filter knows
  // of the target's inertial attitude from 20 s of 1 deg pose fixes, and within what its
  // covariance says (the 3-dof chi-square 0.9999 quantile at every step of the gap).
  EXPECT_GT(end_plain, 15.0 * M_PI / 180.0);
  EXPECT_LT(worst_ahrs, 1.5 * M_PI / 180.0);
  EXPECT_LT(worst_nees, chiSquareQuantile(0.9999, 3));
  EXPECT_EQ(with_ahrs->out.pose->rotation.coeffs(), with_ahrs->out.state->pose.rotation.coeffs());
}

TEST(EstimationFilterExtendedKalman, BadAttitudeMeasurementsAreReported) {
  auto ekf = make();
  std::mt19937 rng(1);
  // Before initialisation: ignored with a warning.
  ekf->in.attitude_measurement.set(ahrsSample(Eigen::Quaterniond::Identity(), 0.5, rng));
  ASSERT_OK(ekf->process());
  EXPECT_EQ(ekf->diagnostics().warning_count, 1u);
  EXPECT_FALSE(ekf->out.state.hasValue());

  ekf->in.initial_state.set(knownState());
  ASSERT_OK(ekf->process());
  PoseWithCovariance z = ahrsSample(Eigen::Quaterniond::Identity(), 1.1, rng);
  z.pose.child_frame = "camera";
  ekf->in.attitude_measurement.set(z);
  testing::expectRejected(*ekf, "expected the chaser's attitude <inertial>_T_servicer");

  z = ahrsSample(Eigen::Quaterniond::Identity(), 1.1, rng);
  z.covariance.block<3, 3>(3, 3) = Eigen::Vector3d(1e-4, 0, 0).asDiagonal();  // singular
  ekf->in.attitude_measurement.set(z);
  testing::expectRejected(*ekf, "not positive definite");

  z = ahrsSample(Eigen::Quaterniond::Identity(), 1.1, rng);
  z.pose.rotation.coeffs() *= 2.0;
  ekf->in.attitude_measurement.set(z);
  testing::expectRejected(*ekf, "attitude_measurement");

  ekf->in.attitude_measurement.set(ahrsSample(Eigen::Quaterniond::Identity(), 1.1, rng));
  ASSERT_OK(ekf->process());  // adds the inertial part
  EXPECT_FALSE(*ekf->out.measurement_accepted);
  z = ahrsSample(Eigen::Quaterniond::Identity(), 1.2, rng);
  z.pose.parent_frame = "earth";
  ekf->in.attitude_measurement.set(z);
  testing::expectRejected(*ekf, "the inertial frame of the earlier AHRS samples");
  ekf->in.attitude_measurement.set(ahrsSample(Eigen::Quaterniond::Identity(), 1.0, rng));
  testing::expectRejected(*ekf, "older than the filter's time");
  ekf->in.attitude_measurement.set(ahrsSample(Eigen::Quaterniond::Identity(), 1.2, rng));
  ASSERT_OK(ekf->process());
  EXPECT_TRUE(*ekf->out.measurement_accepted);
  EXPECT_GT(*ekf->out.innovation_nis, 0.0);
}

TEST(EstimationFilterExtendedKalman, BadParametersAreRejected) {
  auto node = Registry::instance().create("EstimationFilter", "ExtendedKalman");
  ASSERT_TRUE(node.isOk());
  Status s = node.value()->configure(YAML::Load("{position_sigma: -1}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("position_sigma"), std::string::npos) << s.message();
  s = node.value()->configure(YAML::Load("{process_noise: 1}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("process_noise"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace cdff::dfn
