#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <tuple>

#include <fmt/ranges.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "EstimationFilter.gen.hpp"
#include "cdff/types/statistics.hpp"

namespace cdff::dfn {

namespace {

constexpr int kN = 18;
using Matrix18d = Eigen::Matrix<double, kN, kN>;
using Vector18d = Eigen::Matrix<double, kN, 1>;

// Error-state layout (docs/conventions.md): [dt, dtheta, dv, domega] of the relative state a_T_b,
// perturbations in the parent frame a: t = t_hat + dt, R = exp(dtheta) R_hat, v = v_hat + dv,
// w = w_hat + dw; then, once an AHRS sample has added them, [dtheta_i, domega_i] of the target's
// inertial attitude inertial_R_b = exp(dtheta_i) R_hat and inertial angular velocity (inertial
// frame). Without the inertial part its rows and columns of the covariance stay zero.
constexpr int kPos = 0, kRot = 3, kVel = 6, kAng = 9, kTargetRot = 12, kTargetAng = 15;

bool isPositiveDefinite(const Eigen::MatrixXd& m) {
  Eigen::LLT<Eigen::MatrixXd> llt(m);
  return llt.info() == Eigen::Success;
}

struct Estimate {
  RigidBodyState state;  // its covariance is the top-left block of `covariance`, on output
  Matrix18d covariance = Matrix18d::Zero();
  bool has_inertial = false;
  std::string inertial_frame;
  Eigen::Quaterniond target_attitude = Eigen::Quaterniond::Identity();  // inertial_R_b
  Eigen::Vector3d target_rate = Eigen::Vector3d::Zero();                // rad/s, inertial frame
  bool acquiring = false;  // initialised by an initial state, no pose fused since
  Timestamp last_fix = 0;  // stamp of the last fused pose measurement (or of the initial state)
  int rejections = 0;      // pose measurements gated out since the last fused one

  static Estimate from(const RigidBodyState& s) {
    Estimate e;
    e.state = s;
    e.covariance.topLeftCorner<12, 12>() = s.covariance;
    e.last_fix = s.pose.stamp;
    return e;
  }
  RigidBodyState output() const {
    RigidBodyState s = state;
    s.covariance = covariance.topLeftCorner<12, 12>();
    return s;
  }
};

/// What one call's measurements did: the last one's normalised innovation squared, and whether
/// any changed the estimate.
struct Fusion {
  double nis = std::numeric_limits<double>::quiet_NaN();
  bool accepted = false;
};

}  // namespace

class EstimationFilterExtendedKalman final : public EstimationFilterExtendedKalmanBase {
 protected:
  Status onConfigure() override {
    estimate_.reset();  // new parameters start a new estimate
    // The 3-dof gate at the probability that innovation_gate has for 6 dof.
    position_gate_ = params_.innovation_gate == 0.0
                         ? 0.0
                         : chiSquareQuantile(chiSquareCdf(params_.innovation_gate, 6), 3);
    if (!std::isfinite(position_gate_))  // innovation_gate beyond double precision: accept all
      position_gate_ = 0.0;
    return Status::ok();
  }

  Status onProcess() override {
    const bool has_initial = in.initial_state.isFresh();
    const bool has_reference = in.reference_state.isFresh();
    const bool has_time = in.time.isFresh();
    const bool has_position = in.position_measurement.isFresh();
    const bool has_measurement = in.pose_measurement.isFresh();
    const bool has_attitude = in.attitude_measurement.isFresh();
    if (!has_initial && !has_reference && !has_time && !has_position && !has_measurement &&
        !has_attitude)
      return invalidInput(
          "no fresh input; expected a new 'time' (predict), 'position_measurement', "
          "'pose_measurement' or 'attitude_measurement' (correct), 'initial_state' (reset) or "
          "'reference_state' (adopt)");

    // Work on a copy so that a failed call leaves the filter as it was.
    std::optional<Estimate> next = estimate_;
    CDFF_RETURN_IF_ERROR(resetAndPredict(next));
    Fusion fusion;
    // A measurement made in the same call as a reset was made from the estimate the reset
    // replaces (a DFPC that re-initialises its filter from a check of the scan the measurement
    // came from): while acquiring it would be taken as the new pose and undo the reset.
    if (has_position && has_initial)
      warn(fmt::format(
          "position measurement at t = {} us not used: it came with an 'initial_state', which "
          "replaces the estimate it was made from",
          in.position_measurement->pose.stamp));
    else if (has_position)
      CDFF_RETURN_IF_ERROR(fusePosition(*in.position_measurement, next, fusion));
    if (has_measurement && has_initial)
      warn(fmt::format(
          "pose measurement at t = {} us not used: it came with an 'initial_state', which "
          "replaces the estimate it was made from",
          in.pose_measurement->pose.stamp));
    else if (has_measurement)
      CDFF_RETURN_IF_ERROR(fusePose(*in.pose_measurement, next, fusion));
    if (has_attitude) {
      const PoseWithCovariance& z = *in.attitude_measurement;
      CDFF_RETURN_IF_ERROR(z.validate().withContext("input 'attitude_measurement'"));
      if (!next) {
        // An AHRS runs before the first pose fix; its samples cannot be used yet.
        warn(fmt::format(
            "attitude measurement at t = {} us ignored: the filter is not initialised (expected "
            "a 'pose_measurement', a 'position_measurement' or an 'initial_state' first)",
            z.pose.stamp));
        return Status::ok();
      }
      CDFF_RETURN_IF_ERROR(fuseAttitude(z, *next, fusion));
    }
    estimate_ = next;
    publish(fusion);
    return Status::ok();
  }

 private:
  /// The reset by a fresh 'initial_state', then the prediction to a fresh 'time'.
  Status resetAndPredict(std::optional<Estimate>& next) {
    if (in.initial_state.isFresh()) {
      const RigidBodyState& initial = *in.initial_state;
      CDFF_RETURN_IF_ERROR(initial.validate());
      if (!isPositiveDefinite(initial.covariance))
        return invalidInput(
            "input 'initial_state' covariance is not positive definite; expected "
            "the uncertainty of every one of the 12 state components");
      next = Estimate::from(initial);
      next->acquiring = true;
    }
    if (in.reference_state.isFresh()) {
      const RigidBodyState& reference = *in.reference_state;
      if (next && reference.pose.stamp < next->state.pose.stamp)
        warn(fmt::format(
            "reference state at t = {} us not adopted: the filter's time is already {} us (a "
            "later one replaces it)",
            reference.pose.stamp, next->state.pose.stamp));
      else
        CDFF_RETURN_IF_ERROR(adopt(reference, next));
    }
    if (in.time.isFresh()) {
      if (!next)
        return invalidInput(
            "cannot predict to t = {} us: the filter is not initialised; expected an "
            "'initial_state', a 'pose_measurement' or a 'position_measurement' first",
            *in.time);
      CDFF_RETURN_IF_ERROR(predict(*next, *in.time, "time"));
    }
    return Status::ok();
  }

  /// Another filter's estimate taken as this one's, as a fix (input 'reference_state').
  static Status adopt(const RigidBodyState& reference, std::optional<Estimate>& next) {
    CDFF_RETURN_IF_ERROR(reference.validate().withContext("input 'reference_state'"));
    if (!isPositiveDefinite(reference.covariance))
      return invalidInput(
          "input 'reference_state' covariance is not positive definite; expected the "
          "uncertainty of every one of the 12 state components (an unobserved one large)");
    if (next) CDFF_RETURN_IF_ERROR(checkFrames(*next, reference.pose, "reference_state"));
    next = Estimate::from(reference);
    fixed(*next, reference.pose.stamp);
    return Status::ok();
  }

  void publish(const Fusion& fusion) {
    out.state.set(estimate_->output());
    out.pose.set(estimate_->state.pose);
    out.measurement_accepted.set(fusion.accepted);
    out.innovation_nis.set(fusion.nis);
    out.track_state.set(estimate_->acquiring
                            ? (unconfirmed(*estimate_) ? TrackState::kLost : TrackState::kAcquiring)
                        : lost(*estimate_) ? TrackState::kLost
                                           : TrackState::kTracking);
  }

  /// Marks `e` as confirmed by a measurement fused at `stamp` (the track state's fix).
  static void fixed(Estimate& e, Timestamp stamp) {
    e.acquiring = false;
    e.last_fix = stamp;
    e.rejections = 0;
  }

  // A pose measurement: initialises the filter, reacquires, takes the attitude over, or is fused
  // unless gated out.
  Status fusePose(const PoseWithCovariance& z, std::optional<Estimate>& next, Fusion& fusion) {
    CDFF_RETURN_IF_ERROR(z.validate());
    Result<Matrix6d> noise = measurementNoise(z);
    if (!noise) return noise.status();
    if (!next) {
      next = initialiseFrom(z, *noise);
      fusion.accepted = true;
      return Status::ok();
    }
    CDFF_RETURN_IF_ERROR(checkFrames(*next, z.pose, "pose_measurement"));
    CDFF_RETURN_IF_ERROR(predict(*next, z.pose.stamp, "pose_measurement"));
    if (params_.reacquire && (next->acquiring || lost(*next))) {
      reacquire(*next, z, *noise);
      fusion.accepted = true;
      return Status::ok();
    }
    if (attitudeUnobserved(*next)) return takeOverAttitude(z, *noise, *next, fusion);
    Estimate corrected = *next;
    Vector6d residual;
    residual.head<3>() = z.pose.translation - corrected.state.pose.translation;
    residual.tail<3>() = logSO3(z.pose.rotation * corrected.state.pose.rotation.conjugate());
    Eigen::Matrix<double, 6, kN> h = Eigen::Matrix<double, 6, kN>::Zero();
    h.leftCols<6>().setIdentity();
    Result<double> fused = correct<6>(corrected, h, residual, *noise);
    if (!fused) return fused.status();
    fusion.nis = *fused;
    if (params_.innovation_gate == 0.0 || *fused <= params_.innovation_gate) {
      next = corrected;
      fixed(*next, z.pose.stamp);
      fusion.accepted = true;
    } else {  // gated out: the state is only predicted to the measurement's time
      ++next->rejections;
      warn(fmt::format("measurement at t = {} us gated out: NIS {:.3g} > {:.3g}", z.pose.stamp,
                       *fused, params_.innovation_gate));
    }
    return Status::ok();
  }

  // A position measurement: initialises the filter (attitude not observed), reacquires the
  // position, or is fused unless gated out.
  Status fusePosition(const PoseWithCovariance& z, std::optional<Estimate>& next, Fusion& fusion) {
    // Only the translation is used: the rotation (e.g. a placeholder) is not checked.
    CDFF_RETURN_IF_ERROR(
        checkFinite(z.pose.translation, "input 'position_measurement' translation"));
    Result<Eigen::Matrix3d> noise = positionNoise(z);
    if (!noise) return noise.status();
    if (!next) {
      next = initialiseFromPosition(z.pose, *noise);
      fusion.accepted = true;
      return Status::ok();
    }
    CDFF_RETURN_IF_ERROR(checkFrames(*next, z.pose, "position_measurement"));
    CDFF_RETURN_IF_ERROR(predict(*next, z.pose.stamp, "position_measurement"));
    if (params_.reacquire && (next->acquiring || lost(*next))) {
      // The position from the measurement, uncorrelated; attitude and twist as predicted.
      next->state.pose.translation = z.pose.translation;
      next->covariance.middleRows<3>(kPos).setZero();
      next->covariance.middleCols<3>(kPos).setZero();
      next->covariance.block<3, 3>(kPos, kPos) = *noise;
      fixed(*next, z.pose.stamp);
      fusion.accepted = true;
      return Status::ok();
    }
    return correctPosition(z.pose, *noise, *next, fusion);
  }

  /// The 3-dof position correction, gated at position_gate_.
  Status correctPosition(const Transform& z, const Eigen::Matrix3d& noise, Estimate& next,
                         Fusion& fusion) {
    Estimate corrected = next;
    const Eigen::Vector3d residual = z.translation - corrected.state.pose.translation;
    Eigen::Matrix<double, 3, kN> h = Eigen::Matrix<double, 3, kN>::Zero();
    h.block<3, 3>(0, kPos).setIdentity();
    Result<double> fused = correct<3>(corrected, h, residual, noise);
    if (!fused) return fused.status();
    fusion.nis = *fused;
    if (position_gate_ == 0.0 || *fused <= position_gate_) {
      next = corrected;
      fixed(next, z.stamp);
      fusion.accepted = true;
    } else {
      ++next.rejections;
      warn(fmt::format("position at t = {} us gated out: NIS {:.3g} > {:.3g} (3 dof)", z.stamp,
                       *fused, position_gate_));
    }
    return Status::ok();
  }

  /// A pose measurement while the attitude is not observed (attitude_takeover_sigma): its
  /// position is fused as a position measurement and, if accepted, the attitude is taken from it.
  Status takeOverAttitude(const PoseWithCovariance& z, const Matrix6d& noise, Estimate& next,
                          Fusion& fusion) {
    CDFF_RETURN_IF_ERROR(correctPosition(z.pose, noise.topLeftCorner<3, 3>(), next, fusion));
    if (!fusion.accepted) return Status::ok();
    Estimate& e = next;
    e.state.pose.rotation = z.pose.rotation;
    e.state.twist.angular.setZero();
    for (int block : {kRot, kAng}) {
      e.covariance.middleRows<3>(block).setZero();
      e.covariance.middleCols<3>(block).setZero();
    }
    e.covariance.block<3, 3>(kRot, kRot) = noise.bottomRightCorner<3, 3>();
    const double sw = params_.initial_angular_velocity_sigma;
    e.covariance.block<3, 3>(kAng, kAng) = Eigen::Matrix3d::Identity() * sw * sw;
    if (e.has_inertial) {  // tied to the old attitude: added again at the next AHRS sample
      e.has_inertial = false;
      e.covariance.bottomRows<6>().setZero();
      e.covariance.rightCols<6>().setZero();
    }
    return Status::ok();
  }

  /// Whether the attitude's standard deviation (the root of its covariance block's largest
  /// eigenvalue) exceeds attitude_takeover_sigma; the trace bounds it, which spares the
  /// eigenvalues in the usual case.
  bool attitudeUnobserved(const Estimate& e) const {
    const Eigen::Matrix3d p = e.covariance.block<3, 3>(kRot, kRot);
    const double bound = params_.attitude_takeover_sigma * params_.attitude_takeover_sigma;
    if (p.trace() <= bound) return false;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(p, Eigen::EigenvaluesOnly);
    return eig.eigenvalues().maxCoeff() > bound;
  }

  // An attitude measurement of the chaser (an AHRS sample) in an initialised filter: it adds the
  // target's inertial attitude to the state the first time, then is fused unless gated out.
  Status fuseAttitude(const PoseWithCovariance& z, Estimate& next, Fusion& fusion) {
    Result<Eigen::Matrix3d> noise = attitudeNoise(z);
    if (!noise) return noise.status();
    CDFF_RETURN_IF_ERROR(checkAttitudeFrames(next, z.pose));
    CDFF_RETURN_IF_ERROR(predict(next, z.pose.stamp, "attitude_measurement"));
    if (!next.has_inertial) {
      addInertialPart(next, z.pose, *noise);
    } else {
      Estimate corrected = next;
      const Eigen::Quaterniond predicted =
          corrected.target_attitude * corrected.state.pose.rotation.conjugate();  // inertial_R_a
      const Eigen::Vector3d residual = logSO3(z.pose.rotation * predicted.conjugate());
      Eigen::Matrix<double, 3, kN> h = Eigen::Matrix<double, 3, kN>::Zero();
      h.block<3, 3>(0, kRot) = -predicted.toRotationMatrix();
      h.block<3, 3>(0, kTargetRot).setIdentity();
      Result<double> fused = correct<3>(corrected, h, residual, *noise);
      if (!fused) return fused.status();
      fusion.nis = *fused;
      const bool ok =
          params_.attitude_innovation_gate == 0.0 || *fused <= params_.attitude_innovation_gate;
      if (ok) {
        next = corrected;
        fusion.accepted = true;
      } else {
        warn(fmt::format("attitude measurement at t = {} us gated out: NIS {:.3g} > {:.3g}",
                         z.pose.stamp, *fused, params_.attitude_innovation_gate));
      }
    }
    return Status::ok();
  }

  static Status checkFrames(const Estimate& e, const Transform& measured, const char* input) {
    const Transform& pose = e.state.pose;
    if (measured.parent_frame != pose.parent_frame || measured.child_frame != pose.child_frame)
      return invalidInput(
          "input '{}' is {}_T_{}; expected {}_T_{}, the frames the filter was initialised with",
          input, measured.parent_frame, measured.child_frame, pose.parent_frame, pose.child_frame);
    return Status::ok();
  }

  Status checkAttitudeFrames(const Estimate& e, const Transform& measured) const {
    const std::string& chaser = e.state.pose.parent_frame;
    if (measured.child_frame != chaser)
      return invalidInput(
          "input 'attitude_measurement' is {}_T_{}; expected the chaser's attitude "
          "<inertial>_T_{} (its child frame is the filter's parent frame)",
          measured.parent_frame, measured.child_frame, chaser);
    if (e.has_inertial && measured.parent_frame != e.inertial_frame)
      return invalidInput(
          "input 'attitude_measurement' is {}_T_{}; expected {}_T_{}, the inertial frame of the "
          "earlier AHRS samples",
          measured.parent_frame, measured.child_frame, e.inertial_frame, chaser);
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

  /// The position block of a position measurement's covariance (its own, or position_sigma).
  Result<Eigen::Matrix3d> positionNoise(const PoseWithCovariance& z) const {
    const Eigen::Matrix3d block = z.covariance.topLeftCorner<3, 3>();
    if (!block.allFinite())
      return invalidInput(
          "input 'position_measurement' position covariance is non-finite (diagonal {}); "
          "expected a finite positive-definite 3x3 block [0:3, 0:3] or zeros",
          fmt::join(block.diagonal(), ", "));
    if (params_.use_measurement_covariance && !block.isZero(0.0)) {
      if ((block - block.transpose()).cwiseAbs().maxCoeff() > 1e-9 * block.cwiseAbs().maxCoeff() ||
          !isPositiveDefinite(block))
        return invalidInput(
            "input 'position_measurement' position covariance is not symmetric positive "
            "definite (diagonal {}); expected a positive-definite 3x3 block [0:3, 0:3] or zeros",
            fmt::join(block.diagonal(), ", "));
      return Eigen::Matrix3d(block);
    }
    return Eigen::Matrix3d(Eigen::Matrix3d::Identity() * params_.position_sigma *
                           params_.position_sigma);
  }

  Result<Eigen::Matrix3d> attitudeNoise(const PoseWithCovariance& z) const {
    const Eigen::Matrix3d block = z.covariance.block<3, 3>(3, 3);
    if (params_.use_measurement_covariance && !block.isZero(0.0)) {
      if (!isPositiveDefinite(block))
        return invalidInput(
            "input 'attitude_measurement' attitude covariance is not positive definite "
            "(diagonal {}); expected a positive-definite 3x3 block [3:6, 3:6] or zeros",
            fmt::join(block.diagonal(), ", "));
      return Eigen::Matrix3d(block);
    }
    return Eigen::Matrix3d(Eigen::Matrix3d::Identity() * params_.ahrs_attitude_sigma *
                           params_.ahrs_attitude_sigma);
  }

  /// An initial state that no pose measurement has confirmed within acquisition_timeout.
  bool unconfirmed(const Estimate& e) const {
    return params_.acquisition_timeout > 0 &&
           toSeconds(e.state.pose.stamp - e.last_fix) > params_.acquisition_timeout;
  }

  /// No pose fused for longer than lost_after, or lost_after_rejections gated out in a row.
  bool lost(const Estimate& e) const {
    return (params_.lost_after > 0 &&
            toSeconds(e.state.pose.stamp - e.last_fix) > params_.lost_after) ||
           (params_.lost_after_rejections > 0 && e.rejections >= params_.lost_after_rejections);
  }

  /// The pose and its covariance from `z`, the twist and its covariance kept from the
  /// prediction, uncorrelated (the prediction's pose after a loss says nothing of the new one);
  /// the inertial part, tied to the old pose, is dropped until the next AHRS sample.
  void reacquire(Estimate& e, const PoseWithCovariance& z, const Matrix6d& noise) const {
    const Matrix6d twist = e.covariance.block<6, 6>(kVel, kVel);
    e.state.pose = z.pose;
    e.covariance.setZero();
    e.covariance.topLeftCorner<6, 6>() = noise;
    e.covariance.block<6, 6>(kVel, kVel) = twist;
    e.has_inertial = false;
    e.acquiring = false;
    e.last_fix = z.pose.stamp;
    e.rejections = 0;
  }

  Estimate initialiseFrom(const PoseWithCovariance& z, const Matrix6d& noise) const {
    RigidBodyState s;
    s.pose = z.pose;
    s.covariance.setZero();
    s.covariance.topLeftCorner<6, 6>() = noise;
    const double sv = params_.initial_linear_velocity_sigma;
    const double sw = params_.initial_angular_velocity_sigma;
    s.covariance.block<3, 3>(kVel, kVel) = Eigen::Matrix3d::Identity() * sv * sv;
    s.covariance.block<3, 3>(kAng, kAng) = Eigen::Matrix3d::Identity() * sw * sw;
    return Estimate::from(s);  // last_fix = the measurement's stamp, not acquiring
  }

  /// The filter started from a position: the attitude is the identity placeholder with
  /// unknown_attitude_sigma (not observed), the twist zero with its usual prior.
  Estimate initialiseFromPosition(const Transform& z, const Eigen::Matrix3d& noise) const {
    RigidBodyState s;
    s.pose = z;
    s.pose.rotation = Eigen::Quaterniond::Identity();
    s.covariance.setZero();
    s.covariance.topLeftCorner<3, 3>() = noise;
    const double sa = params_.unknown_attitude_sigma;
    const double sv = params_.initial_linear_velocity_sigma;
    const double sw = params_.initial_angular_velocity_sigma;
    s.covariance.block<3, 3>(kRot, kRot) = Eigen::Matrix3d::Identity() * sa * sa;
    s.covariance.block<3, 3>(kVel, kVel) = Eigen::Matrix3d::Identity() * sv * sv;
    s.covariance.block<3, 3>(kAng, kAng) = Eigen::Matrix3d::Identity() * sw * sw;
    return Estimate::from(s);
  }

  /// Adds the target's inertial attitude and rate to the state from the chaser's attitude
  /// inertial_R_a (noise `noise`): inertial_R_b = inertial_R_a a_R_b, and the target's inertial
  /// rate = the chaser's (unknown: zero, give or take initial_chaser_angular_velocity_sigma) +
  /// inertial_R_a w_ab. The new components are correlated with the relative ones through the
  /// Jacobians of these two equations, so that later AHRS samples count each piece of
  /// information once.
  void addInertialPart(Estimate& e, const Transform& chaser, const Eigen::Matrix3d& noise) const {
    const Eigen::Matrix3d r = chaser.rotation.toRotationMatrix();
    e.target_attitude = (chaser.rotation * e.state.pose.rotation).normalized();
    e.target_rate = r * e.state.twist.angular;
    e.inertial_frame = chaser.parent_frame;
    e.has_inertial = true;

    Matrix18d g = Matrix18d::Identity();
    g.block<3, 3>(kTargetRot, kTargetRot).setZero();
    g.block<3, 3>(kTargetAng, kTargetAng).setZero();
    g.block<3, 3>(kTargetRot, kRot) = r;  // dtheta_i = eta + R dtheta
    g.block<3, 3>(kTargetAng, kAng) = r;  // domega_i = R domega - [R w]x eta + zeta
    Eigen::Matrix<double, kN, 6> m = Eigen::Matrix<double, kN, 6>::Zero();
    m.block<3, 3>(kTargetRot, 0).setIdentity();
    m.block<3, 3>(kTargetAng, 0) = -skew(e.target_rate);
    m.block<3, 3>(kTargetAng, 3).setIdentity();
    Matrix6d n = Matrix6d::Zero();
    n.topLeftCorner<3, 3>() = noise;
    const double sc = params_.initial_chaser_angular_velocity_sigma;
    n.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * sc * sc;
    e.covariance = g * e.covariance * g.transpose() + m * n * m.transpose();
    e.covariance = 0.5 * (e.covariance + e.covariance.transpose());
  }

  Status predict(Estimate& e, Timestamp to, const char* input) const {
    RigidBodyState& s = e.state;
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

    Matrix18d f = Matrix18d::Identity();
    f.block<3, 3>(kPos, kVel) = Eigen::Matrix3d::Identity() * dt;
    f.block<3, 3>(kRot, kRot) = step.toRotationMatrix();
    f.block<3, 3>(kRot, kAng) = leftJacobianSO3(rotation_step) * dt;

    // White acceleration noise integrated over dt (the classic discrete white-noise jerk model).
    Matrix18d q = Matrix18d::Zero();
    const Eigen::Matrix3d i3 = Eigen::Matrix3d::Identity();
    const double dt2 = dt * dt, dt3 = dt2 * dt;
    auto add_noise = [&](int pos, int vel, double psd) {
      q.block<3, 3>(pos, pos) = i3 * psd * dt3 / 3.0;
      q.block<3, 3>(pos, vel) = i3 * psd * dt2 / 2.0;
      q.block<3, 3>(vel, pos) = i3 * psd * dt2 / 2.0;
      q.block<3, 3>(vel, vel) = i3 * psd * dt;
    };
    add_noise(kPos, kVel, params_.linear_acceleration_psd);
    add_noise(kRot, kAng, params_.angular_acceleration_psd);
    if (e.has_inertial) {
      const Eigen::Vector3d target_step = e.target_rate * dt;
      const Eigen::Quaterniond turn = expSO3(target_step);
      e.target_attitude = (turn * e.target_attitude).normalized();
      f.block<3, 3>(kTargetRot, kTargetRot) = turn.toRotationMatrix();
      f.block<3, 3>(kTargetRot, kTargetAng) = leftJacobianSO3(target_step) * dt;
      add_noise(kTargetRot, kTargetAng, params_.target_angular_acceleration_psd);
    }
    e.covariance = f * e.covariance * f.transpose() + q;
    e.covariance = 0.5 * (e.covariance + e.covariance.transpose());
    return Status::ok();
  }

  /// Fuses a measurement with residual `residual` ~ h * error + noise into `e`; returns its
  /// normalised innovation squared.
  template <int M>
  Result<double> correct(Estimate& e, const Eigen::Matrix<double, M, kN>& h,
                         const Eigen::Matrix<double, M, 1>& residual,
                         const Eigen::Matrix<double, M, M>& noise) const {
    using MatrixM = Eigen::Matrix<double, M, M>;
    const Eigen::Matrix<double, kN, M> ph = e.covariance * h.transpose();
    const MatrixM innovation_cov = h * ph + noise;
    Eigen::LLT<MatrixM> llt(innovation_cov);
    if (llt.info() != Eigen::Success)
      return numericalFailure(
          "innovation covariance is not positive definite (diagonal {}); "
          "the filter covariance has degenerated, re-initialise",
          fmt::join(innovation_cov.diagonal(), ", "));
    const double nis = residual.dot(llt.solve(residual));
    const Eigen::Matrix<double, kN, M> gain = llt.solve(ph.transpose()).transpose();
    const Vector18d correction = gain * residual;

    RigidBodyState& s = e.state;
    s.pose.translation += correction.segment<3>(kPos);
    s.pose.rotation = (expSO3(correction.segment<3>(kRot)) * s.pose.rotation).normalized();
    s.twist.linear += correction.segment<3>(kVel);
    s.twist.angular += correction.segment<3>(kAng);
    if (e.has_inertial) {
      e.target_attitude =
          (expSO3(correction.segment<3>(kTargetRot)) * e.target_attitude).normalized();
      e.target_rate += correction.segment<3>(kTargetAng);
    }

    // Joseph form: stays symmetric positive semi-definite despite rounding.
    const Matrix18d i_kh = Matrix18d::Identity() - gain * h;
    e.covariance = i_kh * e.covariance * i_kh.transpose() + gain * noise * gain.transpose();
    e.covariance = 0.5 * (e.covariance + e.covariance.transpose());
    return nis;
  }

  std::optional<Estimate> estimate_;  // none until initialised
  double position_gate_ = 0.0;        // chi-square 3 dof; 0 accepts every position
};

CDFF_REGISTER_DFI(EstimationFilterExtendedKalman);

}  // namespace cdff::dfn
