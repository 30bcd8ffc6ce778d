// ArmSimulator: the arm presses the target where it aims with the commanded force, the wrench is
// the contact force seen from the sensor, friction is Coulomb's, the sensors' noise and bias are
// those of the spec, a seed gives the same run, and bad specs are reported.
#include "cdff/egse/arm_simulator.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "cdff/egse/procedural.hpp"

namespace cdff::egse {
namespace {

const std::string kArm = std::string(CDFF_SOURCE_DIR) + "/data/arms/servicer_arm.urdf";

/// The box target with its +x face 0.85 m ahead of the arm's base, facing it, at shoulder
/// height: the arm reaches most of that face, bits of the side faces and of the wings' yokes.
Eigen::Isometry3d baseTTarget() {
  return Eigen::Translation3d(1.45, 0.0, 0.35) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ());
}

ArmSpec spec(bool noise) {
  ArmSpec s;
  s.description = kArm;
  s.force_torque.noise = noise;
  if (!noise) s.encoders.noise = 0;
  return s;
}

std::unique_ptr<ArmSimulator> make(const ArmSpec& s, std::uint64_t seed) {
  Result<std::unique_ptr<ArmSimulator>> sim =
      ArmSimulator::create(s, makeTargetSatellite().value(), seed);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  return std::move(sim).value();
}

/// Runs until `paths` collision paths are done, calling `visit` on every sample.
template <typename Visit>
void run(ArmSimulator& sim, int paths, Visit visit) {
  while (sim.pathsStarted() <= paths) {
    Result<ArmSample> sample = sim.step(baseTTarget());
    ASSERT_TRUE(sample.isOk()) << sample.status().toString();
    visit(*sample);
  }
}

TEST(ArmSimulator, PressesTheAimedPointWithTheCommandedForce) {
  auto sim = make(spec(false), 3);
  const ArmSpec& s = sim->spec();
  int holds = 0, on_aim = 0, last_path = -1;
  run(*sim, 20, [&](const ArmSample& sample) {
    const ArmTruth& t = sample.truth;
    if (t.phase != ArmPhase::kHold || t.path == last_path) return;
    last_path = t.path;  // the first sample of each hold
    ++holds;
    // The approach stops on the first sample at press_force: it overshoots by at most one
    // sample's travel at slow speed into the spring.
    // At rest the damper's share of that force is gone.
    EXPECT_GE(t.normal_force, s.paths.press_force - s.contact.damping * s.paths.slow_speed - 1e-6);
    EXPECT_LE(t.normal_force,
              s.paths.press_force + s.contact.stiffness * s.paths.slow_speed / s.rate + 1e-6);
    const CollisionPath& path = sim->currentPath();
    // Pressed on the aimed face, the tip slid at most its penetration's tilted share.
    if (t.contact_normal.dot(path.normal) > std::cos(1e-3)) {
      ++on_aim;
      EXPECT_LT((t.contact_point - path.aim).norm(), 1e-4);
    }
  });
  // A path ends in a hold unless the servo abandoned it (a joint limit met in spite of the
  // planner's checks along the transit): rare.
  EXPECT_LE(sim->pathsAbandoned(), 2);
  EXPECT_GE(holds, 20 - sim->pathsAbandoned());
  // Aims within a tip radius of an edge may touch the neighbouring face first.
  EXPECT_GE(on_aim, holds * 8 / 10);
}

TEST(ArmSimulator, TheWrenchIsTheContactForceSeenFromTheSensor) {
  auto sim = make(spec(false), 4);
  const double mu = sim->spec().contact.friction, r = sim->tipRadius();
  int contacts = 0, sliding = 0;
  run(*sim, 10, [&](const ArmSample& sample) {
    const ArmTruth& t = sample.truth;
    const Eigen::Vector3d f = sample.wrench.force, tau = sample.wrench.torque;
    if (!t.in_contact) {
      EXPECT_EQ(f.norm() + tau.norm(), 0.0);
      return;
    }
    ++contacts;
    // The force is the normal push plus friction within Coulomb's cone.
    EXPECT_NEAR(f.norm(), t.contact_force.norm(), 1e-9);
    const Eigen::Vector3d n_world = t.contact_normal;
    const double fn = t.contact_force.dot(n_world);
    const double ft = (t.contact_force - fn * n_world).norm();
    EXPECT_NEAR(fn, t.normal_force, 1e-9);
    EXPECT_LE(ft, mu * fn + 1e-9);
    if (ft > 0.99 * mu * fn) ++sliding;
    // The moment about the tip's centre is that of the friction force at the contact, whose
    // lever is the tip radius less the penetration: a force through the centre has none.
    const Eigen::Vector3d about_centre = tau - sim->tipInSensor().cross(f);
    EXPECT_NEAR(about_centre.norm(), (r - t.penetration) * ft, 1e-9);
  });
  EXPECT_GT(contacts, 100);
  EXPECT_GT(sliding, 0);  // tilted approaches slide while they press
}

TEST(ArmSimulator, SensorNoiseAndBiasAreThoseOfTheSpec) {
  auto sim = make(spec(true), 5);
  const ArmSpec& s = sim->spec();
  Vector6d sum = Vector6d::Zero(), square = Vector6d::Zero();
  double encoder_sum = 0, encoder_square = 0;
  int n = 0, readings = 0;
  const double count = 2 * M_PI / std::ldexp(1.0, s.encoders.bits);
  for (int i = 0; i < 20000; ++i) {
    Result<ArmSample> sample = sim->step(baseTTarget());
    ASSERT_TRUE(sample.isOk());
    for (std::size_t j = 0; j < sample->joints.position.size(); ++j) {
      const double read = sample->joints.position[j];
      EXPECT_NEAR(std::remainder(read, count), 0.0, 1e-9 * count);
      const double e = read - sample->truth.joints[j];
      encoder_sum += e;
      encoder_square += e * e;
      ++readings;
    }
    if (sample->truth.in_contact) continue;
    Vector6d e;
    e << sample->wrench.force, sample->wrench.torque;
    e -= sample->truth.wrench;
    sum += e;
    square += e.cwiseAbs2();
    ++n;
  }
  ASSERT_GT(n, 10000);
  for (int i = 0; i < 6; ++i) {
    const double sigma = i < 3 ? s.force_torque.force_noise : s.force_torque.torque_noise;
    const double mean = sum[i] / n, sd = std::sqrt(square[i] / n - mean * mean);
    EXPECT_NEAR(mean, sim->bias()[i], 5 * sigma / std::sqrt(n)) << "axis " << i;
    EXPECT_NEAR(sd, sigma, 0.05 * sigma) << "axis " << i;  // 5 %: 14 standard errors at n = 1e4
  }
  // Encoders: the noise and the quantisation's uniform error add in quadrature.
  const double mean = encoder_sum / readings;
  const double sd = std::sqrt(encoder_square / readings - mean * mean);
  EXPECT_NEAR(sd, std::hypot(s.encoders.noise, count / std::sqrt(12.0)), 0.05 * s.encoders.noise);
}

TEST(ArmSimulator, ParkingLeavesTheContactAlongTheToolAndGoesHomeClearOfTheTarget) {
  auto sim = make(spec(false), 6);
  const TargetModel target = makeTargetSatellite().value();
  auto caster = RayCaster::create(target);
  ASSERT_TRUE(caster.isOk());
  const Eigen::Isometry3d target_T_base = baseTTarget().inverse();
  auto distance = [&](const ArmTruth& t) {  // from the tip's centre to the surface
    const SurfacePoint p = (*caster)->closestPoint(target_T_base * t.base_T_tip.translation(), 1.0);
    return p.found ? p.distance : 1.0;
  };
  // Pressing the second path's aim, halfway through the hold.
  ArmSample sample;
  do {
    sample = sim->step(baseTTarget()).value();
  } while (sample.truth.path < 1 || sample.truth.phase != ArmPhase::kHold);
  for (int i = 0; i < 50; ++i) sample = sim->step(baseTTarget()).value();
  ASSERT_TRUE(sample.truth.in_contact);
  const int parked_path = sample.truth.path;
  sim->park();
  const ArmSpec& s = sim->spec();
  double last = distance(sample.truth);
  int retreat = 0, homing = 0;
  std::vector<double> home;
  for (sample = sim->step(baseTTarget()).value(); sample.truth.path == parked_path;
       sample = sim->step(baseTTarget()).value()) {
    const ArmTruth& t = sample.truth;
    const double d = distance(t);
    if (t.phase == ArmPhase::kRetreat) {
      ++retreat;
      EXPECT_EQ(homing, 0);
      EXPECT_GE(d, last - 1e-9) << "the retreat closes in on the target";
    } else {
      ASSERT_EQ(t.phase, ArmPhase::kHoming);
      ++homing;
      EXPECT_FALSE(t.in_contact);
      // The motion is checked at postures at most 11 mm of tip travel apart: in between the tip
      // is within half of that of a checked one.
      EXPECT_GE(d, sim->tipRadius() + s.paths.homing_clearance - 0.0055);
      home = t.joints;
    }
    last = d;
  }
  EXPECT_GT(retreat, 0);
  EXPECT_GT(homing, 0);
  // Home exactly, then a new path.
  EXPECT_EQ(home, sim->home());
  EXPECT_EQ(sample.truth.path, parked_path + 1);
  EXPECT_EQ(sim->pathsAbandoned(), 0);
}

TEST(ArmSimulator, RunsPathAfterPathWithoutAbandoningOrTouchingOffTheApproach) {
  // The target turning and drifting as in the haptic goals test (dfns/contact_detection): the
  // transits end where the path starts in the target's frame, the posture comes back to home.
  auto sim = make(spec(false), 7);
  int contacts = 0, off_approach = 0;
  bool in_contact = false;
  while (sim->pathsStarted() <= 60) {
    const double t = toSeconds(sim->time() + 1000);
    const Eigen::Isometry3d moving =
        Eigen::Translation3d(1.45, 0.02 * std::sin(2 * M_PI * t / 45), 0.35) *
        Eigen::AngleAxisd(M_PI + 0.05 * std::sin(2 * M_PI * t / 60), Eigen::Vector3d::UnitZ());
    Result<ArmSample> sample = sim->step(moving);
    ASSERT_TRUE(sample.isOk()) << sample.status().toString();
    const ArmTruth& truth = sample->truth;
    if (truth.in_contact && !in_contact) {
      ++contacts;
      off_approach += truth.phase != ArmPhase::kApproach;
    }
    in_contact = truth.in_contact;
  }
  EXPECT_EQ(sim->pathsAbandoned(), 0);
  EXPECT_EQ(contacts, 60);
  EXPECT_EQ(off_approach, 0);
}

TEST(ArmSimulator, ASeedGivesTheSameRun) {
  auto a = make(spec(true), 11), b = make(spec(true), 11), c = make(spec(true), 12);
  bool differs = false;
  for (int i = 0; i < 3000; ++i) {
    const ArmSample sa = a->step(baseTTarget()).value(), sb = b->step(baseTTarget()).value();
    const ArmSample sc = c->step(baseTTarget()).value();
    ASSERT_EQ(sa.wrench.force, sb.wrench.force);
    ASSERT_EQ(sa.wrench.torque, sb.wrench.torque);
    ASSERT_EQ(sa.joints.position, sb.joints.position);
    differs = differs || sa.wrench.force != sc.wrench.force;
  }
  EXPECT_TRUE(differs);
}

TEST(ArmSimulator, BadSpecsAndAnUnreachableTargetAreReported) {
  ArmSpec missing = spec(false);
  missing.description = "/nonexistent/arm.urdf";
  Result<std::unique_ptr<ArmSimulator>> sim =
      ArmSimulator::create(missing, makeTargetSatellite().value(), 1);
  ASSERT_FALSE(sim.isOk());
  EXPECT_NE(sim.status().message().find("/nonexistent/arm.urdf"), std::string::npos);

  ArmSpec negative = spec(true);
  negative.force_torque.force_noise = -1;
  sim = ArmSimulator::create(negative, makeTargetSatellite().value(), 1);
  ASSERT_FALSE(sim.isOk());
  EXPECT_NE(sim.status().message().find("'force_noise' = -1"), std::string::npos);

  ArmSpec no_sensor = spec(true);
  no_sensor.sensor_link = "wrist_camera";
  EXPECT_FALSE(ArmSimulator::create(no_sensor, makeTargetSatellite().value(), 1).isOk());

  ArmSpec few_draws = spec(true);
  few_draws.paths.max_draws = 50;
  auto far = make(few_draws, 1);
  Result<ArmSample> step = far->step(Eigen::Isometry3d(Eigen::Translation3d(10, 0, 0)));
  ASSERT_FALSE(step.isOk());
  EXPECT_NE(step.status().message().find("no collision path within 50 draws"), std::string::npos)
      << step.status().message();
}

}  // namespace
}  // namespace cdff::egse
