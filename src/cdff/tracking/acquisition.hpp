#pragma once
// Acquisition from an uncertain prediction (a fresh initial pose, or a prediction widened by lost
// frames): when the prediction's uncertainty, projected into the image, exceeds the edge search,
// the tracker first runs coarse-to-fine passes on an image pyramid that bring the pose within the
// search, then the usual passes at full resolution.
//
// Two hypotheses, because neither works everywhere. The lateral-first one moves the pose across
// the optical axis only at the coarsest level, with the wide search, then frees all six degrees
// of freedom with the usual search: the lateral offset is what moves the model's image most,
// while range and attitude, weakly observed through the wrong associations of a wide coarse
// search, run away with the update. The plain one frees all six degrees of freedom with the wide
// search from the start, which some geometries need. The plain one runs only when the
// lateral-first one gives no acceptable result, as running both doubles the acquisition frame's
// cost; the full-resolution result with the higher inlier ratio is then kept. An acquired pose
// that the prediction's covariance does not admit is lost (acquisition_confirmation.hpp).
//
// Restarts: the acquisition from a start converges to the same alignment frame after frame, so
// when it is not accepted the caller can give starts with the attitude turned about the
// covariance's principal axes (restartStarts), tried in turn within the frame.

#include <span>
#include <string>
#include <vector>

#include "cdff/tracking/edge_tracker.hpp"
#include "cdff/tracking/image_pyramid.hpp"

namespace cdff::tracking {

struct AcquisitionOptions {
  /// The prediction's spread in the image, in standard deviations of its covariance; the
  /// acquisition runs when the spread exceeds the search distance. 0 disables the acquisition.
  double sigmas = 3;
  int max_search_distance = 64;  // px of its level: the longest search of the coarsest pass
  bool lateral_first = true;     // the lateral-first hypothesis first (else the plain one only)
  /// Starts tried per frame besides the prediction when the acquisition from the prediction is
  /// not accepted (restartStarts); 0 tries none.
  int restarts = 2;
  /// How far a restart turns the prediction's attitude, in standard deviations of the attitude
  /// covariance along one of its principal axes.
  double restart_sigmas = 2;
};

/// How far, in pixels, the prediction's uncertainty may move the model's image in `frame`, as a
/// bound that sizes the acquisition's pyramid and searches: `sigmas` standard deviations of the
/// lateral position, of the range (which scales the image about its centre) and of the attitude
/// (which swings the model's extent), added. 0 without acquisition (sigmas 0), for a covariance
/// that is not finite, not positive or of no information (1e5 or more), or a model centre nearer
/// than `near_clipping`.
double predictionSpreadPx(const TrackingModel& model, const CameraFrame& frame,
                          const PoseWithCovariance& predicted, double sigmas, double near_clipping);

/// How far, in pixels, the prediction's uncertainty moves the visible model's image in `frame`,
/// which decides whether the acquisition (and the coarse alignment) runs at all: `sigmas`
/// times the largest root-mean-square displacement of a model point's image, under the pose
/// covariance projected through the camera, over the model's points that project into the image
/// (over all points in front when none does). Projecting the full covariance keeps its
/// correlations: a lateral offset and a rotation that move the visible part of the model alike and
/// are each uncertain, but not together, do not add up. 0 without acquisition (sigmas 0), for a
/// covariance that is not finite, not positive or of no information (1e5 or more), or a model
/// centre nearer than `near_clipping`. The bound above adds the terms, each at its worst: with an
/// honest covariance (one that does not shrink with the samples per contour) it is 4 times this
/// spread or more at close range, far beyond the search, where the visible model moves by less than
/// it.
double visibleSpreadPx(const TrackingModel& model, const CameraFrame& frame,
                       const PoseWithCovariance& predicted, double sigmas, double near_clipping);

/// The diameter of the model's bounding sphere in `frame`'s image at the prediction (0 for a
/// centre nearer than `near_clipping`).
double modelSizePx(const TrackingModel& model, const CameraFrame& frame,
                   const PoseWithCovariance& predicted, double near_clipping);

/// One frame's measurements, as EdgeTracker::track takes them.
struct FrameMeasurements {
  std::span<const CameraFrame> cameras;
  const DepthMap* depth = nullptr;
  Eigen::Isometry3d depth_T_reference = Eigen::Isometry3d::Identity();
};

struct AcquisitionResult {
  bool ran = false;         // the prediction's spread exceeded the search: acquisition passes ran
  bool acquired = true;     // false: the passes of every hypothesis lost the track
  std::string failure;      // why not acquired: where and why the passes lost the track
  TrackingResult tracking;  // the frame's result; lost with the prediction's pose when not
                            // acquired or not admitted by the prediction
  int restarts = 0;         // restarts tried (after the acquisition from `start` was not accepted)
};

/// Restart `first` to `first + count - 1` of the sequence that the acquisition tries after one
/// from `start` is not accepted: `start` with its attitude turned by `sigmas` standard deviations
/// of `covariance`'s attitude block about each principal axis, both ways, the largest axis first,
/// then the sequence again (index i turns about axis (i / 2) mod 3, the sign alternating). An
/// acquisition from a start converges to the same alignment frame after frame: at close range
/// the model's large edges (the adapter ring's circles) fit a wrong attitude a few degrees off,
/// and a start on the other side of the truth converges to it. Empty when `count` or `sigmas` is
/// not positive or the attitude covariance is not positive definite.
std::vector<Transform> restartStarts(const Transform& start, const Matrix6d& covariance,
                                     double sigmas, int first, int count);

/// Tracks one frame from `start` (the prediction, or the coarse alignment's placement of it when
/// `coarse_placed`), acquiring first when the prediction's spread in the reference camera exceeds
/// options.search.search_distance. After a coarse placement the lateral offset comes from the
/// image's edges, so the lateral-first result is kept when it is not lost and the prediction
/// admits it (at long range it is degraded, as any track there); without one, only when it is
/// tracking and admitted. When the result from `start` is not accepted so, the acquisition runs
/// from each of `restarts` in turn (restartStarts) and the first accepted result is the frame's;
/// none accepted, the result from `start` stands.
Result<AcquisitionResult> trackWithAcquisition(EdgeTracker& tracker, const FrameMeasurements& frame,
                                               const PoseWithCovariance& predicted,
                                               const Transform& start, bool coarse_placed,
                                               const EdgeTrackerOptions& options,
                                               const AcquisitionOptions& acquisition,
                                               FramePyramids& pyramids,
                                               std::span<const Transform> restarts = {});

}  // namespace cdff::tracking
