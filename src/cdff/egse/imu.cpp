#include "cdff/egse/imu.hpp"

#include <cmath>

namespace cdff::egse {

Status AhrsSpec::validate(const std::string& name) const {
  if (!std::isfinite(attitude_sigma) || attitude_sigma < 0 || attitude_sigma > M_PI)
    return invalidParameter(
        "{}: 'attitude_sigma' = {} rad is out of range; expected a finite value in [0, pi]", name,
        attitude_sigma);
  return Status::ok();
}

Status ImuSpec::validate(const std::string& name) const {
  if (!std::isfinite(rate) || rate <= 0 || rate > 10000)
    return invalidParameter("{}: 'rate' = {} Hz is out of range; expected (0, 10000]", name, rate);
  const std::pair<double, const char*> figures[] = {
      {gyro_noise_density, "gyro_noise_density"},
      {accel_noise_density, "accel_noise_density"},
      {gyro_bias_sigma, "gyro_bias_sigma"},
      {accel_bias_sigma, "accel_bias_sigma"},
      {gyro_bias_random_walk, "gyro_bias_random_walk"},
      {accel_bias_random_walk, "accel_bias_random_walk"}};
  for (const auto& [value, key] : figures)
    if (!std::isfinite(value) || value < 0)
      return invalidParameter("{}: '{}' = {} is invalid; expected a finite value >= 0", name, key,
                              value);
  if (!(gyro_range > 0) || !(accel_range > 0))
    return invalidParameter("{}: ranges ({} rad/s, {} m/s^2) must be > 0", name, gyro_range,
                            accel_range);
  return Status::ok();
}

ImuTruth imuTruth(const World& world, const Eigen::Isometry3d& servicer_T_imu, double t) {
  const BodyState s = world.servicer(t);
  const Eigen::Matrix3d servicer_R_lvlh = s.lvlh_T_body.linear().transpose();
  const Eigen::Vector3d& w = s.angular_velocity;  // servicer axes
  const Eigen::Vector3d& alpha = s.angular_acceleration;
  const Eigen::Vector3d r = servicer_T_imu.translation();  // lever arm, servicer axes
  const Eigen::Vector3d f_servicer =
      servicer_R_lvlh * s.control_acceleration + alpha.cross(r) + w.cross(w.cross(r));
  const Eigen::Matrix3d imu_R_servicer = servicer_T_imu.linear().transpose();
  ImuTruth truth;
  truth.angular_velocity = imu_R_servicer * w;
  truth.specific_force = imu_R_servicer * f_servicer;
  return truth;
}

Result<ImuSensor> ImuSensor::create(const ImuSpec& spec, const std::string& name,
                                    const Eigen::Isometry3d& servicer_T_imu, std::uint64_t seed) {
  CDFF_RETURN_IF_ERROR(spec.validate(name));
  ImuSensor s;
  s.spec_ = spec;
  s.name_ = name;
  s.servicer_T_imu_ = servicer_T_imu;
  s.seed_ = seed;
  if (spec.noise) {
    Rng rng = Rng::stream(seed, name + "/turn_on_bias");
    for (int i = 0; i < 3; ++i) s.gyro_bias_[i] = spec.gyro_bias_sigma * rng.normal();
    for (int i = 0; i < 3; ++i) s.accel_bias_[i] = spec.accel_bias_sigma * rng.normal();
    if (spec.gyro_bias) s.gyro_bias_ = *spec.gyro_bias;
    if (spec.accel_bias) s.accel_bias_ = *spec.accel_bias;
  }
  return s;
}

Result<ImuSample> ImuSensor::sample(const World& world, double t,
                                    const std::vector<ImuBiasJump>& jumps) {
  if (!(t > last_time_))
    return invalidInput("{}: sample at t = {} s after one at {} s; expected increasing times",
                        name_, t, last_time_);
  const ImuTruth truth = imuTruth(world, servicer_T_imu_, t);
  Rng rng = Rng::stream(seed_, name_, index_++);
  Eigen::Vector3d n_gyro, n_accel, w_gyro, w_accel;
  for (int i = 0; i < 3; ++i) n_gyro[i] = rng.normal();
  for (int i = 0; i < 3; ++i) n_accel[i] = rng.normal();
  for (int i = 0; i < 3; ++i) w_gyro[i] = rng.normal();
  for (int i = 0; i < 3; ++i) w_accel[i] = rng.normal();
  if (spec_.noise && last_time_ > -1e299) {
    const double dt = t - last_time_;
    gyro_bias_ += spec_.gyro_bias_random_walk * std::sqrt(dt) * w_gyro;
    accel_bias_ += spec_.accel_bias_random_walk * std::sqrt(dt) * w_accel;
  }
  last_time_ = t;
  // Bias jumps are faults, applied even to an otherwise ideal IMU.
  Eigen::Vector3d jump_gyro = Eigen::Vector3d::Zero(), jump_accel = Eigen::Vector3d::Zero();
  for (const ImuBiasJump& jump : jumps)
    if (jump.time <= t) {
      jump_gyro += jump.gyro;
      jump_accel += jump.accel;
    }
  gyro_jump_ = jump_gyro;
  accel_jump_ = jump_accel;
  ImuSample s;
  s.frame_id = name_;
  const double sg = spec_.noise ? spec_.gyro_noise_density * std::sqrt(spec_.rate) : 0.0;
  const double sa = spec_.noise ? spec_.accel_noise_density * std::sqrt(spec_.rate) : 0.0;
  s.angular_velocity = truth.angular_velocity + gyro_bias_ + gyro_jump_ + sg * n_gyro;
  s.linear_acceleration = truth.specific_force + accel_bias_ + accel_jump_ + sa * n_accel;
  s.angular_velocity = s.angular_velocity.cwiseMax(-spec_.gyro_range).cwiseMin(spec_.gyro_range);
  s.linear_acceleration =
      s.linear_acceleration.cwiseMax(-spec_.accel_range).cwiseMin(spec_.accel_range);
  s.angular_velocity_covariance = Eigen::Matrix3d::Identity() * (sg * sg);
  s.linear_acceleration_covariance = Eigen::Matrix3d::Identity() * (sa * sa);
  return s;
}

}  // namespace cdff::egse
