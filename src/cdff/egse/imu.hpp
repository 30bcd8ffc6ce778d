#pragma once
// The IMU on the servicer (default: the seed's Xsens MTi at 120 Hz).
//
// Truth: the gyro sees the servicer's angular velocity relative to the inertial frame; the
// accelerometer sees the specific force at its mounting point, which in orbit is the servicer's
// non-gravitational (thrust) acceleration plus the lever-arm terms alpha x r + omega x (omega x r)
// (gravity acts on the proof mass and the case alike; the gravity gradient across the lever arm,
// ~1e-6 m/s^2 per metre in LEO, is neglected).
// Errors: white noise (noise density x sqrt(rate) per sample), a turn-on bias drawn per run, a
// bias random walk, bias jumps (faults), clipping at the full-scale range.
//
// Default figures: Xsens "MTi and MTx User Manual and Technical Documentation" (MT0100P),
// calibrated data specification for the MTi's default ranges (+-300 deg/s, +-50 m/s^2): rate of
// turn noise 0.05 deg/s/sqrt(Hz), bias stability 1 deg/s (1 sigma); acceleration noise
// 0.002 m/s^2/sqrt(Hz), bias stability 0.02 m/s^2. The datasheet gives no bias random walk; the
// defaults (1e-4 rad/s/sqrt(s), 1e-4 m/s^2/sqrt(s)) are assumptions (docs/simulator.md).

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/egse/rng.hpp"
#include "cdff/egse/world.hpp"
#include "cdff/types/sensors.hpp"

namespace cdff::egse {

struct ImuSpec {
  double rate = 120.0;                              // Hz
  double gyro_noise_density = 0.05 * M_PI / 180.0;  // rad/s/sqrt(Hz)
  double accel_noise_density = 0.002;               // m/s^2/sqrt(Hz)
  double gyro_bias_sigma = 1.0 * M_PI / 180.0;      // rad/s, turn-on bias (1 sigma)
  double accel_bias_sigma = 0.02;                   // m/s^2
  double gyro_bias_random_walk = 1e-4;              // rad/s/sqrt(s)
  double accel_bias_random_walk = 1e-4;             // m/s^2/sqrt(s)
  std::optional<Eigen::Vector3d> gyro_bias;         // fixed turn-on bias instead of a random one
  std::optional<Eigen::Vector3d> accel_bias;
  double gyro_range = 300.0 * M_PI / 180.0;  // rad/s full scale
  double accel_range = 50.0;                 // m/s^2 full scale
  bool noise = true;                         // false: exact truth (biases and noise off)

  Status validate(const std::string& name) const;
};

/// The servicer's AHRS (attitude and heading reference): its attitude in the inertial frame
/// (eci; lvlh when the orbit is off), each sample turned by white noise of `attitude_sigma` per
/// axis. The default (0.2 deg) is an assumption for an attitude solution aided by a star tracker,
/// the EstimationFilter's ahrs_attitude_sigma (docs/simulator.md).
struct AhrsSpec {
  double attitude_sigma = 0.0035;  // rad, 1 sigma per axis
  bool noise = true;               // false: exact truth
  /// true: the attitude in the target's orbital frame (lvlh_T_servicer), as the servicer's
  /// navigation composes it from the AHRS and its orbit (far-range tracking's input).
  bool lvlh_frame = false;

  Status validate(const std::string& name) const;
};

struct ImuBiasJump {
  double time = 0;                                  // s
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // rad/s, added from `time` on
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // m/s^2
};

/// What an ideal IMU at `servicer_T_imu` measures at time t, in the IMU frame.
struct ImuTruth {
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  // rad/s, relative to eci
  Eigen::Vector3d specific_force = Eigen::Vector3d::Zero();    // m/s^2
};
ImuTruth imuTruth(const World& world, const Eigen::Isometry3d& servicer_T_imu, double t);

class ImuSensor {
 public:
  static Result<ImuSensor> create(const ImuSpec& spec, const std::string& name,
                                  const Eigen::Isometry3d& servicer_T_imu, std::uint64_t seed);
  const ImuSpec& spec() const { return spec_; }
  /// The sample at time t; times must increase from call to call (the biases walk forward).
  Result<ImuSample> sample(const World& world, double t, const std::vector<ImuBiasJump>& jumps);
  /// The biases of the last sample, jumps included (ground truth for estimator tests).
  Eigen::Vector3d gyroBias() const { return gyro_bias_ + gyro_jump_; }
  Eigen::Vector3d accelBias() const { return accel_bias_ + accel_jump_; }

 private:
  ImuSpec spec_;
  std::string name_;
  Eigen::Isometry3d servicer_T_imu_ = Eigen::Isometry3d::Identity();
  std::uint64_t seed_ = 0;
  std::uint64_t index_ = 0;
  double last_time_ = -1e300;
  Eigen::Vector3d gyro_bias_ = Eigen::Vector3d::Zero(), accel_bias_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_jump_ = Eigen::Vector3d::Zero(), accel_jump_ = Eigen::Vector3d::Zero();
};

}  // namespace cdff::egse
