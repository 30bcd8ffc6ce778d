// Relative motion and attitude laws against closed forms and conservation laws.
#include <cmath>

#include <gtest/gtest.h>

#include "cdff/egse/world.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

// RK4 on the CW equations with zero control, as an independent check of the closed form.
void integrateCw(const Orbit& orbit, Eigen::Vector3d& r, Eigen::Vector3d& v, double duration,
                 double h) {
  auto f = [&](const Eigen::Vector3d& rr, const Eigen::Vector3d& vv) {
    return orbit.naturalAcceleration(rr, vv);
  };
  for (double t = 0; t < duration - 1e-12; t += h) {
    const Eigen::Vector3d k1r = v, k1v = f(r, v);
    const Eigen::Vector3d k2r = v + 0.5 * h * k1v, k2v = f(r + 0.5 * h * k1r, v + 0.5 * h * k1v);
    const Eigen::Vector3d k3r = v + 0.5 * h * k2v, k3v = f(r + 0.5 * h * k2r, v + 0.5 * h * k2v);
    const Eigen::Vector3d k4r = v + h * k3v, k4v = f(r + h * k3r, v + h * k3v);
    r += h / 6 * (k1r + 2 * k2r + 2 * k3r + k4r);
    v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
  }
}

TEST(Orbit, ClohessyWiltshireClosedFormMatchesIntegration) {
  Orbit orbit;
  orbit.altitude = 500e3;
  EXPECT_NEAR(2 * M_PI / orbit.meanMotion(), 5677.0, 2.0);  // a 500 km orbit lasts ~94.6 min
  const Eigen::Vector3d r0(30, -200, 10), v0(0.05, 0.1, -0.02);
  Eigen::Vector3d r, v, ri = r0, vi = v0;
  orbit.propagate(r0, v0, 1500.0, r, v);
  integrateCw(orbit, ri, vi, 1500.0, 0.5);
  EXPECT_LT((r - ri).norm(), 1e-6);
  EXPECT_LT((v - vi).norm(), 1e-9);
}

TEST(Orbit, NaturalFlyAroundEllipseClosesAfterOneOrbit) {
  Orbit orbit;
  const double n = orbit.meanMotion(), x0 = 20.0;
  // y'(0) = -2 n x0 cancels the drift: a 2:1 ellipse around the target.
  auto translation = cwTranslation(orbit, {x0, 0, 0}, {0, -2 * n * x0, 0});
  const TranslationState end = translation->at(2 * M_PI / n);
  EXPECT_LT((end.position - Eigen::Vector3d(x0, 0, 0)).norm(), 1e-6);
  double max_y = 0;
  for (double t = 0; t < 2 * M_PI / n; t += 10)
    max_y = std::max(max_y, std::abs(translation->at(t).position.y()));
  EXPECT_NEAR(max_y, 2 * x0, 0.01);
  // Free drift needs no thrust.
  World world(orbit, cwTranslation(orbit, {x0, 0, 0}, {0, -2 * n * x0, 0}),
              lvlhFixedAttitude(orbit, Eigen::Quaterniond::Identity()),
              lvlhFixedAttitude(orbit, Eigen::Quaterniond::Identity()), Sun{});
  for (double t : {0.0, 100.0, 2000.0})
    EXPECT_LT(world.servicer(t).control_acceleration.norm(), 1e-12);
}

TEST(Trajectories, DerivativesAreConsistentAndSplinesAreC2) {
  auto line = lineTranslation({0, -17, 0}, {0, -2, 0.5}, 5.0, 65.0, true);
  std::vector<double> times = {0, 10, 25, 40, 60};
  std::vector<Eigen::Vector3d> points = {
      {0, -17, 0}, {1, -12, 0.3}, {0, -8, 0}, {-0.5, -4, 0.2}, {0, -2, 0}};
  auto spline = splineTranslation(times, points);
  ASSERT_OK(spline.status());
  auto fly = flyAroundTranslation({0, 0, 0}, {0, 0, 1}, {0, -1, 0}, 10.0, -0.05, 0.02, 0.3);
  const double h = 1e-4;
  for (const Translation* tr : {line.get(), spline->get(), fly.get()})
    for (double t : {1.0, 7.3, 19.9, 33.3, 59.0}) {
      const TranslationState s = tr->at(t), a = tr->at(t - h), b = tr->at(t + h);
      EXPECT_LT(((b.position - a.position) / (2 * h) - s.velocity).norm(), 1e-6) << "t = " << t;
      EXPECT_LT(((b.velocity - a.velocity) / (2 * h) - s.acceleration).norm(), 1e-5) << "t = " << t;
    }
  // The line rests at both ends; the spline passes through its waypoints with continuous
  // acceleration at the knots.
  EXPECT_LT((line->at(0).position - Eigen::Vector3d(0, -17, 0)).norm(), 1e-12);
  EXPECT_LT(line->at(5.0).velocity.norm() + line->at(65.0).velocity.norm(), 1e-12);
  EXPECT_LT((line->at(70).position - Eigen::Vector3d(0, -2, 0.5)).norm(), 1e-12);
  for (std::size_t i = 0; i < times.size(); ++i)
    EXPECT_LT(((*spline)->at(times[i]).position - points[i]).norm(), 1e-9);
  for (std::size_t i = 1; i + 1 < times.size(); ++i)
    EXPECT_LT(
        ((*spline)->at(times[i] - 1e-9).acceleration - (*spline)->at(times[i] + 1e-9).acceleration)
            .norm(),
        1e-6);
  EXPECT_FALSE(splineTranslation({0, 5, 5}, {points[0], points[1], points[2]}).isOk());
}

TEST(Trajectories, LegsRestAtEveryWaypointAndNeverOvershoot) {
  // A rendezvous's hold points: 2 km, 100 m (held 20 s), 17 m, 2 m.
  const std::vector<double> times = {0, 300, 320, 400, 500};
  const std::vector<Eigen::Vector3d> points = {
      {0, -2000, 0}, {0, -100, 0}, {0, -100, 0}, {0, -17, 0}, {0, -2, 0}};
  auto legs = legsTranslation(times, points);
  ASSERT_OK(legs.status());
  for (std::size_t i = 0; i < times.size(); ++i) {
    EXPECT_LT(((*legs)->at(times[i]).position - points[i]).norm(), 1e-9) << i;
    EXPECT_LT((*legs)->at(times[i]).velocity.norm(), 1e-9) << i;
  }
  EXPECT_LT(((*legs)->at(-5).position - points.front()).norm(), 1e-12);
  EXPECT_LT(((*legs)->at(600).position - points.back()).norm(), 1e-12);
  EXPECT_LT(((*legs)->at(310).position - points[1]).norm(), 1e-12);  // the hold
  // Each leg moves one way only: the range never drops below the next waypoint's.
  double previous = 2000;
  for (double t = 0; t <= 500; t += 0.5) {
    const TranslationState s = (*legs)->at(t);
    EXPECT_LE(-s.position.y(), previous + 1e-9) << "t = " << t;
    previous = -s.position.y();
    const TranslationState a = (*legs)->at(t - 1e-4), b = (*legs)->at(t + 1e-4);
    EXPECT_LT(((b.position - a.position) / 2e-4 - s.velocity).norm(), 1e-4) << "t = " << t;
  }
  EXPECT_FALSE(legsTranslation({0, 5, 5}, {points[0], points[1], points[2]}).isOk());
}

TEST(Attitude, TorqueFreeTumblingConservesMomentumAndEnergy) {
  Orbit free_space;
  free_space.enabled = false;
  const Eigen::Vector3d inertia(800, 1200, 1500);
  const Eigen::Vector3d w0 = Eigen::Vector3d(2.0, -3.5, 4.0) * M_PI / 180.0;  // ~5.7 deg/s
  const Eigen::Quaterniond q0(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()));
  auto tumbling = tumblingAttitude(free_space, q0, w0, inertia, 120.0);
  const Eigen::Vector3d L0 = q0 * inertia.cwiseProduct(w0);
  const double E0 = w0.dot(inertia.cwiseProduct(w0));
  double max_momentum = 0, max_energy = 0;
  bool nutates = false;
  for (double t = 0; t <= 120.0; t += 0.77) {
    const AttitudeState s = tumbling->at(t);
    const Eigen::Vector3d L = s.lvlh_R_body * inertia.cwiseProduct(s.angular_velocity);
    max_momentum = std::max(max_momentum, (L - L0).norm() / L0.norm());
    max_energy = std::max(
        max_energy,
        std::abs(s.angular_velocity.dot(inertia.cwiseProduct(s.angular_velocity)) - E0) / E0);
    nutates = nutates || (s.angular_velocity - w0).norm() > 0.01;
    // Euler's equations hold for the reported angular acceleration.
    const Eigen::Vector3d torque =
        inertia.cwiseProduct(s.angular_acceleration) +
        s.angular_velocity.cross(inertia.cwiseProduct(s.angular_velocity));
    EXPECT_LT(torque.norm(), 1e-9);
  }
  EXPECT_LT(max_momentum, 1e-9);
  EXPECT_LT(max_energy, 1e-9);
  EXPECT_TRUE(nutates) << "an asymmetric body's rate changes in its own axes";
  // The reported rate matches the orientation's derivative.
  const double h = 1e-4;
  const Eigen::Quaterniond a = tumbling->at(50 - h).lvlh_R_body,
                           b = tumbling->at(50 + h).lvlh_R_body;
  EXPECT_LT((logSO3(a.conjugate() * b) / (2 * h) - tumbling->at(50).angular_velocity).norm(), 1e-7);
}

TEST(World, RelativeTwistAndFrames) {
  // In orbit: a servicer holding 10 m behind the target (lvlh-fixed attitude), the target fixed
  // in eci (so it turns at -n in lvlh), the sun fixed in eci.
  Orbit orbit;
  const double n = orbit.meanMotion();
  auto hold = holdTranslation({0, -10, 0});
  const Eigen::Quaterniond facing(
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));  // body x along +y
  Sun sun;
  sun.direction = Eigen::Vector3d(1, 0, 0);
  sun.inertial = true;
  World world(orbit, std::move(hold), lvlhFixedAttitude(orbit, facing),
              inertialAttitude(orbit, Eigen::Quaterniond::Identity()), sun);
  const Twist twist = world.targetTwistInServicer(100.0);
  // The target turns at -n about z relative to lvlh (and so relative to the servicer).
  EXPECT_LT((twist.angular - Eigen::Vector3d(0, 0, -n)).norm(), 1e-9);
  // Its origin does not move relative to the servicer.
  EXPECT_LT(twist.linear.norm(), 1e-9);
  EXPECT_NEAR(world.servicerTtarget(0).translation().x(), 10.0, 1e-12);
  // The servicer holding a fixed point needs thrust against the CW acceleration at y = -10 m
  // (zero: along-track offsets are equilibria).
  EXPECT_LT(world.servicer(5).control_acceleration.norm(), 1e-12);
  // The lvlh-fixed servicer turns with the orbit: its inertial rate is n about lvlh z.
  EXPECT_LT((world.servicer(5).angular_velocity - Eigen::Vector3d(0, 0, n)).norm(), 1e-12);
  // The sun fixed in eci sweeps around in lvlh; after half an orbit it is behind the Earth.
  EXPECT_FALSE(world.inEclipse(0));
  EXPECT_TRUE(world.inEclipse(M_PI / n));
  EXPECT_LT((world.sunDirection(M_PI / n) - Eigen::Vector3d(-1, 0, 0)).norm(), 1e-9);
}

TEST(World, PointingAttitudeKeepsTheTargetOnTheBoresight) {
  Orbit orbit;
  auto fly = flyAroundTranslation({0, 0, 0}, {0, 0, 1}, {0, -1, 0}, 12.0, 0.0, 0.03, 0.0);
  const Translation* self = fly.get();
  auto pointing = pointingAttitude(orbit, self, nullptr, Eigen::Vector3d::UnitZ(), 0.0, 0.0);
  World world(orbit, std::move(fly), std::move(pointing),
              lvlhFixedAttitude(orbit, Eigen::Quaterniond::Identity()), Sun{});
  for (double t : {0.0, 10.0, 33.0}) {
    const Eigen::Isometry3d s_T_t = world.servicerTtarget(t);
    EXPECT_LT(s_T_t.translation().normalized().dot(Eigen::Vector3d::UnitX()), 1.0 + 1e-12);
    EXPECT_GT(s_T_t.translation().normalized().x(), 1.0 - 1e-12);
    // Circling at 0.03 rad/s about lvlh z while facing the centre: inertial rate n + 0.03.
    EXPECT_NEAR(world.servicer(t).angular_velocity.z(), orbit.meanMotion() + 0.03, 1e-7);
  }
}

}  // namespace
}  // namespace cdff::egse
