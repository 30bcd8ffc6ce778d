#pragma once
// Coarse alignment before the acquisition: an oriented chamfer search over image shift and scale.
//
// When the prediction's error moves the model's image by more than the 1D edge searches reach
// (at long range, e.g. a 5 % / 5 degree start at 17 m), the acquisition's passes lock onto wrong
// edges. The model's contours at the prediction are slid (within the lateral uncertainty) and
// scaled (within the range uncertainty) over the truncated distance transform of the image's
// Canny edges, on a pyramid level where the model is kMinModelPx or more across; the cost of a
// contour sample also grows with the angle between its normal and the nearest edge's gradient,
// without which the score favours a shrunk model on interior edges. The best shift and scale move
// the prediction across the line of sight and in range; the attitude is left to the acquisition's
// passes.

#include <optional>
#include <span>
#include <string>

#include "cdff/tracking/acquisition.hpp"
#include "cdff/tracking/image_pyramid.hpp"

namespace cdff::tracking {

struct ChamferAlignmentOptions {
  /// The low hysteresis threshold of the Canny edges (the high one is 3 times it), on the L1 norm
  /// of the 3x3 Sobel gradient of the pyramid level.
  double canny_low = 20;
};

struct CoarseAlignment {
  /// The prediction moved across the line of sight and in range; empty when the alignment did
  /// not run (the spread fits the search, the model is wider than the image, or too few contour
  /// samples) or was skipped.
  std::optional<Transform> start;
  /// Why it was skipped, when the image had too few edges to support any placement.
  std::string note;
};

/// Aligns the model's contours in the reference camera's image (the first camera with an image)
/// with the image's edges, when the prediction's visible spread there (visibleSpreadPx) exceeds
/// options.search.search_distance and the model's image is narrower than the image (a model seen
/// in part biases the score of its clipped contours towards whatever edges lie inside, and the
/// acquisition's passes reach far enough there). Skipped, with a note, when the search's window
/// holds fewer edge pixels than the contour has samples: no placement can then put even half of
/// it on edges, and the search would only pick the least bad clutter. `pyramids` holds the
/// frames' images.
Result<CoarseAlignment> alignCoarsely(const TrackingModel& model,
                                      std::span<const CameraFrame> frames,
                                      const PoseWithCovariance& predicted,
                                      const EdgeTrackerOptions& options,
                                      const AcquisitionOptions& acquisition,
                                      const ChamferAlignmentOptions& chamfer,
                                      FramePyramids& pyramids);

/// Runs OpenCV's Canny and distance transform once on a small image: their first calls initialise
/// the library, which would otherwise be paid by the first acquisition frame, whose time budget is
/// that of every frame.
void warmUpChamferAlignment(const ChamferAlignmentOptions& chamfer);

}  // namespace cdff::tracking
