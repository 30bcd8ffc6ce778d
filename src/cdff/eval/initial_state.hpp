#pragma once
// Initial states for trackers from the ground truth, perturbed as an upstream detection would be
// wrong: the test bench's stand-in for the detection DFPC when a tracking DFPC is tested alone
// (the LIDAR tracking issue: 10 % of the range and 10 degrees).
#include <cstdint>
#include <vector>

#include "cdff/types/geometry.hpp"
#include "cdff/types/status.hpp"

namespace cdff::eval {

struct InitialStatePerturbation {
  double position_fraction = 0.10;         // of the range, in a random direction
  double angle_rad = 0.17453292519943295;  // about a random axis (10 degrees)
  double linear_velocity_sigma = 0.3;      // m/s, the covariance's (the twist itself is zero)
  double angular_velocity_sigma = 0.1;     // rad/s
  std::uint64_t seed = 1;
};

/// The truth interpolated at `stamp` (sorted `truth`, parent_T_child), moved and turned by
/// exactly the perturbation's sizes, with zero twist and a diagonal covariance whose sigmas
/// are those sizes (at least 5 cm and 0.02 rad). Fails when no truth brackets `stamp`.
Result<RigidBodyState> perturbedInitialState(const std::vector<Transform>& truth, Timestamp stamp,
                                             const InitialStatePerturbation& perturbation = {});

}  // namespace cdff::eval
