#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include <Eigen/Core>

#include "PointCloudMotionCompensation.gen.hpp"

namespace cdff::dfn {
namespace {

/// exp(-[w] dt) for the points of one scan: u + a (k x u) + b (k x (k x u)) with k = -w / |w|,
/// a = sin(theta), b = 1 - cos(theta), theta = |w| dt. In float, as the points are.
class ScanRotation {
 public:
  explicit ScanRotation(const Eigen::Vector3d& angular_velocity) {
    rate_ = angular_velocity.norm();
    if (rate_ > 0.0) axis_ = (-angular_velocity / rate_).cast<float>();
  }

  Eigen::Vector3f apply(const Eigen::Vector3f& u, double dt) const {
    if (rate_ == 0.0) return u;
    const double theta = rate_ * dt;
    double sin_angle, one_minus_cos;
    if (std::abs(theta) < 0.1) {
      // The series' next terms are below theta^7/5040 and theta^8/40320: under 2e-11 here.
      const double t2 = theta * theta;
      sin_angle = theta * (1.0 - t2 * (1.0 / 6.0) * (1.0 - t2 * (1.0 / 20.0)));
      one_minus_cos = t2 * 0.5 * (1.0 - t2 * (1.0 / 12.0) * (1.0 - t2 * (1.0 / 30.0)));
    } else {
      sin_angle = std::sin(theta);
      one_minus_cos = 1.0 - std::cos(theta);
    }
    const Eigen::Vector3f k_u = axis_.cross(u);
    return u + static_cast<float>(sin_angle) * k_u +
           static_cast<float>(one_minus_cos) * axis_.cross(k_u);
  }

 private:
  double rate_ = 0.0;
  Eigen::Vector3f axis_ = Eigen::Vector3f::UnitX();
};

}  // namespace

class PointCloudMotionCompensationConstantTwist final
    : public PointCloudMotionCompensationConstantTwistBase {
 protected:
  Status onProcess() override {
    const PointCloud& cloud = *in.cloud;
    CDFF_RETURN_IF_ERROR(cloud.validate("input 'cloud'", /*require_finite=*/false));
    const RigidBodyState& state = *in.state;
    CDFF_RETURN_IF_ERROR(state.validate().withContext("input 'state'"));
    if (!state.pose.parent_frame.empty() && !cloud.frame_id.empty() &&
        state.pose.parent_frame != cloud.frame_id)
      return invalidInput(
          "input 'state' is {}_T_{}; expected the target's state in the cloud's frame '{}' "
          "(re-express it with FrameTransformation)",
          state.pose.parent_frame, state.pose.child_frame, cloud.frame_id);
    const double state_age = toSeconds(cloud.stamp - state.pose.stamp);
    if (std::abs(state_age) > params_.max_state_age)
      return invalidInput(
          "input 'state' is stamped {:.6f} s from the cloud (state {} us, cloud {} us); expected "
          "at most max_state_age = {} s",
          state_age, state.pose.stamp, cloud.stamp, params_.max_state_age);
    const std::int64_t max_offset_us = std::llround(params_.max_time_offset * 1e6);
    for (std::size_t i = 0; i < cloud.time_offset_us.size(); ++i)
      if (std::abs(static_cast<std::int64_t>(cloud.time_offset_us[i])) > max_offset_us)
        return invalidInput(
            "input 'cloud': point {} has time offset {} us; expected at most max_time_offset "
            "= {} s from the stamp",
            i, cloud.time_offset_us[i], params_.max_time_offset);

    // A twist known worse than this would move the points by about as much as it corrects
    // (an acquiring filter's twist is its prior, or the transient of pulling in its attitude).
    const double linear_sigma = std::sqrt(state.covariance.block<3, 3>(6, 6).trace());
    const double angular_sigma = std::sqrt(state.covariance.block<3, 3>(9, 9).trace());
    const bool use_linear = linear_sigma <= params_.max_linear_velocity_sigma;
    const bool use_angular = angular_sigma <= params_.max_angular_velocity_sigma;
    out.linear_compensated.set(use_linear);
    out.angular_compensated.set(use_angular);

    PointCloud result = cloud;
    if (cloud.time_offset_us.empty() || (!use_linear && !use_angular)) {
      out.compensated.set(std::move(result));
      out.max_correction.set(0.0);
      return Status::ok();
    }
    const Eigen::Vector3d velocity =
        use_linear ? state.twist.linear : Eigen::Vector3d::Zero().eval();
    const Eigen::Vector3d angular_velocity =
        use_angular ? state.twist.angular : Eigen::Vector3d::Zero().eval();
    const Eigen::Vector3f centre =
        (state.pose.translation + state.twist.linear * state_age).cast<float>();
    const Eigen::Vector3f velocity_f = velocity.cast<float>();
    const ScanRotation back(angular_velocity);
    std::vector<Point4f> points, normals;
    points.reserve(cloud.size());
    normals.reserve(cloud.normals.size());
    float max_correction_sq = 0.0f;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const double dt = 1e-6 * cloud.time_offset_us[i];
      const Point4f& p = cloud.points[i];
      const Eigen::Vector3f measured(p.x, p.y, p.z);
      const Eigen::Vector3f moved =
          centre + back.apply(measured - centre - velocity_f * static_cast<float>(dt), dt);
      points.emplace_back(moved.x(), moved.y(), moved.z());
      // NaN comparisons are false: a non-finite point stays so and does not count.
      max_correction_sq = std::max(max_correction_sq, (moved - measured).squaredNorm());
      if (!cloud.normals.empty()) {
        const Point4f& n = cloud.normals[i];
        const Eigen::Vector3f turned = back.apply(Eigen::Vector3f(n.x, n.y, n.z), dt);
        normals.emplace_back(turned.x(), turned.y(), turned.z());
      }
    }
    result.points = Buffer<Point4f>::fromVector(std::move(points));
    if (!cloud.normals.empty()) result.normals = Buffer<Point4f>::fromVector(std::move(normals));
    result.time_offset_us =
        Buffer<std::int32_t>::fromVector(std::vector<std::int32_t>(cloud.size(), 0));
    out.compensated.set(std::move(result));
    out.max_correction.set(std::sqrt(static_cast<double>(max_correction_sq)));
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(PointCloudMotionCompensationConstantTwist);

}  // namespace cdff::dfn
