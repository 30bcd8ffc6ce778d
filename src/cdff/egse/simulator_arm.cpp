// The simulator's manipulator (scenario `arm:`, docs/haptic-scanning.md): egse::ArmSimulator
// stepped at its rate with the target where the World puts it, its measurements and its truth
// written to the run's channels.
#include <limits>

#include <fmt/format.h>

#include "cdff/egse/simulator.hpp"

namespace cdff::egse {

namespace {

const char* const kJoints = "/chaser/arm/joints";
const char* const kWrench = "/chaser/arm/wrench";
const char* const kContact = "/truth/arm/contact";
const char* const kContactForce = "/truth/arm/contact_force";
const char* const kTargetPose = "/truth/arm/target_pose";

}  // namespace

Status Simulator::createArm() {
  const ArmConfig& config = scenario_.arm;
  if (!config.enabled) return Status::ok();
  // Its own streams of the run's seed (arm/...): the other sensors' draws are unchanged by it.
  auto arm = ArmSimulator::create(config.spec, target_, seed_);
  if (!arm) return arm.status();  // its messages start with "arm:" or the URDF's file:line
  arm_ = std::move(arm).value();
  arm_steps_ = 0;
  return Status::ok();
}

double Simulator::nextArmTime() const {
  if (!arm_) return std::numeric_limits<double>::infinity();
  return static_cast<double>(arm_steps_ + 1) / scenario_.arm.spec.rate;
}

Status Simulator::beginArm(SimulationMetadata& metadata, std::vector<std::string>& frames) {
  if (!arm_) return Status::ok();
  const ArmSpec& spec = scenario_.arm.spec;
  frames.push_back("servicer -> " + spec.base_link);
  metadata.values["arm"] = fmt::format("{} ({} joints, {} Hz, tip radius {} m)", spec.description,
                                       arm_->arm().jointCount(), spec.rate, arm_->tipRadius());
  queue("/chaser/tf/" + spec.base_link, 0,
        Transform::fromIsometry(scenario_.arm.servicer_T_base, "servicer", spec.base_link, 0));
  return Status::ok();
}

Status Simulator::processArm(double t) {
  const ArmConfig& config = scenario_.arm;
  const Timestamp stamp = fromSeconds(t);
  const Eigen::Isometry3d base_T_target =
      config.servicer_T_base.inverse() * world_->servicerTtarget(t);
  Result<ArmSample> sample = arm_->step(base_T_target);
  if (!sample) return sample.status().withContext(fmt::format("arm at {:.3f} s", t));
  // The arm's own clock counts its samples from 0 as this loop does; the stamps are the run's.
  sample->joints.stamp = stamp;
  sample->wrench.stamp = stamp;
  queue(kJoints, stamp, std::move(sample->joints));
  queue(kWrench, stamp, std::move(sample->wrench));
  const ArmTruth& truth = sample->truth;
  if (!truth.in_contact) return Status::ok();
  // The true contact in the target frame: the point on the surface, its outward normal, the
  // normal force as intensity; and the whole force on the tool (with its friction).
  const Eigen::Vector3f p = truth.contact_point.cast<float>();
  const Eigen::Vector3f n = truth.contact_normal.cast<float>();
  PointCloud contact = PointCloud::fromXyz({p}, "target", stamp);
  contact.normals = Buffer<Point4f>::fromVector({Point4f(n.x(), n.y(), n.z())});
  contact.intensity = Buffer<float>::fromVector({static_cast<float>(truth.normal_force)});
  queue(kContact, stamp, std::move(contact));
  Wrench force;
  force.stamp = stamp;
  force.frame_id = "target";
  force.force = truth.contact_force;
  queue(kContactForce, stamp, force);
  return Status::ok();
}

/// base_T_target at the truth's rate: the target's pose for a haptic DFPC without an estimator.
void Simulator::armTruth(double t) {
  if (!arm_) return;
  const ArmConfig& config = scenario_.arm;
  const Timestamp stamp = fromSeconds(t);
  PoseWithCovariance pose;
  pose.pose = Transform::fromIsometry(config.servicer_T_base.inverse() * world_->servicerTtarget(t),
                                      config.spec.base_link, "target", stamp);
  pose.covariance.setZero();
  queue(kTargetPose, stamp, std::move(pose));
}

}  // namespace cdff::egse
