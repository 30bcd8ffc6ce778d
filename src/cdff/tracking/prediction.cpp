#include "cdff/tracking/prediction.hpp"

#include <algorithm>

namespace cdff::tracking {

PoseWithCovariance predictPose(const RigidBodyState& state, Timestamp to) {
  PoseWithCovariance p = state.poseWithCovariance();
  if (to > state.pose.stamp) {
    const double dt = toSeconds(to - state.pose.stamp);
    p.pose.translation += state.twist.linear * dt;
    p.pose.rotation = (expSO3(state.twist.angular * dt) * p.pose.rotation).normalized();
    p.pose.stamp = to;
  }
  return p;
}

Matrix6d carriedPoseCovariance(const RigidBodyState& state, Timestamp to) {
  const double dt = std::max(0.0, toSeconds(to - state.pose.stamp));
  Eigen::Matrix<double, 6, 12> f;
  f << Matrix6d::Identity(), dt * Matrix6d::Identity();
  Matrix6d c;
  c = f * state.covariance * f.transpose();
  return c;
}

}  // namespace cdff::tracking
