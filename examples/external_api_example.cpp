// How an autonomy framework (OG2) uses CDFF through its external API (docs/external-api.md):
// load a DFPC, initialise CDFF, feed it sensor data (OG4), subscribe to the target pose at a
// fixed rate, query the pose and velocity in a named frame, check the DFPC's status, stop.
//
//   external_api_example [dfpcs/pose_filtering.yaml]
//
// The sensor here is simulated: a pose measurement of a drifting, tumbling target at 10 Hz, in
// the camera frame, played in real time for 3 s.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <random>
#include <thread>

#include <fmt/format.h>

#include "cdff/dfpc/api.hpp"

using namespace cdff;

int main(int argc, char** argv) {
  api::Config config;
  config.graph_files = {argc > 1 ? argv[1] : CDFF_EXAMPLE_GRAPH};
  // Where the camera sits on the servicer: 0.5 m forward, looking along the servicer's x axis.
  Transform servicer_T_camera = Transform::identity("servicer", "camera");
  servicer_T_camera.translation = Eigen::Vector3d(0.5, 0, 0);
  servicer_T_camera.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()));
  config.static_transforms = {servicer_T_camera};

  Result<std::unique_ptr<api::Cdff>> created = api::Cdff::create(config);
  if (!created) {
    fmt::print(stderr, "error: {}\n", created.status().toString());
    return 1;
  }
  api::Cdff& cdff = *created.value();
  if (Status s = cdff.setCDFFState(api::StateRequest::kInitialize); !s) {
    fmt::print(stderr, "error: {}\n", s.toString());
    return 1;
  }

  // The autonomy wants the pose at 4 Hz, whatever the sensor rate.
  std::atomic<int> poses{0};
  Result<api::SubscriptionId> subscription = cdff.getDFPCPose(
      "pose_filtering", 4.0, [&](Timestamp, const Result<PoseWithCovariance>& pose) {
        if (!pose) return;  // no estimate yet
        ++poses;
        const Eigen::Vector3d& t = pose->pose.translation;
        fmt::print(
            "  pose callback: t = {:.1f} s, camera_T_target = [{:.3f} {:.3f} {:.3f}] m, "
            "sigma_x = {:.1f} mm\n",
            toSeconds(pose->pose.stamp), t.x(), t.y(), t.z(),
            1e3 * std::sqrt(pose->covariance(0, 0)));
      });
  if (!subscription) {
    fmt::print(stderr, "error: {}\n", subscription.status().toString());
    return 1;
  }

  // The sensor suite: 3 s of measurements at 10 Hz, in real time.
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 1.0);
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k <= 30; ++k) {
    const double t = 0.1 * k;
    PoseWithCovariance z;
    z.pose = Transform::identity("camera", "target", fromSeconds(t));
    z.pose.translation = Eigen::Vector3d(0.2 + 0.02 * t, -0.1, 8.0 - 0.05 * t) +
                         0.03 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    z.pose.rotation = expSO3(Eigen::Vector3d(0.0, 0.03 * t, 0.0));
    z.covariance.diagonal() << Eigen::Vector3d::Constant(0.03 * 0.03),
        Eigen::Vector3d::Constant(std::pow(0.5 * M_PI / 180, 2));
    if (Status s = cdff.push(dfpc::Message::of("/chaser/target_pose_measurement", z.pose.stamp, z));
        !s) {
      fmt::print(stderr, "error: {}\n", s.toString());
      return 1;
    }
    std::this_thread::sleep_until(start + std::chrono::milliseconds(100 * (k + 1)));
  }
  if (Status s = cdff.flush(5.0); !s) {
    fmt::print(stderr, "error: {}\n", s.toString());
    return 1;
  }

  // Synchronous queries (seed §7.3): in the camera frame, and re-expressed in the servicer frame.
  for (const char* frame : {"camera", "servicer"}) {
    Result<PoseWithCovariance> pose = cdff.getTargetRelativePose(frame);
    Result<api::VelocityWithCovariance> velocity = cdff.getTargetRelativeVelocity(frame);
    if (!pose || !velocity) {
      fmt::print(stderr, "error: {}\n", (pose ? velocity.status() : pose.status()).toString());
      return 1;
    }
    const Eigen::Vector3d& p = pose->pose.translation;
    const Eigen::Vector3d& v = velocity->twist.linear;
    fmt::print("{}_T_target = [{:.3f} {:.3f} {:.3f}] m, velocity [{:.3f} {:.3f} {:.3f}] m/s\n",
               frame, p.x(), p.y(), p.z(), v.x(), v.y(), v.z());
  }
  const Result<api::TargetModel> model = cdff.getModelOfTarget();
  fmt::print("getModelOfTarget: {}\n", model ? "a model" : model.status().message());
  Result<dfpc::DfpcStatus> status = cdff.getDFPCStatus("pose_filtering");
  if (!status) {
    fmt::print(stderr, "error: {}\n", status.status().toString());
    return 1;
  }
  fmt::print("DFPC {}: {}, {} messages, {} products, {} faults; ekf: {} calls, {:.1f} us/call\n",
             status->name, toString(status->state), status->messages, status->products,
             status->faults, status->instances[0].calls, 1e6 * status->instances[0].mean_wall_s);

  // Errors come back as values, never as exceptions.
  const Status refused = cdff.setCDFFState(api::StateRequest::kInitialize);
  fmt::print("setCDFFState(initialize) again: {}\n", refused.toString());
  (void)cdff.cancelSubscription(subscription.value());
  if (Status s = cdff.setCDFFState(api::StateRequest::kStop); !s) {
    fmt::print(stderr, "error: {}\n", s.toString());
    return 1;
  }
  fmt::print("{} pose callbacks; CDFF {}\n", poses.load(), toString(cdff.getCDFFState()));
  return poses.load() > 0 ? 0 : 1;
}
