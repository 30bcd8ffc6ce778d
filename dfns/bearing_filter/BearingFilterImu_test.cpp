// BearingFilter with the servicer's IMU: a servicer 1.5 km from the target manoeuvring (thrust of
// up to 0.07 m/s^2, as the rendezvous's time-compressed far leg) with an accelerometer biased by
// (0.02, -0.015, 0.01) m/s^2 (the seed's MTi: 0.02 m/s^2 turn-on, 1 sigma), its noise density
// 0.002 m/s^2/sqrt(Hz), mounted turned on the servicer; images at 1 Hz with 0.1 px of noise,
// AHRS samples at 10 Hz, the radar at 1 Hz. The truth is the controlled Clohessy-Wiltshire
// equations integrated by RK4, independently of the filter's closed form. With the IMU the
// filter's coasting prediction must follow the manoeuvre (a 20 s gap during a burn: a few pixels
// where the 6-state filter is tens off), its bias estimate converge to the truth within its own
// 3 sigma and well below the turn-on bias, and its bearing stay honest. Bad input: a NaN sample,
// a sample before the IMU's mounting, samples out of order, samples without an attitude.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include <nlohmann/json.hpp>

#include "BearingFilter.gen.hpp"
#include "cdff/tracking/imu_thrust.hpp"
#include "support/dfn_testing.hpp"
#include "support/far_target.hpp"

namespace cdff::dfn {
namespace {

using testing::farCamera;
using tracking::Vector6d;

constexpr double kAltitude = 500e3;
constexpr double kImuRate = 120.0;

/// The servicer's thrust in LVLH (m/s^2): a lateral weave and along-track burns.
Eigen::Vector3d thrustAt(double t) {
  const double burn = (t > 100 && t < 160) ? 0.06 : (t > 200 && t < 240 ? -0.04 : 0.0);
  return {0.03 * std::sin(2 * M_PI * t / 50), burn, 0.02 * std::cos(2 * M_PI * t / 70)};
}

/// p = target - servicer: p'' = CW(p) - thrust.
Vector6d derivative(const Vector6d& x, double t) {
  const double n = tracking::meanMotion(kAltitude);
  Vector6d d;
  d.head<3>() = x.tail<3>();
  d[3] = 3 * n * n * x[0] + 2 * n * x[4];
  d[4] = -2 * n * x[3];
  d[5] = -n * n * x[2];
  d.tail<3>() -= thrustAt(t);
  return d;
}

Vector6d rk4(const Vector6d& x, double t, double h) {
  const Vector6d k1 = derivative(x, t), k2 = derivative(x + h / 2 * k1, t + h / 2),
                 k3 = derivative(x + h / 2 * k2, t + h / 2), k4 = derivative(x + h * k3, t + h);
  return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
}

Transform imuMount() {
  Transform m = Transform::identity("servicer", "imu", 0);
  m.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  m.translation = {0.2, 0.1, 0};
  return m;
}

const Eigen::Vector3d kBias(0.02, -0.015, 0.01);  // servicer axes, m/s^2

struct Flight {
  double coast_error_px = 0;  // the bearing after the 20 s gap
  double bearing_rms_px = 0, nees = 0;
  int bearings = 0;
  Eigen::Vector3d bias = Eigen::Vector3d::Zero(), bias_sigma = Eigen::Vector3d::Zero();
};

class BearingFilterWithImu : public ::testing::Test {
 protected:
  std::mt19937 rng_{5};
  std::normal_distribution<double> unit_{0.0, 1.0};

  std::unique_ptr<BearingFilter> makeFilter() {
    auto f = testing::makeDfn<BearingFilter>(
        "BearingFilter", "ExtendedKalman",
        "{initial_range: 1500, initial_range_sigma: 1000, acceleration_psd: 1.0e-4, "
        "centre_offset_sigma: 0, min_measurement_sigma: 0}");
    f->in.calibration.set(farCamera());
    f->in.camera_mount.set(testing::farCameraMount());
    return f;
  }

  ImuSample imuSample(const Eigen::Matrix3d& lvlh_R_servicer, double t) {
    ImuSample s;
    s.stamp = static_cast<Timestamp>(std::llround(t * 1e6));
    s.frame_id = "imu";
    const double sigma = 0.002 * std::sqrt(kImuRate);
    const Eigen::Vector3d noise(unit_(rng_), unit_(rng_), unit_(rng_));
    const Eigen::Vector3d f_servicer = lvlh_R_servicer.transpose() * thrustAt(t) + kBias;
    s.linear_acceleration = imuMount().rotation.inverse() * f_servicer + sigma * noise;
    return s;
  }

  /// `seconds` of flight; images missing in (gap_from, gap_to]; with or without the IMU.
  Flight fly(BearingFilter& f, bool imu, int seconds, int gap_from = -1, int gap_to = -1) {
    Vector6d x;
    x << 15, 1500, -10, 0.0, -2.0, 0.0;
    Flight run;
    if (imu) f.in.imu_mount.set(imuMount());
    const int per_second = static_cast<int>(kImuRate);
    for (int k = 0; k <= seconds * per_second; ++k) {
      const double t = k / kImuRate;
      const Timestamp stamp = static_cast<Timestamp>(std::llround(t * 1e6));
      const Eigen::Matrix3d r = testing::servicerPointingAt(x.head<3>());
      if (k % 12 == 0) {
        PoseWithCovariance a;
        a.pose = Transform::identity("lvlh", "servicer", stamp);
        a.pose.rotation = Eigen::Quaterniond(r);
        a.covariance.block<3, 3>(3, 3) = 1e-12 * Eigen::Matrix3d::Identity();
        f.in.attitude.set(a);
        EXPECT_TRUE(f.process().isOk());
      }
      if (imu) {
        f.in.imu.set(imuSample(r, t));
        const Status s = f.process();
        EXPECT_TRUE(s.isOk()) << s.toString();
      }
      if (k % per_second == 0) image(f, k / per_second, x, r, stamp, gap_from, gap_to, run);
      x = rk4(x, t, 1 / kImuRate);
    }
    run.bearing_rms_px = std::sqrt(run.bearing_rms_px / std::max(1, run.bearings));
    run.nees /= std::max(1, run.bearings);
    const RigidBodyState& s = *f.out.point_state;
    run.bias = s.twist.angular;
    run.bias_sigma = s.covariance.block<3, 3>(9, 9).diagonal().cwiseSqrt();
    return run;
  }

  void image(BearingFilter& f, int second, const Vector6d& x, const Eigen::Matrix3d& r,
             Timestamp stamp, int gap_from, int gap_to, Flight& run) {
    const tracking::BearingGeometry g{farCamera(),
                                      testing::farCameraMount().rotation.toRotationMatrix(), r,
                                      testing::farCameraMount().translation};
    const Eigen::Vector3d p = x.head<3>();
    nlohmann::json radar = {
        {"valid", true},
        {"range", p.norm() + 0.05 * unit_(rng_)},
        {"range_rate", p.normalized().dot(x.tail<3>()) + 0.005 * unit_(rng_)},
        {"range_sigma", 0.05},
        {"range_rate_sigma", 0.005},
        {"timestamp", {{"sec", stamp / 1'000'000}, {"nsec", stamp % 1'000'000 * 1000}}}};
    const bool gap = second > gap_from && second <= gap_to;
    if (!gap) f.in.radar.set(radar);
    ImageRegion region = ImageRegion::box(0, 0, 1, 1);
    region.homography.topRightCorner<2, 1>() =
        *g.pixelOf(p) + 0.1 * Eigen::Vector2d(unit_(rng_), unit_(rng_));
    region.stamp = stamp;
    region.frame_id = "camera_far_optical";
    region.covariance = 0.01 * Eigen::Matrix2d::Identity();
    region.source = second == 0 ? "user" : (gap ? "prediction" : "match");
    if (gap)
      f.in.prediction.set(region);
    else
      f.in.measurement.set(region);
    const Status s = f.process();
    EXPECT_TRUE(s.isOk()) << s.toString();
    const Bearing& b = *f.out.bearing;
    const Eigen::Vector3d e = b.direction - r.transpose() * p.normalized();
    if (second == gap_to) run.coast_error_px = e.norm() * farCamera().fx;
    if (second < 60 || gap) return;
    run.bearing_rms_px += e.squaredNorm() * farCamera().fx * farCamera().fx;
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(b.covariance, Eigen::ComputeFullU);
    const Eigen::Matrix<double, 3, 2> u = svd.matrixU().leftCols<2>();
    const Eigen::Vector2d e2 = u.transpose() * e;
    run.nees += e2.dot((u.transpose() * b.covariance * u).inverse() * e2);
    ++run.bearings;
  }
};

TEST_F(BearingFilterWithImu, ThePredictionFollowsTheManoeuvreAndTheBiasConverges) {
  auto with = makeFilter(), without = makeFilter();
  const Flight imu = fly(*with, true, 250, 120, 140);  // the gap in the middle of a burn
  rng_.seed(5);
  const Flight none = fly(*without, false, 250, 120, 140);
  // 20 s of 0.06 m/s^2 unmeasured is 12 m at 1.5 km, tens of pixels; measured, with the bias
  // known to a millimetre per second squared, a few pixels at most.
  std::printf(
      "with the IMU: %.2f px after the 20 s gap (without: %.2f px), bearing %.3f px RMS (without: "
      "%.3f), NEES %.2f, bias error %.4f m/s^2 (sigma %.4f %.4f %.4f)\n",
      imu.coast_error_px, none.coast_error_px, imu.bearing_rms_px, none.bearing_rms_px, imu.nees,
      (imu.bias - kBias).norm(), imu.bias_sigma[0], imu.bias_sigma[1], imu.bias_sigma[2]);
  EXPECT_GT(none.coast_error_px, 10.0);
  EXPECT_LT(imu.coast_error_px, 3.0);
  EXPECT_LT(imu.coast_error_px, 0.2 * none.coast_error_px);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(std::abs(imu.bias[i] - kBias[i]), 3 * imu.bias_sigma[i] + 1e-4) << i;
    EXPECT_LT(imu.bias_sigma[i], 0.2 * 0.02) << i;  // from the turn-on's 0.02
  }
  EXPECT_LT((imu.bias - kBias).norm(), 0.2 * kBias.norm());
  EXPECT_LT(imu.bearing_rms_px, none.bearing_rms_px + 0.05);
  EXPECT_LT(imu.bearing_rms_px, 0.3);
  EXPECT_GT(imu.nees, 0.5);  // honest: 2 (2 dof)
  EXPECT_LT(imu.nees, 4.0);
  EXPECT_EQ(*with->out.track_state, TrackState::kTracking);
  // The state for users carries no bias; the 6-state filter's point state none.
  EXPECT_TRUE(with->out.state->twist.angular.isZero());
  EXPECT_TRUE(without->out.point_state->twist.angular.isZero());
  EXPECT_TRUE((without->out.point_state->covariance.block<3, 3>(9, 9).isZero()));
}

TEST(RelativeMotionWithThrust, MatchesTheIntegratedControlledEquations) {
  // A constant attitude turned 0.5 rad, 0.05 m/s^2 measured along its x, a known bias.
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d bias(0.01, 0.0, -0.005), thrust_servicer(0.05, 0, 0.02);
  tracking::MeasuredThrust thrust;
  thrust.model = {0.002, 0.02, 1e-4};
  for (int k = 0; k < 1200; ++k)  // 10 s at 120 Hz
    thrust.spans.push_back(
        {k * 1'000'000 / 120, (k + 1) * 1'000'000 / 120, thrust_servicer + bias, r});
  tracking::RelativeState s;
  s.x << 10, 1000, -5, 0.1, -1.0, 0.05, bias;
  s.covariance.diagonal().setConstant(1e-6);
  ASSERT_TRUE(tracking::propagate(s, 10'000'000, tracking::meanMotion(kAltitude), 0, thrust));
  // The truth: RK4 with the thrust in LVLH, fine steps.
  const double n = tracking::meanMotion(kAltitude);
  Vector6d x = (Vector6d() << 10, 1000, -5, 0.1, -1.0, 0.05).finished();
  auto d = [&](const Vector6d& y) {
    Vector6d dy;
    dy.head<3>() = y.tail<3>();
    dy.tail<3>() << 3 * n * n * y[0] + 2 * n * y[4], -2 * n * y[3], -n * n * y[2];
    dy.tail<3>() -= r * thrust_servicer;
    return dy;
  };
  for (int i = 0; i < 1000; ++i) {
    const double h = 0.01;
    const Vector6d k1 = d(x), k2 = d(x + h / 2 * k1), k3 = d(x + h / 2 * k2), k4 = d(x + h * k3);
    x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  EXPECT_LT((s.x.head<3>() - x.head<3>()).norm(), 1e-6);
  EXPECT_LT((s.x.segment<3>(3) - x.tail<3>()).norm(), 1e-7);
  // The bias's uncertainty moves the position by r T^2/2 per unit, and its random walk by
  // r k^2 T^3/6 (the CW coupling over 10 s is 1 %).
  const Eigen::Matrix3d pb = s.covariance.block<3, 3>(0, 6);
  EXPECT_TRUE(pb.isApprox((1e-6 * 50.0 + 1e-8 * 1000 / 6) * r, 2e-2)) << pb;
}

class BearingFilterImuBadInput : public BearingFilterWithImu {};

TEST_F(BearingFilterImuBadInput, ANanSampleASampleBeforeTheMountAndSamplesOutOfOrder) {
  auto f = makeFilter();
  ImuSample s = imuSample(Eigen::Matrix3d::Identity(), 1.0);
  f->in.imu.set(s);
  testing::expectRejected(*f, "input 'imu' at t = 1000000 us came before 'imu_mount'");
  f->in.imu_mount.set(imuMount());
  s.linear_acceleration.y() = std::numeric_limits<double>::quiet_NaN();
  f->in.imu.set(s);
  testing::expectRejected(*f, "input 'imu' at t = 1000000 us");
  s = imuSample(Eigen::Matrix3d::Identity(), 1.0);
  f->in.imu.set(s);
  ASSERT_TRUE(f->process().isOk());
  f->in.imu.set(imuSample(Eigen::Matrix3d::Identity(), 0.5));
  testing::expectRejected(*f, "expected samples in time order");
  Transform other = imuMount();
  other.child_frame = "gyro";
  f->in.imu_mount.set(other);
  f->in.imu.set(imuSample(Eigen::Matrix3d::Identity(), 2.0));
  testing::expectRejected(*f, "expected the mounting of the IMU 'imu'");
}

TEST_F(BearingFilterImuBadInput, SamplesWithoutAnAttitudeAreLeftOutWithAWarning) {
  auto f = makeFilter();
  f->in.imu_mount.set(imuMount());
  PoseWithCovariance a;
  a.pose = Transform::identity("lvlh", "servicer", 0);
  a.pose.rotation = Eigen::Quaterniond(testing::servicerPointingAt({15, 1500, -10}));
  f->in.attitude.set(a);
  ASSERT_TRUE(f->process().isOk());
  ImageRegion m = ImageRegion::box(500, 500, 1, 1);
  m.frame_id = "camera_far_optical";
  m.source = "user";
  f->in.measurement.set(m);
  ASSERT_TRUE(f->process().isOk());
  // IMU samples 1-2 s later, the attitudes at 0 and 3 s (beyond attitude_tolerance, 0.5 s).
  for (int k = 120; k <= 240; ++k) {
    f->in.imu.set(imuSample(Eigen::Matrix3d::Identity(), k / kImuRate));
    ASSERT_TRUE(f->process().isOk());
  }
  a.pose.stamp = 3'000'000;  // 1 s after the last sample: no attitude for them still
  f->in.attitude.set(a);
  m.stamp = 3'000'000;
  m.source = "match";
  f->in.measurement.set(m);
  ASSERT_TRUE(f->process().isOk()) << f->diagnostics().last_error;
  ASSERT_FALSE(f->diagnostics().warnings.empty());
  EXPECT_NE(f->diagnostics().warnings.front().find("IMU samples between"), std::string::npos)
      << f->diagnostics().warnings.front();
  // Nothing measured: no bias states started.
  EXPECT_TRUE((f->out.point_state->covariance.block<3, 3>(9, 9).isZero()));
}

}  // namespace
}  // namespace cdff::dfn
