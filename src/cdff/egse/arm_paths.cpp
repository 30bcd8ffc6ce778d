// The arm's random collision paths and the motion along them (arm_simulator.hpp).
#include <algorithm>
#include <cmath>

#include "cdff/egse/arm_simulator.hpp"

namespace cdff::egse {

namespace {

/// A unit vector perpendicular to `n`.
Eigen::Vector3d perpendicular(const Eigen::Vector3d& n) {
  const Eigen::Vector3d other =
      std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return n.cross(other).normalized();
}

/// The tip pose with its centre at `centre` and attitude `attitude`.
Eigen::Isometry3d tipPose(const Eigen::Vector3d& centre, const Eigen::Quaterniond& attitude) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = attitude.toRotationMatrix();
  pose.translation() = centre;
  return pose;
}

/// The margin kept between the tip and the target during a transit between paths (m), and
/// along an approach before it touches: the approach aims at one point, not at a grazing
/// contact on the way.
constexpr double kTransitClearance = 0.005;
constexpr double kApproachClearance = 2e-4;
/// Poses of a transit checked for reach before it is taken.
constexpr int kTransitChecks = 10;

}  // namespace

bool ArmSimulator::clear(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                         double clearance) const {
  const double length = (to - from).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length / 0.002)));
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector3d p = from + (to - from) * (static_cast<double>(i) / steps);
    if (caster_->closestPoint(p, clearance).found) return false;
  }
  return true;
}

Result<CollisionPath> ArmSimulator::candidatePath(const Eigen::Isometry3d& base_T_target,
                                                  Rng& rng) const {
  const Eigen::Isometry3d target_T_base = base_T_target.inverse();
  const Eigen::Vector3d shoulder = target_T_base * spec_.paths.reach_centre;
  // A point uniform over the surface: a triangle by area, then uniform inside it.
  const double pick = rng.uniform() * cumulative_area_.back();
  const auto t = static_cast<std::size_t>(
      std::upper_bound(cumulative_area_.begin(), cumulative_area_.end(), pick) -
      cumulative_area_.begin());
  const auto& tri = target_.mesh.triangles[std::min(t, cumulative_area_.size() - 1)];
  const Eigen::Vector3d a = target_.mesh.vertices[tri[0]].cast<double>();
  const Eigen::Vector3d b = target_.mesh.vertices[tri[1]].cast<double>();
  const Eigen::Vector3d c = target_.mesh.vertices[tri[2]].cast<double>();
  const double root = std::sqrt(rng.uniform()), v = rng.uniform();
  CollisionPath path;
  path.aim = (1 - root) * a + root * (1 - v) * b + root * v * c;
  path.normal = (b - a).cross(c - a).normalized();
  if (!path.normal.allFinite()) return invalidInput("degenerate triangle");
  if ((path.aim - shoulder).norm() > spec_.paths.reach) return invalidInput("out of reach");
  if (path.normal.dot(shoulder - path.aim) <= 0) return invalidInput("facing away");
  // The approach axis: uniform over the cone of half-angle max_tilt about the normal.
  const double cos_tilt = 1 - rng.uniform() * (1 - std::cos(spec_.paths.max_tilt));
  const double azimuth = 2 * M_PI * rng.uniform();
  const Eigen::Vector3d e1 = perpendicular(path.normal), e2 = path.normal.cross(e1);
  path.axis = cos_tilt * path.normal + std::sqrt(1 - cos_tilt * cos_tilt) *
                                           (std::cos(azimuth) * e1 + std::sin(azimuth) * e2);
  path.touch = path.aim + tip_radius_ * path.normal;
  path.start = path.touch + spec_.paths.standoff * path.axis;
  // The tool points along the approach (its z from the sensor to the tip), at a random roll.
  const Eigen::Vector3d z = -path.axis, x0 = perpendicular(z);
  const Eigen::Vector3d x = Eigen::AngleAxisd(2 * M_PI * rng.uniform(), z) * x0;
  Eigen::Matrix3d attitude;
  attitude << x, z.cross(x), z;
  path.attitude = Eigen::Quaterniond(attitude);
  if (!clear(path.start, path.touch + 0.5 * spec_.paths.slow_zone * path.axis,
             tip_radius_ + kApproachClearance))
    return invalidInput("approach blocked");
  const Eigen::Isometry3d from = target_T_base * arm_.forward(q_);
  if (!clear(from.translation(), path.start, tip_radius_ + kTransitClearance))
    return invalidInput("transit blocked");
  // Reachable all along: the transit's straight line (its inverse kinematics chained from the
  // current posture, as the servo will) and the approach's end.
  const Eigen::Quaterniond from_attitude(from.linear());
  std::vector<double> q = q_;
  for (int i = 1; i <= kTransitChecks; ++i) {
    const double s = static_cast<double>(i) / kTransitChecks;
    const Eigen::Isometry3d waypoint =
        tipPose(from.translation() + s * (path.start - from.translation()),
                from_attitude.slerp(s, path.attitude));
    Result<std::vector<double>> next = arm_.inverse(base_T_target * waypoint, q);
    if (!next) return next.status();
    q = std::move(next).value();
  }
  Result<std::vector<double>> at_touch =
      arm_.inverse(base_T_target * tipPose(path.touch, path.attitude), q);
  if (!at_touch) return at_touch.status();
  return path;
}

Status ArmSimulator::drawPath(const Eigen::Isometry3d& base_T_target) {
  ++path_index_;
  needs_path_ = false;
  Rng rng = Rng::stream(seed_, "arm/collision_path", static_cast<std::uint64_t>(path_index_));
  for (int draw = 0; draw < spec_.paths.max_draws; ++draw) {
    Result<CollisionPath> path = candidatePath(base_T_target, rng);
    if (!path) continue;
    path_ = std::move(path).value();
    phase_ = ArmPhase::kTransit;
    phase_time_ = 0;
    travel_ = 0;
    const double distance = (path_.start - transit_from_.translation()).norm();
    const double turn = Eigen::Quaterniond(transit_from_.linear()).angularDistance(path_.attitude);
    transit_duration_ = std::max(
        {distance / spec_.paths.transit_speed, turn / spec_.paths.transit_rate, 10.0 / spec_.rate});
    return Status::ok();
  }
  // From a posture none of the draws could leave (an elbow folded by the last paths), the arm
  // first goes home in joint space and draws again there.
  if (phase_ != ArmPhase::kHoming && q_ != home_) {
    --path_index_;
    phase_ = ArmPhase::kHoming;
    phase_time_ = 0;
    homing_from_ = q_;
    double turn = 0;
    for (std::size_t i = 0; i < q_.size(); ++i) turn = std::max(turn, std::abs(home_[i] - q_[i]));
    transit_duration_ = std::max(turn / spec_.paths.transit_rate, 10.0 / spec_.rate);
    return Status::ok();
  }
  return numericalFailure(
      "arm: no collision path within {} draws (path {}): no surface of '{}' within {} m of the "
      "reach centre that faces the arm, has a clear approach and is reachable; expected the "
      "target within the arm's reach",
      spec_.paths.max_draws, path_index_, target_.name, spec_.paths.reach);
}

Eigen::Isometry3d ArmSimulator::command() {
  const double dt = 1.0 / spec_.rate;
  const CollisionPathSpec& p = spec_.paths;
  phase_time_ += dt;
  switch (phase_) {
    case ArmPhase::kTransit: {
      // A smooth start and stop (cosine profile) on the straight line to the path's start.
      const double tau = std::min(1.0, phase_time_ / transit_duration_);
      const double s = 0.5 - 0.5 * std::cos(M_PI * tau);
      const Eigen::Quaterniond from(transit_from_.linear());
      const Eigen::Vector3d centre =
          transit_from_.translation() + s * (path_.start - transit_from_.translation());
      if (tau >= 1) {
        phase_ = ArmPhase::kApproach;
        phase_time_ = 0;
      }
      return tipPose(centre, from.slerp(s, path_.attitude));
    }
    case ArmPhase::kApproach:
      if (last_normal_force_ >= p.press_force) {
        phase_ = ArmPhase::kHold;
        phase_time_ = 0;
        break;
      }
      travel_ += (travel_ < p.standoff - p.slow_zone ? p.fast_speed : p.slow_speed) * dt;
      if (travel_ > p.standoff + p.max_overtravel) {  // nothing there: a miss
        phase_ = ArmPhase::kRetract;
        phase_time_ = 0;
      }
      break;
    case ArmPhase::kHold:
      if (phase_time_ >= p.hold) {
        phase_ = ArmPhase::kRetract;
        phase_time_ = 0;
      }
      break;
    case ArmPhase::kRetract:
      travel_ = std::max(0.0, travel_ - p.fast_speed * dt);
      if (travel_ <= 0) needs_path_ = true;
      break;
    case ArmPhase::kHoming:
      break;  // in joint space: homingJoints()
  }
  return tipPose(path_.start - travel_ * path_.axis, path_.attitude);
}

std::vector<double> ArmSimulator::homingJoints() {
  const double tau = std::min(1.0, phase_time_ / transit_duration_);
  const double s = 0.5 - 0.5 * std::cos(M_PI * tau);
  std::vector<double> q(q_.size());
  for (std::size_t i = 0; i < q.size(); ++i)
    q[i] = homing_from_[i] + s * (home_[i] - homing_from_[i]);
  if (tau >= 1) needs_path_ = true;
  return q;
}

}  // namespace cdff::egse
