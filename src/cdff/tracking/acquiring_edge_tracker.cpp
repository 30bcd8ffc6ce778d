#include "cdff/tracking/acquiring_edge_tracker.hpp"

namespace cdff::tracking {

void AcquiringEdgeTracker::configure(const AcquiringEdgeTrackerOptions& options) {
  options_ = options;
  tracker_ = EdgeTracker();
  confirmation_.reset();
  if (options_.coarse_alignment) warmUpChamferAlignment(options_.chamfer);
}

Status AcquiringEdgeTracker::setModel(const PolygonModel& model) {
  return tracker_.setModel(model, options_.tracking.model);
}

Result<AcquiringTrackingResult> AcquiringEdgeTracker::track(const FrameMeasurements& frame,
                                                            const PosePrediction& prediction) {
  PosePrediction predicted = prediction;
  predicted.pose.covariance = confirmation_.widened(prediction.pose.covariance);
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
  Result<AcquisitionResult> acquired =
      trackWithAcquisition(tracker_, frame, predicted.pose, start, coarse_placed, options_.tracking,
                           options_.acquisition, pyramids);
  if (!acquired) return acquired.status();
  AcquiringTrackingResult out;
  out.tracking = std::move(acquired->tracking);
  out.acquisition_ran = acquired->ran;
  confirmAcquisition(confirmation_, out.tracking, out.acquisition_ran, predicted);
  if (out.acquisition_ran && !coarse_note.empty()) out.tracking.reason += " (" + coarse_note + ")";
  out.acquiring = out.acquisition_ran && out.tracking.status != TrackingStatus::kLost;
  return out;
}

}  // namespace cdff::tracking
