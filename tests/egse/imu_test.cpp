// The simulated IMU integrated back into a trajectory reproduces the truth: exactly without
// noise, and within the noise model's random-walk growth with it (Monte Carlo).
#include <cmath>

#include <gtest/gtest.h>

#include "cdff/egse/imu.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

// A servicer circling the target at 12 m and 1.5 deg/s while pointing at it, in a 500 km orbit:
// the IMU sees the orbital rate, the fly-around rate and the thrust that holds the circle
// against the CW dynamics.
std::unique_ptr<World> flyAroundWorld() {
  Orbit orbit;
  auto fly = flyAroundTranslation({0, 0, 0}, {0.2, 0.1, 1.0}, {0, -1, 0}, 12.0, -0.02,
                                  1.5 * M_PI / 180, 0.0);
  const Translation* self = fly.get();
  auto pointing = pointingAttitude(orbit, self, nullptr, Eigen::Vector3d::UnitZ(), 0.05, -0.03);
  return std::make_unique<World>(orbit, std::move(fly), std::move(pointing),
                                 lvlhFixedAttitude(orbit, Eigen::Quaterniond::Identity()), Sun{});
}

Eigen::Isometry3d mounting() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return T;  // at the servicer's centre of mass, rotated
}

struct Errors {
  Eigen::Vector3d attitude;  // rad, rotation vector of truth^-1 * estimate, lvlh axes
  Eigen::Vector3d position;  // m, lvlh
};

// Strapdown in lvlh: attitude from the gyro relative to eci, position from the CW equations
// driven by the measured specific force (trapezoidal attitude, RK2 translation at the IMU rate).
Errors integrate(const World& world, ImuSensor& imu, double duration) {
  const Eigen::Isometry3d servicer_T_imu = mounting();
  const Orbit& orbit = world.orbit();
  const double dt = 1.0 / imu.spec().rate;
  BodyState s0 = world.servicer(0);
  Eigen::Quaterniond eci_R_imu(orbit.eciRotationLvlh(0) * s0.lvlh_T_body.linear() *
                               servicer_T_imu.linear());
  Eigen::Vector3d r = s0.lvlh_T_body.translation(), v = s0.velocity;
  ImuSample previous = *imu.sample(world, 0.0, {});
  const int steps = static_cast<int>(std::lround(duration / dt));
  for (int k = 1; k <= steps; ++k) {
    const double t0 = (k - 1) * dt, t1 = k * dt;
    const ImuSample next = *imu.sample(world, t1, {});
    const Eigen::Quaterniond q0 = eci_R_imu;
    eci_R_imu = (eci_R_imu * expSO3(0.5 * (previous.angular_velocity + next.angular_velocity) * dt))
                    .normalized();
    auto force_lvlh = [&](const Eigen::Quaterniond& q, const ImuSample& s, double t) {
      return Eigen::Vector3d(orbit.eciRotationLvlh(t).transpose() * (q * s.linear_acceleration));
    };
    const Eigen::Vector3d f0 = force_lvlh(q0, previous, t0), f1 = force_lvlh(eci_R_imu, next, t1);
    // Heun's method on r'' = natural(r, v) + f.
    const Eigen::Vector3d a0 = orbit.naturalAcceleration(r, v) + f0;
    const Eigen::Vector3d r_pred = r + dt * v, v_pred = v + dt * a0;
    const Eigen::Vector3d a1 = orbit.naturalAcceleration(r_pred, v_pred) + f1;
    r += 0.5 * dt * (v + v_pred);
    v += 0.5 * dt * (a0 + a1);
    previous = next;
  }
  const BodyState s1 = world.servicer(steps * dt);
  const Eigen::Quaterniond truth(orbit.eciRotationLvlh(steps * dt) * s1.lvlh_T_body.linear() *
                                 servicer_T_imu.linear());
  Errors e;
  e.attitude =
      orbit.eciRotationLvlh(steps * dt).transpose() * logSO3(eci_R_imu * truth.conjugate());
  e.position = r - s1.lvlh_T_body.translation();
  return e;
}

TEST(Imu, NoiseFreeIntegrationReproducesTheTrajectory) {
  auto world = flyAroundWorld();
  ImuSpec spec;
  spec.noise = false;
  auto imu = ImuSensor::create(spec, "imu", mounting(), 1);
  ASSERT_OK(imu.status());
  const Errors e = integrate(*world, *imu, 60.0);
  RecordProperty("attitude_error_rad", fmt::format("{:.3g}", e.attitude.norm()));
  RecordProperty("position_error_m", fmt::format("{:.3g}", e.position.norm()));
  EXPECT_LT(e.attitude.norm(), 1e-6) << "60 s of integration at 120 Hz";
  EXPECT_LT(e.position.norm(), 1e-3);
}

TEST(Imu, ErrorsGrowAsTheNoiseModelPredicts) {
  // Monte Carlo over seeds: errors after T = 20 s against the variance the model predicts for a
  // turn-on bias b (sigma_b), white noise N and bias random walk K:
  //   attitude: sigma_b^2 T^2 + N_g^2 T + K_g^2 T^3 / 3
  //   position: sigma_b^2 T^4 / 4 + N_a^2 T^3 / 3 + K_a^2 T^5 / 20
  // (the attitude error's effect on position is small at these accelerations). Twice: with the
  // MTi's turn-on biases (they dominate), and without them (the random-walk growth alone).
  auto world = flyAroundWorld();
  for (bool turn_on_bias : {true, false}) {
    ImuSpec spec;  // Xsens MTi defaults
    if (!turn_on_bias) spec.gyro_bias_sigma = spec.accel_bias_sigma = 0;
    const double T = 20.0;
    const double var_attitude = std::pow(spec.gyro_bias_sigma * T, 2) +
                                std::pow(spec.gyro_noise_density, 2) * T +
                                std::pow(spec.gyro_bias_random_walk, 2) * std::pow(T, 3) / 3;
    const double var_position = std::pow(spec.accel_bias_sigma, 2) * std::pow(T, 4) / 4 +
                                std::pow(spec.accel_noise_density, 2) * std::pow(T, 3) / 3 +
                                std::pow(spec.accel_bias_random_walk, 2) * std::pow(T, 5) / 20;
    const int runs = 40;
    double sum_attitude = 0, sum_position = 0;
    int outside = 0;
    for (int seed = 1; seed <= runs; ++seed) {
      auto imu = ImuSensor::create(spec, "imu", mounting(), static_cast<std::uint64_t>(seed));
      const Errors e = integrate(*world, *imu, T);
      for (int i = 0; i < 3; ++i) {
        sum_attitude += e.attitude[i] * e.attitude[i];
        sum_position += e.position[i] * e.position[i];
        outside += std::abs(e.attitude[i]) > 3 * std::sqrt(var_attitude);
        outside += std::abs(e.position[i]) > 3 * std::sqrt(var_position);
      }
    }
    // Normalised variances: chi-square with 3 x runs degrees of freedom, divided by them; its
    // 99.9 % interval for 120 degrees of freedom is about [0.66, 1.43].
    const double attitude_ratio = sum_attitude / (3 * runs * var_attitude);
    const double position_ratio = sum_position / (3 * runs * var_position);
    const std::string which = turn_on_bias ? "with_turn_on_bias" : "random_walk_only";
    RecordProperty("attitude_variance_ratio_" + which, fmt::format("{:.3f}", attitude_ratio));
    RecordProperty("position_variance_ratio_" + which, fmt::format("{:.3f}", position_ratio));
    EXPECT_GT(attitude_ratio, 0.66) << which;
    EXPECT_LT(attitude_ratio, 1.43) << which;
    EXPECT_GT(position_ratio, 0.66) << which;
    EXPECT_LT(position_ratio, 1.43) << which;
    EXPECT_LE(outside, 3) << which << ": errors beyond 3 sigma; expected about 0.3 % of 240";
  }
}

TEST(Imu, LeverArmBiasJumpsAndBadSpecifications) {
  auto world = flyAroundWorld();
  // Away from the centre of mass the accelerometer sees alpha x r + w x (w x r) on top: compare
  // with the second derivative of the mounting point's inertial position.
  Eigen::Isometry3d servicer_T_imu = mounting();
  servicer_T_imu.translation() = Eigen::Vector3d(0.4, -0.3, 0.2);
  const Orbit& orbit = world->orbit();
  auto inertial_position = [&](double t) {
    const BodyState s = world->servicer(t);
    return Eigen::Vector3d(orbit.eciRotationLvlh(t) *
                               (s.lvlh_T_body * servicer_T_imu.translation()) +
                           orbit.targetPositionEci(t));
  };
  // Gravity at the mounting point, linearised around the target (consistent with CW).
  auto gravity = [&](double t) {
    const Eigen::Vector3d p = inertial_position(t);
    return Eigen::Vector3d(-kEarthMu * p / std::pow(p.norm(), 3));
  };
  const double t = 17.0, h = 1e-2;
  const Eigen::Vector3d acceleration =
      (inertial_position(t + h) - 2 * inertial_position(t) + inertial_position(t - h)) / (h * h);
  const Eigen::Vector3d specific_force_eci = acceleration - gravity(t);
  const ImuTruth truth = imuTruth(*world, servicer_T_imu, t);
  const Eigen::Matrix3d eci_R_imu =
      orbit.eciRotationLvlh(t) * world->servicer(t).lvlh_T_body.linear() * servicer_T_imu.linear();
  // The finite difference of positions 6.9e6 m from the Earth's centre limits this to ~1e-4.
  EXPECT_LT((eci_R_imu * truth.specific_force - specific_force_eci).norm(), 5e-4);

  ImuSpec spec;
  spec.noise = false;
  auto imu = ImuSensor::create(spec, "imu", mounting(), 1);
  ImuBiasJump jump;
  jump.time = 1.0;
  jump.gyro = Eigen::Vector3d(0.01, 0, 0);
  jump.accel = Eigen::Vector3d(0, 0.05, 0);
  const ImuSample before = *imu->sample(*world, 0.99, {jump});
  const ImuTruth t_before = imuTruth(*world, mounting(), 0.99);
  EXPECT_LT((before.angular_velocity - t_before.angular_velocity).norm(), 1e-12);
  const ImuSample after = *imu->sample(*world, 1.01, {jump});
  const ImuTruth t_after = imuTruth(*world, mounting(), 1.01);
  EXPECT_LT((after.angular_velocity - t_after.angular_velocity - jump.gyro).norm(), 1e-12);
  EXPECT_LT((after.linear_acceleration - t_after.specific_force - jump.accel).norm(), 1e-12);
  EXPECT_FALSE(imu->sample(*world, 0.5, {}).isOk()) << "time goes forward";
  spec.rate = -1;
  EXPECT_FALSE(ImuSensor::create(spec, "imu", mounting(), 1).isOk());
}

}  // namespace
}  // namespace cdff::egse
