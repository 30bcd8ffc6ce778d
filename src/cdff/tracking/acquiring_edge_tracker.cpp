#include "cdff/tracking/acquiring_edge_tracker.hpp"

namespace cdff::tracking {

void AcquiringEdgeTracker::configure(const AcquiringEdgeTrackerOptions& options) {
  options_ = options;
  tracker_ = EdgeTracker();
  confirmation_.reset();
  on_track_ = false;
  restart_cursor_ = 0;
  if (options_.coarse_alignment) warmUpChamferAlignment(options_.chamfer);
}

Status AcquiringEdgeTracker::setModel(const PolygonModel& model) {
  return tracker_.setModel(model, options_.tracking.model);
}

Result<AcquiringTrackingResult> AcquiringEdgeTracker::track(const FrameMeasurements& frame,
                                                            const PosePrediction& prediction) {
  // While an acquired pose awaits confirmation, the prediction is searched with its pose
  // covariance carried to the image's time with the velocity covariance: the filter has fused one
  // acquired pose, and its velocity is the initial state's corrected by that pose's offset from
  // the initial pose (the filter cannot tell an initial error from motion since the initial
  // state), so the prediction can be off by as much as the velocity is uncertain, far beyond the
  // edge search (degrees at close range from 5 % / 5 deg with the initial state one frame before
  // the first image). Once confirmed, the filter's velocity rests on consecutive poses and
  // its covariance mostly carries the process noise, an allowance for manoeuvres that the target
  // does not make (carried over a frame, it would trigger the acquisition on most frames): the
  // state's own covariance decides.
  PosePrediction predicted = prediction;
  predicted.pose.covariance = confirmation_.widened(
      confirmation_.awaiting() && prediction.carried_covariance ? *prediction.carried_covariance
                                                                : prediction.pose.covariance);
  // After a failed confirmation the search starts where the unconfirmed acquisition's did: the
  // filter has fused the unconfirmed pose, and its prediction, pulled towards a wrong alignment,
  // would lead the next acquisitions onto it (at 17 m a model 16 deg off in attitude and 3 m
  // farther matches as many samples as the right one).
  if (!confirmation_.awaiting()) predicted.pose.pose = confirmation_.anchored(prediction.pose.pose);
  // Only the direct track of an awaited acquired pose can confirm it
  // (acquisition_confirmation.hpp); when it is lost, whatever this frame finds instead is a new
  // acquisition.
  const bool awaited = confirmation_.awaiting() && tracker_.hasModel();
  if (awaited) {
    Result<std::optional<TrackingResult>> direct = trackAwaitedDirectly(frame, prediction);
    if (!direct) return direct.status();
    if (*direct) {
      AcquiringTrackingResult out;
      out.tracking = std::move(**direct);
      confirmAcquisition(confirmation_, out.tracking, false, predicted);
      settle(out);
      return out;
    }
  }
  FramePyramids pyramids(frame.cameras);
  Transform start = predicted.pose.pose;
  bool coarse_placed = false;
  std::string coarse_note;
  if (options_.coarse_alignment && !frame.cameras.empty() && tracker_.hasModel()) {
    Result<CoarseAlignment> aligned =
        alignCoarsely(tracker_.model(), frame.cameras, predicted.pose, options_.tracking,
                      options_.acquisition, options_.chamfer, pyramids);
    if (!aligned) return aligned.status();
    coarse_placed = aligned->start.has_value();
    if (coarse_placed) start = *aligned->start;
    coarse_note = std::move(aligned->note);
  }
  // Off a track, an acquisition that is not accepted restarts from turned attitudes, a few per
  // frame (the frame's time), the next frame continuing the sequence where this one stopped: from
  // one start the passes converge to the same alignment frame after frame.
  const std::vector<Transform> restarts =
      on_track_
          ? std::vector<Transform>()
          : restartStarts(start, predicted.pose.covariance, options_.acquisition.restart_sigmas,
                          restart_cursor_, options_.acquisition.restarts);
  Result<AcquisitionResult> acquired =
      trackWithAcquisition(tracker_, frame, predicted.pose, start, coarse_placed, options_.tracking,
                           options_.acquisition, pyramids, restarts);
  if (!acquired) return acquired.status();
  restart_cursor_ += acquired->restarts;
  AcquiringTrackingResult out;
  out.tracking = std::move(acquired->tracking);
  out.acquisition_ran = acquired->ran;
  if (out.acquisition_ran && !coarse_placed && !on_track_)
    losePartialAlignment(out.tracking, predicted.pose.pose);
  // The confirmation is for acquisitions off a track, whose gate can admit a wrong alignment once
  // lost frames have widened the prediction; one from a track (triggered as the track's
  // covariance grows: at close range with an honest covariance) is gated by the track's own
  // prediction and stands as a tracked frame.
  confirmAcquisition(confirmation_, out.tracking, (out.acquisition_ran && !on_track_) || awaited,
                     predicted);
  if (out.acquisition_ran && !coarse_note.empty()) out.tracking.reason += " (" + coarse_note + ")";
  settle(out);
  return out;
}

void AcquiringEdgeTracker::settle(AcquiringTrackingResult& out) {
  out.acquiring = confirmation_.awaiting();
  on_track_ = out.tracking.status != TrackingStatus::kLost && !out.acquiring;
  if (on_track_) restart_cursor_ = 0;
}

void AcquiringEdgeTracker::losePartialAlignment(TrackingResult& t,
                                                const Transform& predicted) const {
  // An acquisition that leaves fewer than degraded_inlier_ratio of the samples matched is a
  // partial alignment unless a coarse placement put the model on the image's edges (at long range
  // every track has such a ratio): without one, the model is wider than the image, and the
  // passes' coarse levels, which do not see its finer edges, can settle where only its large
  // edges fit (at close range the adapter ring's circles fit at any rotation about its axis,
  // with about a third of the samples matched against three quarters when right). Such a pose,
  // confirmed by the next frame tracking the same partial alignment, would be a wrong track. It
  // applies to acquisitions off a track (from the initial state, or after a loss): one from a
  // track, triggered as its covariance grows, starts at its own accuracy, and near 1 m right
  // tracks match fewer than half their samples.
  if (t.status != TrackingStatus::kDegraded ||
      t.inlier_ratio >= options_.tracking.degraded_inlier_ratio)
    return;
  t.reason = fmt::format(
      "the acquired pose matches {:.2f} of its samples, below degraded_inlier_ratio {:.2f}, "
      "without a coarse placement: a partial alignment",
      t.inlier_ratio, options_.tracking.degraded_inlier_ratio);
  t.status = TrackingStatus::kLost;
  t.reference_T_model = predicted;
  t.covariance = noInformationCovariance();
}

Result<std::optional<TrackingResult>> AcquiringEdgeTracker::trackAwaitedDirectly(
    const FrameMeasurements& frame, const PosePrediction& prediction) {
  Transform start = prediction.pose.pose;
  if (const std::optional<Transform>& held = confirmation_.acquiredPose()) {
    start = *held;
    start.stamp = prediction.pose.pose.stamp;
  }
  Result<TrackingResult> t =
      tracker_.track(frame.cameras, frame.depth, frame.depth_T_reference, start, options_.tracking);
  if (!t) return t.status();
  if (t->status == TrackingStatus::kLost) return std::optional<TrackingResult>();
  return std::optional<TrackingResult>(std::move(t).value());
}

}  // namespace cdff::tracking
