#include "cdff/egse/world.hpp"

namespace cdff::egse {

World::World(const Orbit& orbit, std::unique_ptr<Translation> servicer_translation,
             std::unique_ptr<Attitude> servicer_attitude, std::unique_ptr<Attitude> target_attitude,
             const Sun& sun)
    : orbit_(orbit),
      servicer_translation_(std::move(servicer_translation)),
      servicer_attitude_(std::move(servicer_attitude)),
      target_attitude_(std::move(target_attitude)),
      sun_(sun) {
  sun_.direction.normalize();
}

BodyState World::servicer(double t) const {
  const TranslationState tr = servicer_translation_->at(t);
  const AttitudeState at = servicer_attitude_->at(t);
  BodyState s;
  s.lvlh_T_body.linear() = at.lvlh_R_body.toRotationMatrix();
  s.lvlh_T_body.translation() = tr.position;
  s.velocity = tr.velocity;
  s.acceleration = tr.acceleration;
  s.control_acceleration = tr.acceleration - orbit_.naturalAcceleration(tr.position, tr.velocity);
  s.angular_velocity = at.angular_velocity;
  s.angular_acceleration = at.angular_acceleration;
  return s;
}

BodyState World::target(double t) const {
  const AttitudeState at = target_attitude_->at(t);
  BodyState s;
  s.lvlh_T_body.linear() = at.lvlh_R_body.toRotationMatrix();
  s.angular_velocity = at.angular_velocity;
  s.angular_acceleration = at.angular_acceleration;
  return s;
}

Eigen::Isometry3d World::servicerTtarget(double t) const {
  return servicer(t).lvlh_T_body.inverse() * target(t).lvlh_T_body;
}

Twist World::targetTwistInServicer(double t) const {
  constexpr double h = 1e-4;
  const Eigen::Isometry3d a = servicerTtarget(t - h), b = servicerTtarget(t + h);
  Twist twist;
  twist.linear = (b.translation() - a.translation()) / (2 * h);
  // Angular velocity of the target relative to the servicer in servicer axes:
  // R(t+h) R(t-h)^T = exp([w] 2h).
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  twist.angular = logSO3((qb * qa.conjugate()).normalized()) / (2 * h);
  return twist;
}

Eigen::Vector3d World::sunDirection(double t) const {
  if (!sun_.inertial) return sun_.direction;
  return orbit_.eciRotationLvlh(t).transpose() * sun_.direction;
}

bool World::inEclipse(double t) const {
  if (!orbit_.enabled) return false;
  const Eigen::Vector3d s = sunDirection(t);
  const Eigen::Vector3d p = -orbit_.earthCentreLvlh();  // target relative to the Earth's centre
  const double along = p.dot(s);
  return along < 0 && (p - along * s).norm() < kEarthRadius;
}

}  // namespace cdff::egse
