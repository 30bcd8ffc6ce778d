#include "cdff/tracking/imu_thrust.hpp"

#include <algorithm>
#include <cmath>

namespace cdff::tracking {

Status ImuHistory::add(const ImuSample& sample, const Transform* mount) {
  if (Status s = sample.validate(); !s)
    return invalidInput("input 'imu' at t = {} us: {}; expected finite values", sample.stamp,
                        s.message());
  if (!mount)
    return invalidInput(
        "input 'imu' at t = {} us came before 'imu_mount'; expected the IMU's mounting "
        "(servicer_T_{}) first",
        sample.stamp, sample.frame_id);
  CDFF_RETURN_IF_ERROR(mount->validate().withContext("input 'imu_mount'"));
  if (mount->child_frame != sample.frame_id)
    return invalidInput("input 'imu_mount' is {}_T_{}; expected the mounting of the IMU '{}'",
                        mount->parent_frame, mount->child_frame, sample.frame_id);
  if (!samples_.empty() && sample.stamp <= samples_.back().stamp)
    return invalidInput(
        "input 'imu' at t = {} us is not newer than the last sample (t = {} us); expected "
        "samples in time order",
        sample.stamp, samples_.back().stamp);
  samples_.push_back({sample.stamp, mount->rotation * sample.linear_acceleration});
  if (samples_.size() > 2048) samples_.pop_front();
  return Status::ok();
}

MeasuredThrust ImuHistory::between(Timestamp t0, Timestamp t1, const AttitudeHistory& attitudes,
                                   double tolerance, const AccelerometerModel& model) const {
  MeasuredThrust thrust;
  thrust.model = model;
  if (samples_.empty() || t1 <= t0) return thrust;
  // The last sample at or before t0 holds into the interval.
  auto it = std::upper_bound(samples_.begin(), samples_.end(), t0,
                             [](Timestamp t, const Sample& s) { return t < s.stamp; });
  if (it != samples_.begin()) --it;
  for (; it != samples_.end() && it->stamp < t1; ++it) {
    const auto next = std::next(it);
    Timestamp to = it->stamp + kMaxHold;
    if (next != samples_.end()) to = std::min(to, next->stamp);
    const Timestamp from = std::max(it->stamp, t0);
    to = std::min(to, t1);
    if (to <= from) continue;
    auto attitude = attitudes.at(it->stamp, tolerance);
    if (!attitude) {
      ++thrust.samples_without_attitude;
      continue;
    }
    thrust.spans.push_back({from, to, it->specific_force, attitude->first.toRotationMatrix()});
  }
  return thrust;
}

namespace {

/// Gamma(dt) = integral over [0, dt] of Phi(s)'s velocity columns: the response of [p; v] to a
/// constant acceleration held dt seconds (3-point Gauss-Legendre).
Eigen::Matrix<double, 6, 3> cwInputResponse(double n, double dt) {
  static const double kNode = std::sqrt(0.6);
  Eigen::Matrix<double, 6, 3> g = Eigen::Matrix<double, 6, 3>::Zero();
  for (const auto& [xi, w] :
       {std::pair{-kNode, 5.0 / 9}, std::pair{0.0, 8.0 / 9}, std::pair{kNode, 5.0 / 9}})
    g += w * cwTransition(n, 0.5 * dt * (1 + xi)).rightCols<3>();
  return 0.5 * dt * g;
}

/// The covariance a bias random walk of psd k2 ((m/s^2)^2/s) adds over dt to [p, v, b], the
/// bias acting on v through r (lvlh_R_servicer): b = integral of w, v' = r b, p' = v.
Matrix9d biasWalkNoise(double k2, double dt, const Eigen::Matrix3d& r) {
  Matrix9d q = Matrix9d::Zero();
  const Eigen::Matrix3d i = Eigen::Matrix3d::Identity();
  const double t2 = dt * dt, t3 = t2 * dt;
  q.block<3, 3>(0, 0) = k2 * t3 * t2 / 20 * i;
  q.block<3, 3>(0, 3) = q.block<3, 3>(3, 0) = k2 * t2 * t2 / 8 * i;
  q.block<3, 3>(3, 3) = k2 * t3 / 3 * i;
  q.block<3, 3>(0, 6) = k2 * t3 / 6 * r;
  q.block<3, 3>(3, 6) = k2 * t2 / 2 * r;
  q.block<3, 3>(6, 0) = q.block<3, 3>(0, 6).transpose();
  q.block<3, 3>(6, 3) = q.block<3, 3>(3, 6).transpose();
  q.block<3, 3>(6, 6) = k2 * dt * i;
  return q;
}

}  // namespace

Status propagate(RelativeState& s, Timestamp stamp, double mean_motion, double psd,
                 const MeasuredThrust& thrust) {
  const double k2 = thrust.model.bias_random_walk * thrust.model.bias_random_walk;
  if (thrust.spans.empty()) return propagate(s, stamp, mean_motion, psd, k2);
  if (stamp < s.stamp)
    return invalidInput("cannot propagate the relative state back from t = {} us to t = {} us",
                        s.stamp, stamp);
  if (!s.hasBias()) {  // the first measured thrust: its bias is unknown, within the turn-on's
    s.x.tail<3>().setZero();
    s.covariance.rightCols<3>().setZero();
    s.covariance.bottomRows<3>().setZero();
    s.covariance.bottomRightCorner<3, 3>() =
        std::max(thrust.model.bias_sigma * thrust.model.bias_sigma, 1e-12) *
        Eigen::Matrix3d::Identity();
  }
  Vector6d x = s.x.head<6>();
  const Eigen::Vector3d b = s.x.tail<3>();
  Eigen::Matrix<double, 6, 3> j = Eigen::Matrix<double, 6, 3>::Zero();  // d x / d b
  Timestamp t = s.stamp;
  double measured = 0, cached_dt = -1;
  Matrix6d phi;
  Eigen::Matrix<double, 6, 3> gamma;
  const Eigen::Matrix3d* last_r = &thrust.spans.back().lvlh_R_servicer;
  auto step = [&](double dt) {
    if (dt != cached_dt) {  // samples come at a steady rate: most steps reuse the last
      phi = cwTransition(mean_motion, dt);
      gamma = cwInputResponse(mean_motion, dt);
      cached_dt = dt;
    }
  };
  for (const ThrustSpan& span : thrust.spans) {
    const Timestamp from = std::clamp(span.from, t, stamp), to = std::clamp(span.to, from, stamp);
    if (from > t) {  // unmeasured: coast
      step(static_cast<double>(from - t) * 1e-6);
      x = phi * x;
      j = phi * j;
    }
    if (to > from) {
      const double dt = static_cast<double>(to - from) * 1e-6;
      step(dt);
      const Eigen::Matrix3d& r = span.lvlh_R_servicer;
      x = phi * x + gamma * (r * (b - span.specific_force));
      j = phi * j + gamma * r;
      measured += dt;
    }
    t = to;
  }
  if (stamp > t) {
    step(static_cast<double>(stamp - t) * 1e-6);
    x = phi * x;
    j = phi * j;
  }
  const double dt = static_cast<double>(stamp - s.stamp) * 1e-6;
  Matrix9d f = Matrix9d::Identity();
  f.topLeftCorner<6, 6>() = cwTransition(mean_motion, dt);
  f.topRightCorner<6, 3>() = j;
  Matrix9d p = f * s.covariance * f.transpose() + biasWalkNoise(k2, dt, *last_r);
  const double n2 = thrust.model.noise_density * thrust.model.noise_density;
  p.topLeftCorner<6, 6>() += whiteAccelerationNoise(psd, dt) + whiteAccelerationNoise(n2, measured);
  s.covariance = 0.5 * (p + p.transpose());
  s.x.head<6>() = x;
  s.stamp = stamp;
  return Status::ok();
}

}  // namespace cdff::tracking
