#include <cmath>
#include <limits>
#include <optional>
#include <tuple>

#include <fmt/ranges.h>
#include <Eigen/Cholesky>

#include "EstimationFilter.gen.hpp"

namespace cdff::dfn {

namespace {

using Matrix12x6d = Eigen::Matrix<double, 12, 6>;
using Vector12d = Eigen::Matrix<double, 12, 1>;

// Error-state layout (docs/conventions.md): [dt, dtheta, dv, domega], perturbations in the parent
// frame: t = t_hat + dt, R = exp(dtheta) R_hat, v = v_hat + dv, w = w_hat + dw.
constexpr int kPos = 0, kRot = 3, kVel = 6, kAng = 9;

bool isPositiveDefinite(const Eigen::MatrixXd& m) {
  Eigen::LLT<Eigen::MatrixXd> llt(m);
  return llt.info() == Eigen::Success;
}

}  // namespace

class EstimationFilterExtendedKalman final : public EstimationFilterExtendedKalmanBase {
 protected:
  Status onConfigure() override {
    estimate_.reset();  // new parameters start a new estimate
    return Status::ok();
  }

  Status onProcess() override {
    const bool has_initial = in.initial_state.isFresh();
    const bool has_time = in.time.isFresh();
    const bool has_measurement = in.pose_measurement.isFresh();
    if (!has_initial && !has_time && !has_measurement)
      return invalidInput(
          "no fresh input; expected a new 'time' (predict), 'pose_measurement' (correct) or "
          "'initial_state' (reset)");

    // Work on a copy so that a failed call leaves the filter as it was.
    std::optional<RigidBodyState> next = estimate_;
    if (has_initial) {
      const RigidBodyState& initial = *in.initial_state;
      CDFF_RETURN_IF_ERROR(initial.validate());
      if (!isPositiveDefinite(initial.covariance))
        return invalidInput(
            "input 'initial_state' covariance is not positive definite; expected "
            "the uncertainty of every one of the 12 state components");
      next = initial;
    }
    if (has_time) {
      if (!next)
        return invalidInput(
            "cannot predict to t = {} us: the filter is not initialised; "
            "expected an 'initial_state' or a 'pose_measurement' first",
            *in.time);
      CDFF_RETURN_IF_ERROR(predict(*next, *in.time, "time"));
    }
    double nis = std::numeric_limits<double>::quiet_NaN();
    bool accepted = false;
    if (has_measurement) {
      const PoseWithCovariance& z = *in.pose_measurement;
      CDFF_RETURN_IF_ERROR(z.validate());
      Result<Matrix6d> noise = measurementNoise(z);
      if (!noise) return noise.status();
      if (!next) {
        next = initialiseFrom(z, *noise);
        accepted = true;
      } else {
        CDFF_RETURN_IF_ERROR(checkFrames(*next, z.pose));
        CDFF_RETURN_IF_ERROR(predict(*next, z.pose.stamp, "pose_measurement"));
        RigidBodyState corrected = *next;
        Result<double> fused = correct(corrected, z.pose, *noise);
        if (!fused) return fused.status();
        nis = *fused;
        accepted = params_.innovation_gate == 0.0 || nis <= params_.innovation_gate;
        if (accepted)
          next = corrected;
        else  // gated out: the state is only predicted to the measurement's time
          warn(fmt::format("measurement at t = {} us gated out: NIS {:.3g} > {:.3g}", z.pose.stamp,
                           nis, params_.innovation_gate));
      }
    }
    estimate_ = next;
    out.state.set(*estimate_);
    out.measurement_accepted.set(accepted);
    out.innovation_nis.set(nis);
    return Status::ok();
  }

 private:
  Status checkFrames(const RigidBodyState& state, const Transform& measured) const {
    if (measured.parent_frame != state.pose.parent_frame ||
        measured.child_frame != state.pose.child_frame)
      return invalidInput(
          "input 'pose_measurement' is {}_T_{}; expected {}_T_{}, the frames the "
          "filter was initialised with",
          measured.parent_frame, measured.child_frame, state.pose.parent_frame,
          state.pose.child_frame);
    return Status::ok();
  }

  Result<Matrix6d> measurementNoise(const PoseWithCovariance& z) const {
    if (params_.use_measurement_covariance && !z.covariance.isZero(0.0)) {
      if (!isPositiveDefinite(z.covariance))
        return invalidInput(
            "input 'pose_measurement' covariance is not positive definite "
            "(diagonal {}); expected a positive-definite 6x6 matrix or all zeros",
            fmt::join(z.covariance.diagonal(), ", "));
      return Matrix6d(z.covariance);
    }
    Matrix6d r = Matrix6d::Zero();
    r.diagonal() << Eigen::Vector3d::Constant(params_.position_sigma * params_.position_sigma),
        Eigen::Vector3d::Constant(params_.attitude_sigma * params_.attitude_sigma);
    return r;
  }

  RigidBodyState initialiseFrom(const PoseWithCovariance& z, const Matrix6d& noise) const {
    RigidBodyState s;
    s.pose = z.pose;
    s.covariance.setZero();
    s.covariance.topLeftCorner<6, 6>() = noise;
    const double sv = params_.initial_linear_velocity_sigma;
    const double sw = params_.initial_angular_velocity_sigma;
    s.covariance.block<3, 3>(kVel, kVel) = Eigen::Matrix3d::Identity() * sv * sv;
    s.covariance.block<3, 3>(kAng, kAng) = Eigen::Matrix3d::Identity() * sw * sw;
    return s;
  }

  Status predict(RigidBodyState& s, Timestamp to, const char* input) const {
    const Timestamp from = s.pose.stamp;
    if (to < from)
      return invalidInput(
          "input '{}' at t = {} us is older than the filter's time {} us; "
          "expected non-decreasing timestamps",
          input, to, from);
    const double dt = toSeconds(to - from);
    if (params_.max_prediction_interval > 0 && dt > params_.max_prediction_interval)
      return invalidInput(
          "input '{}' at t = {} us is {:.3f} s after the filter's time; expected "
          "at most max_prediction_interval = {} s (re-initialise after a gap)",
          input, to, dt, params_.max_prediction_interval);
    if (dt == 0.0) return Status::ok();

    const Eigen::Vector3d rotation_step = s.twist.angular * dt;
    const Eigen::Quaterniond step = expSO3(rotation_step);
    s.pose.translation += s.twist.linear * dt;
    s.pose.rotation = (step * s.pose.rotation).normalized();
    s.pose.stamp = to;

    Matrix12d f = Matrix12d::Identity();
    f.block<3, 3>(kPos, kVel) = Eigen::Matrix3d::Identity() * dt;
    f.block<3, 3>(kRot, kRot) = step.toRotationMatrix();
    f.block<3, 3>(kRot, kAng) = leftJacobianSO3(rotation_step) * dt;

    // White acceleration noise integrated over dt (the classic discrete white-noise jerk model).
    Matrix12d q = Matrix12d::Zero();
    const Eigen::Matrix3d i3 = Eigen::Matrix3d::Identity();
    const double dt2 = dt * dt, dt3 = dt2 * dt;
    for (const auto& [pos, vel, psd] : {std::tuple{kPos, kVel, params_.linear_acceleration_psd},
                                        std::tuple{kRot, kAng, params_.angular_acceleration_psd}}) {
      q.block<3, 3>(pos, pos) = i3 * psd * dt3 / 3.0;
      q.block<3, 3>(pos, vel) = i3 * psd * dt2 / 2.0;
      q.block<3, 3>(vel, pos) = i3 * psd * dt2 / 2.0;
      q.block<3, 3>(vel, vel) = i3 * psd * dt;
    }
    s.covariance = f * s.covariance * f.transpose() + q;
    s.covariance = 0.5 * (s.covariance + s.covariance.transpose());
    return Status::ok();
  }

  /// Fuses a pose measurement into `s`; returns its normalised innovation squared.
  Result<double> correct(RigidBodyState& s, const Transform& measured,
                         const Matrix6d& noise) const {
    Vector6d residual;
    residual.head<3>() = measured.translation - s.pose.translation;
    residual.tail<3>() = logSO3(measured.rotation * s.pose.rotation.conjugate());

    // H = [I6 0]: the measurement observes the pose error directly.
    const Matrix6d innovation_cov = s.covariance.topLeftCorner<6, 6>() + noise;
    Eigen::LLT<Matrix6d> llt(innovation_cov);
    if (llt.info() != Eigen::Success)
      return numericalFailure(
          "innovation covariance is not positive definite (diagonal {}); "
          "the filter covariance has degenerated, re-initialise",
          fmt::join(innovation_cov.diagonal(), ", "));
    const double nis = residual.dot(llt.solve(residual));
    const Matrix12x6d gain = llt.solve(s.covariance.leftCols<6>().transpose()).transpose();
    const Vector12d correction = gain * residual;

    s.pose.translation += correction.segment<3>(kPos);
    s.pose.rotation = (expSO3(correction.segment<3>(kRot)) * s.pose.rotation).normalized();
    s.twist.linear += correction.segment<3>(kVel);
    s.twist.angular += correction.segment<3>(kAng);

    // Joseph form: stays symmetric positive semi-definite despite rounding.
    Matrix12d i_kh = Matrix12d::Identity();
    i_kh.leftCols<6>() -= gain;
    s.covariance = i_kh * s.covariance * i_kh.transpose() + gain * noise * gain.transpose();
    s.covariance = 0.5 * (s.covariance + s.covariance.transpose());
    return nis;
  }

  std::optional<RigidBodyState> estimate_;  // none until initialised
};

CDFF_REGISTER_DFI(EstimationFilterExtendedKalman);

}  // namespace cdff::dfn
