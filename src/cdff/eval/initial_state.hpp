#pragma once
// Initial states for trackers from the ground truth, wrong as an upstream detection would be:
// the test bench's stand-in for the detection DFPC when a tracking DFPC is tested alone.
//
// The error's size is stated as the RMS of the position error's length (a fraction of the range)
// and of the attitude error's angle. By default the error is drawn from the zero-mean Gaussian
// with that RMS (each axis with sigma = size / sqrt(3)), tails included, and the state's
// covariance is that Gaussian's: the tracker is told the distribution the error came from, not
// the error. `kFixedSize` moves the truth by exactly the stated sizes in random directions (a
// controlled test of a basin's edge); its covariance is the same.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "cdff/types/geometry.hpp"
#include "cdff/types/status.hpp"

namespace cdff::eval {

enum class InitialErrorDistribution { kGaussian, kFixedSize };

struct InitialStatePerturbation {
  double position_fraction = 0.10;         // RMS of |position error| / range
  double angle_rad = 0.17453292519943295;  // RMS of the attitude error's angle (10 degrees)
  double linear_velocity_sigma = 0.3;      // m/s per axis, the covariance's (the twist is zero)
  double angular_velocity_sigma = 0.1;     // rad/s per axis
  InitialErrorDistribution distribution = InitialErrorDistribution::kGaussian;
  std::uint64_t seed = 1;
};

/// The truth interpolated at `stamp` (sorted `truth`, parent_T_child) with the drawn error, zero
/// twist and the block-diagonal covariance described above. Fails when no truth brackets
/// `stamp`, or when a size is negative or not finite.
Result<RigidBodyState> perturbedInitialState(const std::vector<Transform>& truth, Timestamp stamp,
                                             const InitialStatePerturbation& perturbation = {});

/// Where a recording's initial state comes from and goes to (`cdff initial-state`).
struct InitialStateFromRecording {
  std::string truth_channel = "/truth/target_pose";            // RigidBodyState (or a pose)
  std::string at_channel = "/chaser/lidar/points";             // the state is at its first message
  std::string channel = "/cdff/lidar_tracking/initial_state";  // where it is written
  InitialStatePerturbation perturbation;
};

struct WrittenInitialState {
  RigidBodyState state;
  Timestamp at = 0;
  std::optional<Transform> truth;  // the truth at `at`
};

/// Reads the truth of the simulated recording `input`, draws the perturbed initial state at the
/// first message of `at_channel` (a scan's own stamp, its start), and writes it to the MCAP file
/// `output` on `channel`.
Result<WrittenInitialState> writeInitialState(const std::string& input, const std::string& output,
                                              const InitialStateFromRecording& options);

}  // namespace cdff::eval
