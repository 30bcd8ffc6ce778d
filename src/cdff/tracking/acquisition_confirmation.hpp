#pragma once
// The acquisition's gate and the confirmation of an acquired pose by the next frame.
//
// A wide acquisition can lock onto a wrong alignment: at long range the model's image is small
// next to the search, and once lost frames have widened the prediction a wrong alignment can pass
// both the prediction's gate and the inlier test. So an acquired pose is first gated by the
// prediction's covariance (not admitted: lost), and an admitted one off a track (from the initial
// state, or after a lost frame; the caller, AcquiringEdgeTracker, decides) is not yet a track: it
// is reported degraded (track state ACQUIRING) until the next frame confirms it: that frame
// tracks the acquired alignment directly (from the acquired pose held still, whatever the
// prediction's spread), and its estimate is not lost and is admitted by the prediction's pose
// covariance carried to the image's time plus the estimate's own. A right alignment is a fixed
// point of the tracker and holds; a wrong one that fits the edges about as well (at 17 m the
// model farther and turned) lies in a valley along which the next frame's track slides beyond its
// divergence bound. A frame that acquires again does not confirm, admitted or not: its wide search
// slides along that valley and stays admitted; its pose replaces the awaited one (and awaits the
// next frame). Any other failed confirmation is lost, and the following frames acquire again from
// a covariance as wide as the unconfirmed acquisition's (the filter's state has been pulled to the
// wrong alignment and its covariance no longer covers the truth), searched from the pose the
// unconfirmed acquisition was searched from (anchored()). The direct track runs on every frame
// that an acquired pose awaits, so the widened covariance, which makes those frames acquire when
// the direct track is lost, does not keep a right alignment from being confirmed.

#include <optional>

#include "cdff/tracking/edge_tracker.hpp"
#include "cdff/tracking/prediction.hpp"

namespace cdff::tracking {

/// The gate on a pose estimate against its prediction: the chi-square 0.999 quantile for 6
/// degrees of freedom, on the squared Mahalanobis distance.
inline constexpr double kAcquisitionGate = 22.46;

/// The estimate minus the prediction: [translation, rotation vector], both in the reference frame
/// (the covariance's perturbation convention).
Vector6d poseDifference(const Transform& estimate, const Transform& predicted);

struct GateTest {
  bool admitted = true;
  double distance = 0;  // squared Mahalanobis distance; 0 when the covariance is singular
};

/// Whether `covariance` admits `estimate` as a draw about `predicted`: its squared Mahalanobis
/// distance is at most kAcquisitionGate. A singular covariance admits all.
GateTest testGate(const Transform& estimate, const Transform& predicted,
                  const Matrix6d& covariance);

/// What must persist between frames for the confirmation: whether an acquired pose awaits the
/// next frame, the covariance it was acquired with, and the covariance to acquire again with
/// after a failed confirmation. Sensor-independent: it sees poses, covariances and whether the
/// track was lost.
class AcquisitionConfirmation {
 public:
  /// The covariance this frame's prediction is searched with: after a failed confirmation, the
  /// unconfirmed acquisition's when its trace exceeds `predicted`'s (until a confirmation).
  Matrix6d widened(const Matrix6d& predicted) const;

  /// The pose this frame's prediction is searched from: after a failed confirmation, the pose
  /// the unconfirmed acquisition was searched from (until a confirmation), stamped as `predicted`:
  /// the filter has fused the unconfirmed pose and its prediction has moved towards it.
  Transform anchored(const Transform& predicted) const;

  /// A frame acquired `pose`, not lost, searching the prediction's `covariance` about `searched`:
  /// the pose awaits the next frame.
  void acquired(const Matrix6d& covariance, const std::optional<Transform>& pose = std::nullopt,
                const std::optional<Transform>& searched = std::nullopt);

  /// The pose that awaits confirmation, when one does and was given.
  const std::optional<Transform>& acquiredPose() const { return acquired_pose_; }

  struct Check {
    bool checked = false;    // an acquired pose awaited this frame
    bool confirmed = false;  // ... and this frame confirmed it
    double distance = 0;     // squared Mahalanobis distance (0 when lost or not checked)
  };
  /// The frame after an acquisition: when an acquired pose awaits it, this frame confirms it if
  /// not `lost` and `gate_covariance` admits `estimate` about `predicted`. A failed confirmation
  /// makes widened() return the acquisition's covariance and anchored() the pose it was searched
  /// from.
  Check confirm(bool lost, const Transform& estimate, const Transform& predicted,
                const Matrix6d& gate_covariance);

  bool awaiting() const { return awaiting_; }
  void reset();

 private:
  bool awaiting_ = false;
  Matrix6d acquisition_covariance_ = Matrix6d::Zero();
  std::optional<Transform> acquired_pose_;
  std::optional<Matrix6d> reacquisition_covariance_;
  std::optional<Transform> acquisition_anchor_, reacquisition_anchor_;
};

/// The covariance of the difference between a confirming estimate and the prediction: the
/// prediction's pose covariance carried to the image's time with its velocity covariance (the
/// filter's state is that of its correction by the acquired pose, with a small pose covariance;
/// the motion since then is what the velocity's covariance allows), or the prediction's own
/// covariance when it came as a pose, plus the estimate's covariance when finite.
Matrix6d confirmationCovariance(const TrackingResult& result, const PosePrediction& prediction);

/// Applies the confirmation to one frame's edge-tracking result, after the acquisition's gate.
/// When an acquired pose awaits, this frame checks it: a tracked result (`acquisition_ran`
/// false: AcquiringEdgeTracker passes only the direct track from the acquired pose so) that is
/// not lost and admitted confirms it and stands; a result that acquired (`acquisition_ran`) and
/// is not lost awaits the next frame in its place (DEGRADED), admitted or not; any other is LOST
/// with the prediction's pose and a no-information covariance.
/// When none awaits, an acquisition that ran and is not lost awaits the next frame (a TRACKING
/// result is reported DEGRADED until then). `prediction.pose` is the prediction as searched
/// (widened(), anchored()).
void confirmAcquisition(AcquisitionConfirmation& state, TrackingResult& result,
                        bool acquisition_ran, const PosePrediction& prediction);

}  // namespace cdff::tracking
