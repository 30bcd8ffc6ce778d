#include "cdff/eval/initial_state.hpp"

#include <cmath>
#include <random>

#include "cdff/eval/pose_evaluation.hpp"

namespace cdff::eval {

namespace {

Eigen::Vector3d gaussian3(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  // Evaluated in order: the three draws are sequenced.
  const double x = n(rng), y = n(rng), z = n(rng);
  return {x, y, z};
}

/// A unit vector uniform on the sphere.
Eigen::Vector3d direction(std::mt19937_64& rng) {
  Eigen::Vector3d d;
  do d = gaussian3(rng);
  while (d.norm() < 1e-9);
  return d.normalized();
}

}  // namespace

Result<RigidBodyState> perturbedInitialState(const std::vector<Transform>& truth, Timestamp stamp,
                                             const InitialStatePerturbation& p) {
  for (const double v :
       {p.position_fraction, p.angle_rad, p.linear_velocity_sigma, p.angular_velocity_sigma})
    if (!std::isfinite(v) || v < 0)
      return invalidParameter(
          "initial error: position fraction {}, angle {} rad, velocity sigmas {} m/s and {} "
          "rad/s; expected finite sizes >= 0",
          p.position_fraction, p.angle_rad, p.linear_velocity_sigma, p.angular_velocity_sigma);
  const std::optional<Transform> at = truthAt(truth, stamp, {});
  if (!at)
    return invalidInput(
        "no ground truth at t = {} us ({} truth samples); expected truth around "
        "the time of the initial state",
        stamp, truth.size());
  RigidBodyState state;
  state.pose = *at;
  state.pose.stamp = stamp;
  const double range = state.pose.translation.norm();
  const double sigma_p = p.position_fraction * range / std::sqrt(3.0);
  const double sigma_r = p.angle_rad / std::sqrt(3.0);
  std::mt19937_64 rng(p.seed);
  Eigen::Vector3d dp, dr;
  if (p.distribution == InitialErrorDistribution::kGaussian) {
    dp = sigma_p * gaussian3(rng);
    dr = sigma_r * gaussian3(rng);
  } else {
    dp = p.position_fraction * range * direction(rng);
    dr = p.angle_rad * direction(rng);
  }
  state.pose.translation += dp;
  state.pose.rotation = (expSO3(dr) * state.pose.rotation).normalized();
  state.covariance.setZero();
  state.covariance.diagonal() << Eigen::Vector3d::Constant(sigma_p * sigma_p),
      Eigen::Vector3d::Constant(sigma_r * sigma_r),
      Eigen::Vector3d::Constant(p.linear_velocity_sigma * p.linear_velocity_sigma),
      Eigen::Vector3d::Constant(p.angular_velocity_sigma * p.angular_velocity_sigma);
  return state;
}

}  // namespace cdff::eval
