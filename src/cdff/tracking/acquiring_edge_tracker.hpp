#pragma once
// The edge tracker with its acquisition: what ModelBasedTracking/EdgeTracker runs on every frame.
//
// Each frame: the prediction, widened after a failed confirmation, is placed by the coarse
// alignment (chamfer_alignment.hpp, when enabled), acquired coarse to fine when its spread in the
// image exceeds the edge search (acquisition.hpp), tracked at full resolution and gated; an
// acquired pose then awaits the next frame's confirmation (acquisition_confirmation.hpp). The
// image pyramid is built once per frame for all of them. This class keeps what persists between
// frames: the EdgeTracker (its model and cached contours) and the confirmation's state.

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
  bool acquiring = false;        // an acquired pose awaits the next frame (track state ACQUIRING)
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
  AcquiringEdgeTrackerOptions options_;
  EdgeTracker tracker_;
  AcquisitionConfirmation confirmation_;
};

}  // namespace cdff::tracking
