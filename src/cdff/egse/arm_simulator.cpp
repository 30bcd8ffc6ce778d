// The arm's servo loop, its contact with the target and its sensors (arm_simulator.hpp); the
// collision paths are drawn in arm_paths.cpp.
#include <algorithm>
#include <cmath>

#include "cdff/egse/arm_simulator.hpp"

namespace cdff::egse {

namespace {

/// The posture the arm starts from when the spec gives none: the upper arm nearly upright, the
/// elbow folded by 103 deg and the wrist pitched by 40 deg, so that the tool points ahead (+x) of
/// the base with its tip 0.70 m out and 0.65 m up, back from the targets the arm reaches and
/// away from the stretched-out singularity, the wrist's (joint 6 at 0) and the pitch limits.
std::vector<double> defaultHome(std::size_t joints) {
  std::vector<double> home(joints, 0.0);
  if (joints == 7) home = {0.0, 0.2, 0.0, -1.8, 0.0, -0.7, 0.0};
  return home;
}

/// Below this sliding speed Coulomb friction is scaled down linearly (its direction is
/// undefined at rest, where a sign switch per sample would chatter): 0.1 mm/s.
constexpr double kStictionSpeed = 1e-4;

Result<Eigen::Isometry3d> sensorTTip(const kinematics::ArmModel& arm, const std::vector<double>& q,
                                     const std::string& sensor_link) {
  Result<Eigen::Isometry3d> base_T_sensor = arm.forwardTo(q, sensor_link);
  if (!base_T_sensor) return base_T_sensor.status().withContext("arm: 'sensor_link'");
  return Eigen::Isometry3d(base_T_sensor->inverse() * arm.forward(q));
}

}  // namespace

Status ArmSpec::validate() const {
  if (description.empty())
    return invalidParameter("arm: 'description' is empty; expected a URDF file");
  if (!std::isfinite(rate) || rate <= 0 || rate > 100000)
    return invalidParameter("arm: 'rate' = {} Hz is out of range; expected (0, 100000]", rate);
  const std::pair<double, const char*> non_negative[] = {
      {tip_radius, "tip_radius"},
      {force_torque.force_noise, "force_noise"},
      {force_torque.torque_noise, "torque_noise"},
      {force_torque.force_bias_sigma, "force_bias_sigma"},
      {force_torque.torque_bias_sigma, "torque_bias_sigma"},
      {encoders.noise, "encoder noise"},
      {contact.damping, "contact damping"},
      {contact.friction, "contact friction"},
      {paths.hold, "hold"},
      {paths.max_overtravel, "max_overtravel"},
      {paths.max_tilt, "max_tilt"},
      {paths.region_radius, "region_radius"},
      {posture_rate, "posture_rate"}};
  for (const auto& [value, key] : non_negative)
    if (!std::isfinite(value) || value < 0)
      return invalidParameter("arm: '{}' = {} is invalid; expected a finite value >= 0", key,
                              value);
  const std::pair<double, const char*> positive[] = {{force_torque.force_range, "force_range"},
                                                     {force_torque.torque_range, "torque_range"},
                                                     {contact.stiffness, "contact stiffness"},
                                                     {paths.standoff, "standoff"},
                                                     {paths.fast_speed, "fast_speed"},
                                                     {paths.slow_speed, "slow_speed"},
                                                     {paths.press_force, "press_force"},
                                                     {paths.transit_speed, "transit_speed"},
                                                     {paths.transit_rate, "transit_rate"},
                                                     {paths.reach, "reach"},
                                                     {paths.homing_clearance, "homing_clearance"}};
  for (const auto& [value, key] : positive)
    if (!std::isfinite(value) || value <= 0)
      return invalidParameter("arm: '{}' = {} is invalid; expected a finite value > 0", key, value);
  if (paths.slow_zone < 0 || paths.slow_zone > paths.standoff)
    return invalidParameter("arm: 'slow_zone' = {} m is invalid; expected [0, standoff = {} m]",
                            paths.slow_zone, paths.standoff);
  if (paths.max_tilt >= M_PI / 2)
    return invalidParameter("arm: 'max_tilt' = {} rad is invalid; expected < pi/2", paths.max_tilt);
  if (encoders.bits < 8 || encoders.bits > 32)
    return invalidParameter("arm: encoder 'bits' = {} is out of range; expected [8, 32]",
                            encoders.bits);
  if (paths.max_draws < 1)
    return invalidParameter("arm: 'max_draws' = {}; expected >= 1", paths.max_draws);
  return Status::ok();
}

Result<std::unique_ptr<ArmSimulator>> ArmSimulator::create(const ArmSpec& spec,
                                                           const TargetModel& target,
                                                           std::uint64_t seed) {
  CDFF_RETURN_IF_ERROR(spec.validate());
  std::unique_ptr<ArmSimulator> sim(new ArmSimulator());
  sim->spec_ = spec;
  Result<kinematics::ArmModel> arm =
      kinematics::ArmModel::load(spec.description, spec.base_link, spec.tip_link);
  if (!arm) return arm.status();
  sim->arm_ = std::move(arm).value();
  Result<std::unique_ptr<RayCaster>> caster = RayCaster::create(target);
  if (!caster) return caster.status();
  sim->caster_ = std::move(caster).value();
  sim->target_ = target;
  sim->seed_ = seed;
  sim->tip_radius_ = spec.tip_radius > 0 ? spec.tip_radius : sim->arm_.tipSphereRadius();
  if (!(sim->tip_radius_ > 0))
    return invalidParameter(
        "arm: no tip radius: 'tip_radius' is 0 and link '{}' of '{}' has no collision sphere",
        spec.tip_link, spec.description);
  sim->q_ = spec.home.empty() ? defaultHome(sim->arm_.jointCount()) : spec.home;
  sim->home_ = sim->q_;
  CDFF_RETURN_IF_ERROR(sim->arm_.checkJoints(sim->q_, 0.0, "arm: 'home'"));
  // The tip in the sensor frame, at two postures: a joint between them would move it.
  Result<Eigen::Isometry3d> at_home = sensorTTip(sim->arm_, sim->q_, spec.sensor_link);
  Result<Eigen::Isometry3d> at_zero =
      sensorTTip(sim->arm_, std::vector<double>(sim->q_.size(), 0.0), spec.sensor_link);
  if (!at_home) return at_home.status();
  if (!at_home->isApprox(*at_zero, 1e-9))
    return invalidParameter(
        "arm: a joint moves between '{}' and '{}'; expected the tool rigid on the sensor",
        spec.sensor_link, spec.tip_link);
  sim->sensor_T_tip_ = *at_home;
  CDFF_RETURN_IF_ERROR(sim->weighTriangles());
  if (spec.force_torque.noise) {
    Rng rng = Rng::stream(seed, "arm/force_torque/bias");
    for (int i = 0; i < 3; ++i) sim->bias_[i] = rng.normal(0, spec.force_torque.force_bias_sigma);
    for (int i = 3; i < 6; ++i) sim->bias_[i] = rng.normal(0, spec.force_torque.torque_bias_sigma);
  }
  sim->noise_ = Rng::stream(seed, "arm/noise");
  return sim;
}

/// The cumulative area of the target's triangles that paths may aim at: all of them, or with a
/// scan region those that come within it (a triangle's bounding sphere about its centroid).
Status ArmSimulator::weighTriangles() {
  const TriangleMesh& mesh = target_.mesh;
  const double region = spec_.paths.region_radius;
  double area = 0;
  for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>(),
                          b = mesh.vertices[tri[1]].cast<double>(),
                          c = mesh.vertices[tri[2]].cast<double>();
    const Eigen::Vector3d centroid = (a + b + c) / 3;
    const double bound =
        std::max({(a - centroid).norm(), (b - centroid).norm(), (c - centroid).norm()});
    if (region <= 0 || (centroid - spec_.paths.region_centre).norm() <= region + bound)
      area += 0.5 * (b - a).cross(c - a).norm();
    cumulative_area_.push_back(area);
  }
  if (!(area > 0))
    return invalidParameter(
        "arm: no surface of '{}' within region_radius = {} m of region_centre ({}, {}, {}) m; "
        "expected a scan region on the target",
        target_.name, region, spec_.paths.region_centre.x(), spec_.paths.region_centre.y(),
        spec_.paths.region_centre.z());
  return Status::ok();
}

Timestamp ArmSimulator::time() const {
  return static_cast<Timestamp>(std::llround(static_cast<double>(index_) * 1e6 / spec_.rate));
}

Result<ArmSample> ArmSimulator::step(const Eigen::Isometry3d& base_T_target) {
  ++index_;
  const Eigen::Isometry3d target_T_base = base_T_target.inverse();
  const bool going_home = phase_ == ArmPhase::kRetreat || phase_ == ArmPhase::kHoming;
  if (park_ && path_index_ >= 0 && !going_home) {
    transit_from_ = target_T_base * arm_.forward(q_);
    CDFF_RETURN_IF_ERROR(planHoming(base_T_target));
    needs_path_ = false;
  } else if (path_index_ < 0 || needs_path_) {
    transit_from_ = target_T_base * arm_.forward(q_);
    CDFF_RETURN_IF_ERROR(drawPath(base_T_target));
  }
  park_ = false;
  Result<std::vector<double>> q = std::vector<double>{};
  if (phase_ == ArmPhase::kTransit || phase_ == ArmPhase::kHoming) {
    q = jointMove(base_T_target);
  } else {
    // The self-motion is left alone on the retreat, whose way home was checked without it.
    const kinematics::PosturePull pull{
        home_, phase_ == ArmPhase::kRetreat ? 0.0 : 1 - std::exp(-spec_.posture_rate / spec_.rate)};
    q = arm_.inverse(base_T_target * command(), q_, 1e-6, &pull);
  }
  if (q) {
    q_ = std::move(q).value();
  } else {
    // The arm stops where it is and aims elsewhere (a singularity or a limit on the way).
    ++abandoned_;
    needs_path_ = true;
  }
  ArmSample sample;
  ArmTruth& truth = sample.truth;
  truth.joints = q_;
  truth.base_T_tip = arm_.forward(q_);
  truth.base_T_sensor = truth.base_T_tip * sensor_T_tip_.inverse();
  truth.path = path_index_;
  truth.phase = phase_;
  contact(target_T_base * truth.base_T_tip.translation(), truth);
  last_normal_force_ = truth.normal_force;
  // The wrench on the tool at the sensor's origin, in the sensor frame.
  const Eigen::Isometry3d sensor_T_target = truth.base_T_sensor.inverse() * base_T_target;
  const Eigen::Vector3d force = sensor_T_target.linear() * truth.contact_force;
  truth.wrench << force, (sensor_T_target * truth.contact_point).cross(force);
  sample.wrench = measureWrench(truth);
  sample.joints = measureJoints(q_);
  return sample;
}

void ArmSimulator::contact(const Eigen::Vector3d& centre, ArmTruth& truth) {
  const double dt = 1.0 / spec_.rate;
  const Eigen::Vector3d velocity =
      last_centre_ ? Eigen::Vector3d((centre - *last_centre_) / dt) : Eigen::Vector3d::Zero();
  last_centre_ = centre;
  const SurfacePoint s = caster_->closestPoint(centre, tip_radius_);
  if (!s.found || s.distance >= tip_radius_) return;
  const Eigen::Vector3d n =
      s.distance > 1e-12 ? Eigen::Vector3d((centre - s.point) / s.distance) : s.face_normal;
  const double penetration = tip_radius_ - s.distance;
  const double normal_force = std::max(
      0.0, spec_.contact.stiffness * penetration - spec_.contact.damping * velocity.dot(n));
  truth.penetration = penetration;
  truth.contact_point = s.point;
  truth.contact_normal = n;
  if (normal_force <= 0) return;  // separating faster than the surface springs back
  const Eigen::Vector3d sliding = velocity - velocity.dot(n) * n;
  const Eigen::Vector3d friction =
      -spec_.contact.friction * normal_force * sliding / std::max(sliding.norm(), kStictionSpeed);
  truth.in_contact = true;
  truth.normal_force = normal_force;
  truth.contact_force = normal_force * n + friction;
}

Wrench ArmSimulator::measureWrench(ArmTruth& truth) {
  const ForceTorqueSpec& ft = spec_.force_torque;
  Vector6d measured = truth.wrench;
  if (ft.noise) {
    measured += bias_;
    for (int i = 0; i < 6; ++i)
      measured[i] += noise_.normal() * (i < 3 ? ft.force_noise : ft.torque_noise);
  }
  for (int i = 0; i < 6; ++i) {
    const double range = i < 3 ? ft.force_range : ft.torque_range;
    if (std::abs(measured[i]) >= range) truth.saturated = true;
    measured[i] = std::clamp(measured[i], -range, range);
  }
  Wrench w;
  w.stamp = time();
  w.frame_id = spec_.sensor_link;
  w.force = measured.head<3>();
  w.torque = measured.tail<3>();
  return w;
}

JointState ArmSimulator::measureJoints(const std::vector<double>& q) {
  const double count = 2 * M_PI / std::ldexp(1.0, spec_.encoders.bits);
  JointState state;
  state.stamp = time();
  for (std::size_t i = 0; i < q.size(); ++i) {
    state.names.push_back(arm_.joints()[i].name);
    const double read = q[i] + noise_.normal() * spec_.encoders.noise;
    state.position.push_back(std::round(read / count) * count);
  }
  return state;
}

}  // namespace cdff::egse
