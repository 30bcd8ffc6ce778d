#pragma once
// The edge tracker with its acquisition: what ModelBasedTracking/EdgeTracker runs on every frame.
//
// Each frame: the prediction (its covariance carried to the image's time while an acquired pose
// awaits confirmation, widened after a failed confirmation) is placed by the coarse alignment
// (chamfer_alignment.hpp, when enabled), acquired coarse to fine when its spread in the image
// exceeds the edge search (acquisition.hpp), tracked at full resolution and gated; off a track, an
// acquisition that is not accepted restarts from turned attitudes (acquisition_restarts per
// frame, the sequence continued by the next frame). An acquisition
// off a track (from the initial state or after a lost frame) that matches fewer than
// degraded_inlier_ratio of its samples without a coarse placement is lost (a partial alignment);
// one that is not lost awaits the next frame's confirmation (acquisition_confirmation.hpp), which
// is first tracked directly from the acquired pose; after a failed confirmation the search starts
// from where the unconfirmed acquisition's did. An acquisition from a track stands. The image
// pyramid is built once per frame for all of them. This class keeps what persists between frames:
// the EdgeTracker (its model and cached contours), the confirmation's state and whether the last
// frame was a track.

#include <optional>
#include <span>
#include <string>

#include "cdff/tracking/acquisition.hpp"
#include "cdff/tracking/acquisition_confirmation.hpp"
#include "cdff/tracking/chamfer_alignment.hpp"
#include "cdff/tracking/edge_tracker.hpp"
#include "cdff/tracking/prediction.hpp"

namespace cdff::tracking {

struct AcquiringEdgeTrackerOptions {
  EdgeTrackerOptions tracking;
  AcquisitionOptions acquisition;
  bool coarse_alignment = false;  // the chamfer search before the acquisition's passes
  ChamferAlignmentOptions chamfer;
};

struct AcquiringTrackingResult {
  /// The frame's result after the acquisition's gate and the confirmation; its reason ends with
  /// the coarse alignment's note when the alignment was skipped.
  TrackingResult tracking;
  bool acquisition_ran = false;  // the prediction's spread exceeded the search
  bool acquiring = false;  // after this frame an acquired pose awaits the next one (ACQUIRING)
};

class AcquiringEdgeTracker {
 public:
  /// New options: a new EdgeTracker (no model: the model's tessellation depends on them) and no
  /// acquisition awaiting confirmation. With the coarse alignment, OpenCV is initialised now
  /// rather than in the first (acquisition) frame.
  void configure(const AcquiringEdgeTrackerOptions& options);

  /// Builds the tracking form of `model`; the previous model stays on error.
  Status setModel(const PolygonModel& model);
  bool hasModel() const { return tracker_.hasModel(); }

  /// Tracks one frame (cameras, optional depth map placed by depth_T_reference) from the
  /// prediction at the measurements' time. Input errors are errors; a lost track is a result.
  Result<AcquiringTrackingResult> track(const FrameMeasurements& frame,
                                        const PosePrediction& prediction);

  const EdgeTracker& tracker() const { return tracker_; }

 private:
  /// While an acquired pose awaits confirmation, the frame is first tracked directly from the
  /// acquired pose held still (the prediction's pose when none was given): whether the acquired
  /// alignment holds, tracked again from itself, is what confirms it. Not from the filter's
  /// prediction: after one acquired pose its velocity attributes part of the pose's offset from
  /// the initial state to motion and moves the start along a wrong alignment's valley (at 17 m a
  /// start so moved converged where the held one was lost). Not LOST, the result is the frame's
  /// (the confirmation then checks it); LOST, the frame acquires from the carried covariance.
  Result<std::optional<TrackingResult>> trackAwaitedDirectly(const FrameMeasurements& frame,
                                                             const PosePrediction& prediction);

  /// An acquisition off a track without a coarse placement that leaves fewer than
  /// degraded_inlier_ratio of the samples matched is a partial alignment: `t` becomes LOST with
  /// the `predicted` pose and a no-information covariance.
  void losePartialAlignment(TrackingResult& t, const Transform& predicted) const;

  /// The frame's ACQUIRING flag and whether it leaves a track (which resets the restarts).
  void settle(AcquiringTrackingResult& out);

  AcquiringEdgeTrackerOptions options_;
  EdgeTracker tracker_;
  AcquisitionConfirmation confirmation_;
  bool on_track_ = false;
  int restart_cursor_ = 0;  // the next restart of restartStarts' sequence, off a track  // the last
                            // frame was a track: not LOST, no acquisition awaiting
};

}  // namespace cdff::tracking
