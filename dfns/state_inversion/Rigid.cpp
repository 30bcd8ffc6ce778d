#include "StateInversion.gen.hpp"
#include "cdff/types/geometry.hpp"

namespace cdff::dfn {

namespace {

/// d(b_T_a, twist of a in b) / d(a_T_b, twist of b in a): rows [dq, dphi, du, dOmega], columns
/// [dp, dtheta, dv, domega], all perturbations in their state's parent frame (left ones for the
/// attitudes). With q = -R^T p, u = R^T (w x p - v), Omega = -R^T w and R' = exp(dtheta) R.
Matrix12d inversionJacobian(const Eigen::Matrix3d& r, const Eigen::Vector3d& p,
                            const Eigen::Vector3d& v, const Eigen::Vector3d& w) {
  const Eigen::Matrix3d rt = r.transpose();
  const Eigen::Vector3d moving = w.cross(p) - v;
  Matrix12d j = Matrix12d::Zero();
  j.block<3, 3>(0, 0) = -rt;
  j.block<3, 3>(0, 3) = -rt * skew(p);
  j.block<3, 3>(3, 3) = -rt;
  j.block<3, 3>(6, 0) = rt * skew(w);
  j.block<3, 3>(6, 3) = rt * skew(moving);
  j.block<3, 3>(6, 6) = -rt;
  j.block<3, 3>(6, 9) = -rt * skew(p);
  j.block<3, 3>(9, 3) = -rt * skew(w);
  j.block<3, 3>(9, 9) = -rt;
  return j;
}

}  // namespace

class StateInversionRigid final : public StateInversionRigidBase {
 protected:
  Status onProcess() override {
    const RigidBodyState& s = *in.state;
    CDFF_RETURN_IF_ERROR(s.validate().withContext("input 'state'"));
    const Eigen::Matrix3d r = s.pose.rotation.toRotationMatrix();
    const Eigen::Vector3d& p = s.pose.translation;
    const Eigen::Vector3d& v = s.twist.linear;
    const Eigen::Vector3d& w = s.twist.angular;
    RigidBodyState inverse;
    inverse.pose.stamp = s.pose.stamp;
    inverse.pose.parent_frame = s.pose.child_frame;
    inverse.pose.child_frame =
        params_.child_frame.empty() ? s.pose.parent_frame : params_.child_frame;
    inverse.pose.rotation = s.pose.rotation.conjugate();
    inverse.pose.translation = -(r.transpose() * p);
    inverse.twist.linear = r.transpose() * (w.cross(p) - v);
    inverse.twist.angular = -(r.transpose() * w);
    const Matrix12d j = inversionJacobian(r, p, v, w);
    inverse.covariance = j * s.covariance * j.transpose();
    if (params_.unobserved_attitude_sigma > 0) {
      const double attitude = params_.unobserved_attitude_sigma;      // rad (degrees in YAML)
      const double rate = params_.unobserved_angular_velocity_sigma;  // rad/s
      for (int block : {3, 9}) {
        inverse.covariance.middleRows<3>(block).setZero();
        inverse.covariance.middleCols<3>(block).setZero();
      }
      inverse.covariance.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * attitude * attitude;
      inverse.covariance.block<3, 3>(9, 9) = Eigen::Matrix3d::Identity() * rate * rate;
    }
    inverse.covariance = 0.5 * (inverse.covariance + inverse.covariance.transpose());
    out.state.set(std::move(inverse));
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(StateInversionRigid);

}  // namespace cdff::dfn
