// cdff initial-state SIM.mcap -o INIT.mcap: the test bench's stand-in for a detection. Reads the
// ground truth of a simulated recording and writes one initial state for a tracking DFPC: the
// truth at the first scan (or any channel's first message) with an error drawn from a Gaussian
// whose RMS is a fraction of the range and an angle, and that Gaussian's covariance
// (eval::perturbedInitialState). `cdff run GRAPH -i SIM.mcap -i INIT.mcap` then starts the
// tracker from it.
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "cdff/eval/initial_state.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

struct InitialStateOptions {
  std::string input, output;
  std::string truth_channel = "/truth/target_pose";
  std::string at_channel = "/chaser/lidar/points";
  std::string channel = "/cdff/lidar_tracking/initial_state";
  double position_fraction = 0.10;
  double angle_deg = 10.0;
  double linear_velocity_sigma = eval::InitialStatePerturbation{}.linear_velocity_sigma;
  double angular_velocity_sigma_deg =
      eval::InitialStatePerturbation{}.angular_velocity_sigma * 180.0 / M_PI;
  std::string distribution = "gaussian";
  std::uint64_t seed = 1;
};

Status writeInitialState(const InitialStateOptions& o) {
  eval::InitialStateFromRecording from;
  from.truth_channel = o.truth_channel;
  from.at_channel = o.at_channel;
  from.channel = o.channel;
  eval::InitialStatePerturbation& p = from.perturbation;
  p.position_fraction = o.position_fraction;
  p.angle_rad = o.angle_deg * M_PI / 180.0;
  p.seed = o.seed;
  p.distribution = o.distribution == "fixed" ? eval::InitialErrorDistribution::kFixedSize
                                             : eval::InitialErrorDistribution::kGaussian;
  p.linear_velocity_sigma = o.linear_velocity_sigma;
  p.angular_velocity_sigma = o.angular_velocity_sigma_deg * M_PI / 180.0;
  Result<eval::WrittenInitialState> written = eval::writeInitialState(o.input, o.output, from);
  if (!written) return written.status();
  const RigidBodyState& state = written->state;
  const std::optional<Transform>& truth_at = written->truth;
  const double moved = truth_at ? (state.pose.translation - truth_at->translation).norm() : 0;
  const double turned =
      truth_at ? logSO3(state.pose.rotation * truth_at->rotation.conjugate()).norm() : 0;
  std::cout << fmt::format(
      "{}: initial state {}_T_{} at t = {:.3f} s on {} ({} error of RMS {:.1f} % of the range "
      "and {:.1f} deg; this draw: {:.3f} m and {:.2f} deg)\n",
      o.output, state.pose.parent_frame, state.pose.child_frame, toSeconds(written->at), o.channel,
      o.distribution, 100 * o.position_fraction, o.angle_deg, moved, turned * 180 / M_PI);
  return Status::ok();
}

}  // namespace

void addInitialStateCommand(CLI::App& root, int& exit_code) {
  auto options = std::make_shared<InitialStateOptions>();
  CLI::App* cmd = root.add_subcommand(
      "initial-state",
      "Write a tracker's initial state: the ground truth of a recording, perturbed (the test "
      "bench's stand-in for a detection)");
  cmd->add_option("INPUT", options->input, "The simulated recording (with ground truth)")
      ->required();
  cmd->add_option("-o,--output", options->output, "The MCAP file to write")->required();
  cmd->add_option("--truth", options->truth_channel, "Truth channel (RigidBodyState)");
  cmd->add_option("--at", options->at_channel, "The state is at this channel's first message");
  cmd->add_option("--channel", options->channel, "Channel of the initial state");
  cmd->add_option("--position-fraction", options->position_fraction,
                  "RMS of the position error as a fraction of the range")
      ->check(CLI::Range(0.0, 10.0));
  cmd->add_option("--angle-deg", options->angle_deg, "RMS of the attitude error (degrees)")
      ->check(CLI::Range(0.0, 180.0));
  cmd->add_option("--velocity-sigma", options->linear_velocity_sigma,
                  "Standard deviation of the (zero) linear velocity in the covariance (m/s)")
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--angular-velocity-sigma-deg", options->angular_velocity_sigma_deg,
                  "Standard deviation of the (zero) angular velocity in the covariance (deg/s)")
      ->check(CLI::Range(0.0, 1000.0));
  cmd->add_option("--distribution", options->distribution,
                  "gaussian: drawn from the Gaussian the covariance states (tails included); "
                  "fixed: exactly the stated sizes in random directions")
      ->check(CLI::IsMember({"gaussian", "fixed"}))
      ->capture_default_str();
  cmd->add_option("--seed", options->seed, "Seed of the error's draw");
  cmd->callback([options, &exit_code] {
    const Status s = writeInitialState(*options);
    if (!s) {
      std::cerr << "cdff initial-state: " << s.toString() << "\n";
      exit_code = 1;
    }
  });
}

}  // namespace cdff::app
