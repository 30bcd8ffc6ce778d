#include "cdff/tracking/acquisition_confirmation.hpp"

#include <string>

#include <Eigen/Cholesky>

namespace cdff::tracking {

Vector6d poseDifference(const Transform& estimate, const Transform& predicted) {
  const Eigen::Isometry3d p = predicted.isometry();
  const Eigen::Isometry3d e = estimate.isometry();
  Vector6d d;
  d.head<3>() = e.translation() - p.translation();
  d.tail<3>() = logSO3(Eigen::Quaterniond(e.linear() * p.linear().transpose()));
  return d;
}

GateTest testGate(const Transform& estimate, const Transform& predicted,
                  const Matrix6d& covariance) {
  const Vector6d d = poseDifference(estimate, predicted);
  const Eigen::LDLT<Matrix6d> ldlt(covariance);
  const double m = ldlt.info() == Eigen::Success ? d.dot(ldlt.solve(d)) : 0.0;
  return {ldlt.info() != Eigen::Success || m <= kAcquisitionGate, m};
}

Matrix6d AcquisitionConfirmation::widened(const Matrix6d& predicted) const {
  if (reacquisition_covariance_ && reacquisition_covariance_->trace() > predicted.trace())
    return *reacquisition_covariance_;
  return predicted;
}

Transform AcquisitionConfirmation::anchored(const Transform& predicted) const {
  if (!reacquisition_anchor_) return predicted;
  Transform t = *reacquisition_anchor_;
  t.stamp = predicted.stamp;
  return t;
}

void AcquisitionConfirmation::acquired(const Matrix6d& covariance,
                                       const std::optional<Transform>& pose,
                                       const std::optional<Transform>& searched) {
  awaiting_ = true;
  acquisition_anchor_ = searched;
  acquisition_covariance_ = covariance;
  acquired_pose_ = pose;
}

AcquisitionConfirmation::Check AcquisitionConfirmation::confirm(bool lost,
                                                                const Transform& estimate,
                                                                const Transform& predicted,
                                                                const Matrix6d& gate_covariance) {
  Check check;
  if (!awaiting_) return check;
  awaiting_ = false;
  acquired_pose_.reset();
  check.checked = true;
  if (!lost) {
    const GateTest gate = testGate(estimate, predicted, gate_covariance);
    check.distance = gate.distance;
    check.confirmed = gate.admitted;
  }
  if (check.confirmed) {
    reacquisition_covariance_.reset();
    reacquisition_anchor_.reset();
  } else {
    reacquisition_covariance_ = acquisition_covariance_;
    reacquisition_anchor_ = acquisition_anchor_;
  }
  return check;
}

void AcquisitionConfirmation::reset() {
  awaiting_ = false;
  acquired_pose_.reset();
  reacquisition_covariance_.reset();
  acquisition_anchor_.reset();
  reacquisition_anchor_.reset();
}

Matrix6d confirmationCovariance(const TrackingResult& result, const PosePrediction& prediction) {
  Matrix6d c = prediction.pose.covariance;
  if (prediction.carried_covariance) c = *prediction.carried_covariance;
  if (result.covariance.allFinite()) c += result.covariance;
  return c;
}

void confirmAcquisition(AcquisitionConfirmation& state, TrackingResult& result,
                        bool acquisition_ran, const PosePrediction& prediction) {
  const bool lost = result.status == TrackingStatus::kLost;
  if (state.awaiting()) {
    // Only a track of the awaited alignment confirms it: a frame that acquired again searched as
    // widely as the acquisition did, and from a wrong alignment in a valley of the edges' fit
    // (at 17 m: farther and turned, as many samples matched) its search slides on along the
    // valley, still admitted by the carried covariance. Such a frame is a new acquisition.
    const bool confirming = !lost && !acquisition_ran;
    const AcquisitionConfirmation::Check check =
        state.confirm(!confirming, result.reference_T_model, prediction.pose.pose,
                      confirming ? confirmationCovariance(result, prediction) : Matrix6d::Zero());
    if (check.confirmed) return;
    const std::string why =
        lost ? fmt::format("the next frame did not confirm the acquired pose ({})", result.reason)
        : acquisition_ran
            ? std::string(
                  "the next frame lost the acquired pose, tracked from itself; what it found "
                  "instead, acquired again, does not confirm it")
            : fmt::format(
                  "the next frame did not confirm the acquired pose (tracked; squared Mahalanobis "
                  "distance {:.1f} from the prediction, gate {:.2f})",
                  check.distance, kAcquisitionGate);
    if (acquisition_ran && !lost) {
      // The replacing acquisition keeps the anchor of the one it replaces.
      state.acquired(prediction.pose.covariance, result.reference_T_model,
                     state.anchored(prediction.pose.pose));
      result.status = TrackingStatus::kDegraded;
      result.reason = why + ": this frame's acquired pose replaces it and awaits the next frame";
      return;
    }
    result.reason = why + ": acquiring again";
    result.status = TrackingStatus::kLost;
    result.reference_T_model = prediction.pose.pose;
    result.covariance = noInformationCovariance();
    return;
  }
  if (!acquisition_ran || lost) return;
  state.acquired(prediction.pose.covariance, result.reference_T_model, prediction.pose.pose);
  if (result.status == TrackingStatus::kTracking) {
    result.status = TrackingStatus::kDegraded;
    result.reason = "acquired; not tracking until the next frame confirms the acquired pose";
  }
}

}  // namespace cdff::tracking
