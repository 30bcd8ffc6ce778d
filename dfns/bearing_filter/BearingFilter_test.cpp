// BearingFilter and the relative motion it shares with BearingPrediction: a target drifting on
// the Clohessy-Wiltshire equations (integrated here by Runge-Kutta, independently of the closed
// form) seen from 2 km by a 35 mm, 1024 x 1024 camera on a servicer that points at it with a
// jittering attitude; image positions with 0.1 px of noise, AHRS samples with 5 arcsec, radar
// ranges with 5 cm. The filter's bearing must be as good as the pixels it fuses and its
// covariance honest (NEES of the 2-dof direction error within a factor 2 of 2), its range within
// 1 % with the radar (the goal), and it must coast and report LOST without images.
// Bad input: a negative or NaN radar range, images out of time order, an attitude in another
// frame or too far from an image's time.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <nlohmann/json.hpp>

#include "BearingFilter.gen.hpp"
#include "cdff/tracking/relative_motion.hpp"
#include "support/dfn_testing.hpp"
#include "support/far_target.hpp"

namespace cdff::dfn {
namespace {

using tracking::Vector6d;

constexpr double kAltitude = 500e3;

using testing::farCamera;

Transform cameraMount() {
  return testing::farCameraMount();
}

/// The CW equations integrated by RK4 (steps of 0.1 s): the truth the closed form must match.
Vector6d integrate(const Vector6d& x0, double seconds) {
  const double n = tracking::meanMotion(kAltitude);
  auto f = [n](const Vector6d& x) {
    Vector6d d;
    d.head<3>() = x.tail<3>();
    d[3] = 3 * n * n * x[0] + 2 * n * x[4];
    d[4] = -2 * n * x[3];
    d[5] = -n * n * x[2];
    return d;
  };
  Vector6d x = x0;
  const int steps = static_cast<int>(std::lround(seconds / 0.1));
  const double h = seconds / std::max(1, steps);
  for (int i = 0; i < steps; ++i) {
    const Vector6d k1 = f(x), k2 = f(x + h / 2 * k1), k3 = f(x + h / 2 * k2), k4 = f(x + h * k3);
    x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return x;
}

TEST(RelativeMotion, TheClosedFormMatchesTheIntegratedEquations) {
  Vector6d x0;
  x0 << 30, 2000, -15, 0.02, -0.5, 0.01;
  for (double t : {1.0, 60.0, 900.0}) {
    const Vector6d closed = tracking::cwTransition(tracking::meanMotion(kAltitude), t) * x0;
    EXPECT_LT((closed - integrate(x0, t)).head<3>().norm(), 1e-6 * (1 + t)) << t;
  }
  EXPECT_TRUE(tracking::cwTransition(0.0, 2.0).isApprox(
      (Eigen::Matrix<double, 6, 6>() << Eigen::Matrix3d::Identity(),
       2 * Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Identity())
          .finished()));
}

struct Flight {
  double bearing_rms_px = 0, nees = 0, worst_range_pct = 0;
  int bearings = 0;
  bool range_reported = false;
};

class BearingFilterOnADrift : public ::testing::Test {
 protected:
  std::unique_ptr<BearingFilter> filter_ = testing::makeDfn<BearingFilter>(
      "BearingFilter", "ExtendedKalman",
      "{initial_range: 1500, initial_range_sigma: 1000, acceleration_psd: 1.0e-6, "
      "centre_offset_sigma: 0, min_measurement_sigma: 0}");  // the measurements: the centre
  std::mt19937 rng_{11};
  std::normal_distribution<double> unit_{0.0, 1.0};
  const double pixel_sigma_ = 0.1, attitude_sigma_ = 5.0 / 3600 * M_PI / 180;

  void SetUp() override {
    filter_->in.calibration.set(farCamera());
    filter_->in.camera_mount.set(cameraMount());
  }

  PoseWithCovariance attitudeSample(const Eigen::Matrix3d& truth, Timestamp stamp) {
    PoseWithCovariance a;
    a.pose = Transform::identity("lvlh", "servicer", stamp);
    const Eigen::Vector3d e(unit_(rng_), unit_(rng_), unit_(rng_));
    a.pose.rotation = Eigen::Quaterniond(truth * expSO3(attitude_sigma_ * e).toRotationMatrix());
    a.covariance.block<3, 3>(3, 3) =
        attitude_sigma_ * attitude_sigma_ * Eigen::Matrix3d::Identity();
    return a;
  }

  nlohmann::json radarAt(const Vector6d& x, Timestamp stamp) {
    const Eigen::Vector3d p = x.head<3>();
    return {{"valid", true},
            {"range", p.norm() + 0.05 * unit_(rng_)},
            {"range_rate", p.normalized().dot(x.tail<3>()) + 0.005 * unit_(rng_)},
            {"range_sigma", 0.05},
            {"range_rate_sigma", 0.005},
            {"timestamp", {{"sec", stamp / 1'000'000}, {"nsec", stamp % 1'000'000 * 1000}}}};
  }

  /// Images at 1 Hz for `seconds`, the first a designation; `missing` images are not matched.
  Flight fly(bool radar, int seconds, int missing_from = -1, int missing_to = -1) {
    Vector6d x;
    x << 20, 2000, -10, 0.01, -1.5, 0.005;  // closing at 1.5 m/s along V-bar
    Flight run;
    const tracking::BearingGeometry truth_geometry{
        farCamera(), cameraMount().rotation.toRotationMatrix(), Eigen::Matrix3d::Identity(),
        cameraMount().translation};
    for (int k = 0; k <= seconds; ++k) {
      const Timestamp stamp = static_cast<Timestamp>(k) * 1'000'000;
      const Vector6d xk = integrate(x, k);
      const Eigen::Vector3d jitter =
          2e-4 * Eigen::Vector3d(std::sin(0.3 * k), std::cos(0.21 * k), std::sin(0.17 * k + 1));
      tracking::BearingGeometry g = truth_geometry;
      g.lvlh_R_servicer = testing::servicerPointingAt(xk.head<3>(), jitter);
      filter_->in.attitude.set(attitudeSample(g.lvlh_R_servicer, stamp));
      if (radar) filter_->in.radar.set(radarAt(xk, stamp));
      const bool matched = k < missing_from || k > missing_to;
      ImageRegion region = ImageRegion::box(0, 0, 1, 1);
      const Eigen::Vector2d pixel =
          *g.pixelOf(xk.head<3>()) + pixel_sigma_ * Eigen::Vector2d(unit_(rng_), unit_(rng_));
      region.homography.topRightCorner<2, 1>() = pixel;
      region.stamp = stamp;
      region.frame_id = "camera_far_optical";
      region.covariance = pixel_sigma_ * pixel_sigma_ * Eigen::Matrix2d::Identity();
      region.source = k == 0 ? "user" : "match";
      if (matched)
        filter_->in.measurement.set(region);
      else {
        region.source = "prediction";
        filter_->in.prediction.set(region);
      }
      const Status s = filter_->process();
      EXPECT_TRUE(s.isOk()) << s.toString();
      if (k < 60 || !matched) continue;  // converged after a minute
      const Bearing& b = *filter_->out.bearing;
      const Eigen::Vector3d truth = g.lvlh_R_servicer.transpose() * xk.head<3>().normalized();
      const Eigen::Vector3d e = b.direction - truth;
      run.bearing_rms_px += e.squaredNorm() * farCamera().fx * farCamera().fx;
      Eigen::JacobiSVD<Eigen::Matrix3d> svd(b.covariance, Eigen::ComputeFullU);
      const Eigen::Matrix<double, 3, 2> u = svd.matrixU().leftCols<2>();
      const Eigen::Vector2d e2 = u.transpose() * e;
      run.nees += e2.dot((u.transpose() * b.covariance * u).inverse() * e2);
      run.range_reported = !std::isnan(b.range);
      if (run.range_reported)
        run.worst_range_pct =
            std::max(run.worst_range_pct,
                     100 * std::abs(b.range - xk.head<3>().norm()) / xk.head<3>().norm());
      ++run.bearings;
    }
    run.bearing_rms_px = std::sqrt(run.bearing_rms_px / run.bearings);
    run.nees /= run.bearings;
    return run;
  }
};

TEST_F(BearingFilterOnADrift, WithRadarTheBearingIsAsGoodAsItsPixelsAndTheRangeWithinOnePercent) {
  const Flight run = fly(true, 300);
  // Each image gives 0.1 px per axis, each attitude sample 5 arcsec (0.15 px): one image through
  // one attitude sample is 0.26 px off (RMS of the angle); the filter does better.
  EXPECT_LT(run.bearing_rms_px, 0.25);
  EXPECT_GT(run.nees, 1.0);
  EXPECT_LT(run.nees, 4.0);
  EXPECT_TRUE(run.range_reported);
  EXPECT_LT(run.worst_range_pct, 1.0);
  EXPECT_EQ(*filter_->out.track_state, TrackState::kTracking);
  EXPECT_EQ(filter_->out.bearing->designation, "user");
}

TEST_F(BearingFilterOnADrift, WithoutRadarItTracksTheBearingAndReportsNoRange) {
  const Flight run = fly(false, 200);
  EXPECT_LT(run.bearing_rms_px, 0.25);
  EXPECT_GT(run.nees, 1.0);
  EXPECT_LT(run.nees, 4.0);
  EXPECT_FALSE(run.range_reported);
}

TEST_F(BearingFilterOnADrift, CoastsWithoutImagesAndIsLostAfterLostAfter) {
  fly(true, 100, 90, 100);
  EXPECT_EQ(*filter_->out.track_state, TrackState::kLost);  // 11 s without an image
  const Bearing& b = *filter_->out.bearing;
  EXPECT_GT(std::sqrt(b.covariance.trace()) * farCamera().fx, 0.2);  // grown while coasting
}

class BearingFilterBadInput : public BearingFilterOnADrift {};

TEST_F(BearingFilterBadInput, ANegativeOrNanRadarRange) {
  fly(true, 3);
  nlohmann::json radar = radarAt(Vector6d::Constant(1.0), 4'000'000);
  radar["range"] = -3.0;
  filter_->in.radar.set(radar);
  testing::expectRejected(*filter_, "range at t = 4000000 us is -3 m");
  radar["range"] = nullptr;  // NaN is written as null
  filter_->in.radar.set(radar);
  testing::expectRejected(*filter_, "expected a positive finite value");
}

TEST_F(BearingFilterBadInput, ImagesOutOfTimeOrder) {
  fly(false, 5);
  ImageRegion old = ImageRegion::box(500, 500, 1, 1);
  old.stamp = 2'000'000;
  old.frame_id = "camera_far_optical";
  old.source = "match";
  filter_->in.measurement.set(old);
  testing::expectRejected(*filter_, "expected images in time order");
}

TEST_F(BearingFilterBadInput, AnAttitudeInAnotherFrameOrTooFarFromTheImage) {
  PoseWithCovariance eci;
  eci.pose = Transform::identity("eci", "servicer", 0);
  filter_->in.attitude.set(eci);
  testing::expectRejected(*filter_, "expected lvlh_T_servicer");
  PoseWithCovariance a;
  a.pose = Transform::identity("lvlh", "servicer", 0);
  filter_->in.attitude.set(a);
  ASSERT_TRUE(filter_->process().isOk());
  ImageRegion m = ImageRegion::box(500, 500, 1, 1);
  m.stamp = 10'000'000;  // 10 s after the only attitude sample
  m.frame_id = "camera_far_optical";
  m.source = "user";
  filter_->in.measurement.set(m);
  testing::expectRejected(*filter_, "no servicer attitude within 0.5 s");
}

}  // namespace
}  // namespace cdff::dfn
