#include "cdff/eval/initial_state.hpp"

#include <algorithm>
#include <random>

#include "cdff/eval/pose_evaluation.hpp"

namespace cdff::eval {

Result<RigidBodyState> perturbedInitialState(const std::vector<Transform>& truth, Timestamp stamp,
                                             const InitialStatePerturbation& perturbation) {
  const std::optional<Transform> at = truthAt(truth, stamp, {});
  if (!at)
    return invalidInput(
        "no ground truth at t = {} us ({} truth samples); expected truth around "
        "the time of the initial state",
        stamp, truth.size());
  RigidBodyState state;
  state.pose = *at;
  state.pose.stamp = stamp;
  std::mt19937_64 rng(perturbation.seed);
  std::normal_distribution<double> n;
  const Eigen::Vector3d direction = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  const Eigen::Vector3d axis = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  const double range = state.pose.translation.norm();
  state.pose.translation += perturbation.position_fraction * range * direction;
  state.pose.rotation = (expSO3(perturbation.angle_rad * axis) * state.pose.rotation).normalized();
  const double sigma_p = std::max(0.05, perturbation.position_fraction * range);
  const double sigma_r = std::max(0.02, perturbation.angle_rad);
  state.covariance.setZero();
  state.covariance.diagonal() << Eigen::Vector3d::Constant(sigma_p * sigma_p),
      Eigen::Vector3d::Constant(sigma_r * sigma_r),
      Eigen::Vector3d::Constant(perturbation.linear_velocity_sigma *
                                perturbation.linear_velocity_sigma),
      Eigen::Vector3d::Constant(perturbation.angular_velocity_sigma *
                                perturbation.angular_velocity_sigma);
  return state;
}

}  // namespace cdff::eval
