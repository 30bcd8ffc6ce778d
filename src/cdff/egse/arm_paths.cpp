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
/// Poses of a retreat checked for reach before it is taken.
constexpr int kRetreatChecks = 10;
/// The largest joint motion between two checked poses of a retreat (rad): the servo moves the
/// joints continuously, so a check whose solution jumps (a roll joint wrapped by a turn, the
/// wrist flipped) does not tell whether the servo gets through.
constexpr double kMaxCheckStep = 0.5;
/// The tool's roll about its axis is drawn within this angle of the home attitude's (rad).
constexpr double kMaxRoll = M_PI / 2;
/// Draws of a point before a scan region counts as missed: 1000 misses a region of 1 % of its
/// triangles' area once in e^10.
constexpr int kRegionTries = 1000;
/// The retreats along the tool's axis tried, shortest first, before the arm goes home in joint
/// space (m): far enough out, the tip's joint-space way home passes clear of the target.
constexpr double kRetreats[] = {0.05, 0.1, 0.2, 0.3};
/// The largest joint step between the postures of a joint-space motion checked for clearance
/// (rad): at the arm's reach of 1.07 m the tip moves at most 11 mm between them, so a surface
/// within the clearance of the path is within the clearance plus 5.5 mm of a checked posture.
constexpr double kJointCheckStep = 0.01;

/// The smooth start and stop of every motion: the fraction done at `tau` of its duration.
double cosineProfile(double tau) {
  return 0.5 - 0.5 * std::cos(M_PI * std::min(1.0, tau));
}

/// The largest joint displacement between two postures (rad).
double largestTurn(const std::vector<double>& a, const std::vector<double>& b) {
  double turn = 0;
  for (std::size_t i = 0; i < a.size(); ++i) turn = std::max(turn, std::abs(b[i] - a[i]));
  return turn;
}

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

/// A point uniform over the surface (a triangle by area, then uniform inside it) and its face's
/// normal; with a scan region, drawn again until it falls inside the region (cheap draws, not
/// counted against max_draws: a region of a few percent of its triangles' area takes about a
/// hundred). False when kRegionTries miss it or the triangle is degenerate.
bool ArmSimulator::drawAim(Rng& rng, Eigen::Vector3d& aim, Eigen::Vector3d& normal) const {
  const double region = spec_.paths.region_radius;
  for (int tries = 0; tries < kRegionTries; ++tries) {
    const double pick = rng.uniform() * cumulative_area_.back();
    const auto t = static_cast<std::size_t>(
        std::upper_bound(cumulative_area_.begin(), cumulative_area_.end(), pick) -
        cumulative_area_.begin());
    const auto& tri = target_.mesh.triangles[std::min(t, cumulative_area_.size() - 1)];
    const Eigen::Vector3d a = target_.mesh.vertices[tri[0]].cast<double>();
    const Eigen::Vector3d b = target_.mesh.vertices[tri[1]].cast<double>();
    const Eigen::Vector3d c = target_.mesh.vertices[tri[2]].cast<double>();
    const double root = std::sqrt(rng.uniform()), v = rng.uniform();
    aim = (1 - root) * a + root * (1 - v) * b + root * v * c;
    normal = (b - a).cross(c - a).normalized();
    if (!normal.allFinite()) return false;
    if (region <= 0 || (aim - spec_.paths.region_centre).norm() <= region) return true;
  }
  return false;
}

Result<CollisionPath> ArmSimulator::candidatePath(const Eigen::Isometry3d& base_T_target,
                                                  Rng& rng) const {
  const Eigen::Isometry3d target_T_base = base_T_target.inverse();
  const Eigen::Vector3d shoulder = target_T_base * spec_.paths.reach_centre;
  CollisionPath path;
  if (!drawAim(rng, path.aim, path.normal)) return invalidInput("no aim in the scan region");
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
  // The tool points along the approach (its z from the sensor to the tip). Its roll about that
  // axis is free (the tip is a sphere): the smallest turn from the home attitude, then a random
  // roll within kMaxRoll of it, so that the sensor sees contacts at many rolls while the wrist
  // stays away from its limits.
  const Eigen::Matrix3d home = target_T_base.linear() * arm_.forward(home_).linear();
  const Eigen::Quaterniond swing = Eigen::Quaterniond::FromTwoVectors(home.col(2), -path.axis);
  path.attitude = Eigen::AngleAxisd((2 * rng.uniform() - 1) * kMaxRoll, -path.axis) * swing *
                  Eigen::Quaterniond(home);
  path.attitude.normalize();
  if (!clear(path.start, path.touch + 0.5 * spec_.paths.slow_zone * path.axis,
             tip_radius_ + kApproachClearance))
    return invalidInput("approach blocked");
  // The joints at the start, solved from home (every path starts in a posture near it, so the
  // arm does not wander from path to path), reachable down to the touch, and a joint-space
  // transit there that keeps clear of the target.
  Result<std::vector<double>> at_start =
      arm_.inverse(base_T_target * tipPose(path.start, path.attitude), home_);
  if (!at_start) return at_start.status();
  Result<std::vector<double>> at_touch =
      arm_.inverse(base_T_target * tipPose(path.touch, path.attitude), *at_start);
  if (!at_touch) return at_touch.status();
  if (largestTurn(*at_start, *at_touch) > kMaxCheckStep) return invalidInput("approach jumps");
  if (!jointMoveClear(base_T_target, q_, *at_start, kTransitClearance))
    return invalidInput("transit blocked");
  path.start_joints = std::move(at_start).value();
  return path;
}

Result<std::vector<double>> ArmSimulator::reachAlong(const Eigen::Isometry3d& base_T_target,
                                                     const Eigen::Isometry3d& from,
                                                     const Eigen::Vector3d& to) const {
  std::vector<double> q = q_;
  for (int i = 1; i <= kRetreatChecks; ++i) {
    const double s = static_cast<double>(i) / kRetreatChecks;
    Eigen::Isometry3d waypoint = from;
    waypoint.translation() += s * (to - from.translation());
    Result<std::vector<double>> next = arm_.inverse(base_T_target * waypoint, q);
    if (!next) return next.status();
    for (std::size_t j = 0; j < q.size(); ++j)
      if (std::abs((*next)[j] - q[j]) > kMaxCheckStep)
        return numericalFailure("joint '{}' jumps by {:.2f} rad between two checked poses",
                                arm_.joints()[j].name, (*next)[j] - q[j]);
    q = std::move(next).value();
  }
  return q;
}

double ArmSimulator::jointMoveDuration(const std::vector<double>& from,
                                       const std::vector<double>& to) const {
  // The cosine profile peaks at pi/2 times the mean speed: the fastest joint at transit_rate.
  return std::max(0.5 * M_PI * largestTurn(from, to) / spec_.paths.transit_rate, 10.0 / spec_.rate);
}

Status ArmSimulator::drawPath(const Eigen::Isometry3d& base_T_target) {
  ++path_index_;
  needs_path_ = false;
  Rng rng = Rng::stream(seed_, "arm/collision_path", static_cast<std::uint64_t>(path_index_));
  for (int draw = 0; draw < spec_.paths.max_draws; ++draw) {
    Result<CollisionPath> path = candidatePath(base_T_target, rng);
    if (!path) continue;
    path_ = std::move(path).value();
    startJointMove(ArmPhase::kTransit, path_.start_joints);
    travel_ = 0;
    return Status::ok();
  }
  // From a posture none of the draws could leave (a wrist near a limit, a path abandoned in
  // contact), the arm first goes home and draws again there.
  if (phase_ != ArmPhase::kHoming && q_ != home_) {
    --path_index_;
    return planHoming(base_T_target);
  }
  return numericalFailure(
      "arm: no collision path within {} draws (path {}): no surface of '{}' within {} m of the "
      "reach centre that faces the arm, has a clear approach and is reachable; expected the "
      "target within the arm's reach",
      spec_.paths.max_draws, path_index_, target_.name, spec_.paths.reach);
}

/// True when the tip moving from `from` to `to` never comes closer to the surface than it
/// starts, nor closer than `clearance` once it is that far: a retreat that may start in contact
/// but only leaves it.
bool ArmSimulator::movesAway(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                             double clearance) const {
  auto distance = [&](const Eigen::Vector3d& p) {
    const SurfacePoint s = caster_->closestPoint(p, clearance);
    return s.found ? s.distance : clearance;
  };
  double floor = distance(from);
  const int steps = std::max(1, static_cast<int>(std::ceil((to - from).norm() / 0.002)));
  for (int i = 1; i <= steps; ++i) {
    const double d = distance(from + (to - from) * (static_cast<double>(i) / steps));
    if (d < floor) return false;
    floor = std::min(std::max(floor, d), clearance);
  }
  return true;
}

bool ArmSimulator::jointMoveClear(const Eigen::Isometry3d& base_T_target,
                                  const std::vector<double>& from, const std::vector<double>& to,
                                  double clearance) const {
  const Eigen::Isometry3d target_T_base = base_T_target.inverse();
  const int steps =
      std::max(1, static_cast<int>(std::ceil(largestTurn(from, to) / kJointCheckStep)));
  std::vector<double> q(from.size());
  for (int k = 0; k <= steps; ++k) {
    const double s = static_cast<double>(k) / steps;
    for (std::size_t i = 0; i < q.size(); ++i) q[i] = from[i] + s * (to[i] - from[i]);
    const Eigen::Vector3d tip = target_T_base * arm_.forward(q).translation();
    if (caster_->closestPoint(tip, tip_radius_ + clearance).found) return false;
  }
  return true;
}

void ArmSimulator::startJointMove(ArmPhase phase, const std::vector<double>& to) {
  phase_ = phase;
  phase_time_ = 0;
  move_from_ = q_;
  move_to_ = to;
  transit_duration_ = jointMoveDuration(move_from_, move_to_);
}

Status ArmSimulator::planHoming(const Eigen::Isometry3d& base_T_target) {
  const Eigen::Isometry3d& from = transit_from_;
  // Back along the probe: the tool's z points from the sensor to the tip.
  const Eigen::Vector3d back = -from.linear().col(2);
  const double clearance = tip_radius_ + kTransitClearance;
  for (const double distance : kRetreats) {
    Eigen::Isometry3d to = from;
    to.translation() += distance * back;
    if (!movesAway(from.translation(), to.translation(), clearance)) continue;
    Result<std::vector<double>> q = reachAlong(base_T_target, from, to.translation());
    if (!q || !jointMoveClear(base_T_target, *q, home_, spec_.paths.homing_clearance)) continue;
    retreat_to_ = to;
    phase_ = ArmPhase::kRetreat;
    phase_time_ = 0;
    transit_duration_ = std::max(distance / spec_.paths.transit_speed, 10.0 / spec_.rate);
    return Status::ok();
  }
  return numericalFailure(
      "arm: no way home clear of '{}' (path {}): no retreat of up to {} m along the tool's axis "
      "reachable and leading to a joint-space motion home that keeps {} m from the target; "
      "expected the target farther from the arm's home posture",
      target_.name, path_index_ + 1, kRetreats[std::size(kRetreats) - 1],
      spec_.paths.homing_clearance);
}

Eigen::Isometry3d ArmSimulator::command() {
  const double dt = 1.0 / spec_.rate;
  const CollisionPathSpec& p = spec_.paths;
  phase_time_ += dt;
  switch (phase_) {
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
    case ArmPhase::kRetreat: {
      Eigen::Isometry3d pose = transit_from_;
      pose.translation() += cosineProfile(phase_time_ / transit_duration_) *
                            (retreat_to_.translation() - transit_from_.translation());
      if (phase_time_ >= transit_duration_) startJointMove(ArmPhase::kHoming, home_);
      return pose;
    }
    case ArmPhase::kTransit:
    case ArmPhase::kHoming:
      break;  // in joint space: jointMove()
  }
  return tipPose(path_.start - travel_ * path_.axis, path_.attitude);
}

Result<std::vector<double>> ArmSimulator::jointMove(const Eigen::Isometry3d& base_T_target) {
  phase_time_ += 1.0 / spec_.rate;
  if (phase_ == ArmPhase::kTransit) {
    // The transit's end follows the target: the path's start solved again at every sample,
    // from the last solution (the target moves a fraction of a millimetre per sample).
    Result<std::vector<double>> goal =
        arm_.inverse(base_T_target * tipPose(path_.start, path_.attitude), move_to_);
    if (!goal) return goal.status();
    move_to_ = std::move(goal).value();
  }
  if (phase_time_ >= transit_duration_) {
    if (phase_ == ArmPhase::kTransit) {
      phase_ = ArmPhase::kApproach;
      phase_time_ = 0;
    } else {
      needs_path_ = true;
    }
    return move_to_;
  }
  const double s = cosineProfile(phase_time_ / transit_duration_);
  std::vector<double> q(q_.size());
  for (std::size_t i = 0; i < q.size(); ++i)
    q[i] = move_from_[i] + s * (move_to_[i] - move_from_[i]);
  return q;
}

}  // namespace cdff::egse
