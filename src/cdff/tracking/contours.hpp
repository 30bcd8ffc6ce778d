#pragma once
// Visibility determination and contour sampling for model-based edge tracking.
//
// computeContours() finds the edges of a TrackingModel that show as contours in an image taken
// from a pose (creases, silhouettes, free borders, explicit lines) and removes their hidden
// parts exactly: each candidate segment is clipped to the view frustum and against the occlusion
// volume of every face in front of it (Cyrus-Beck clipping against the face's convex pieces), so
// what remains is the visible part of every edge, not a sampled approximation.
//
// sampleContours() places points along the visible segments at a regular spacing in the image,
// with the image normal of the projected segment, ready for a 1D edge search.

#include <memory>

#include "cdff/tracking/tracking_model.hpp"
#include "cdff/types/contours.hpp"

namespace cdff::tracking {

struct VisibilityOptions {
  double near_clipping = 0.01;  // m: parts closer than this to the camera are cut off
  double far_clipping = 0;      // m: parts farther are cut off; 0 disables
  /// rad: a face seen more obliquely than this (between its normal and the line of sight to its
  /// centroid) does not make its creases and borders visible; silhouettes stay.
  double max_view_angle = 89.0 * M_PI / 180.0;
  /// rad: edges between two faces seen from the same side that bend less than this are not
  /// contours (flat or gently curved surfaces).
  double min_crease_angle = 5.0 * M_PI / 180.0;
  /// Faces are surfaces seen from both sides (open models: the inside of a box without a lid);
  /// hidden-line removal then hides what a closed model's front faces cover. False: only faces
  /// seen from the front count, as in ViSP.
  bool two_sided_faces = true;
  double min_segment_length = 3.0;    // px: shorter visible pieces are dropped
  double image_margin = 2.0;          // px: contours are clipped to the image shrunk by this
  double occlusion_tolerance = 1e-4;  // m: a point must be this far behind a face to be hidden
  bool compute_segments = true;       // false: only the visible faces (for depth association)
};

/// The contours of `model` seen by `camera` (pinhole, no distortion) from camera_T_model.
/// `camera_T_reference` places this camera in the rig and is passed through. An empty result
/// (model behind the camera, out of view) is not an error.
Result<ModelContours> computeContours(const TrackingModel& model, const CameraModel& camera,
                                      const Transform& camera_T_model,
                                      const Transform& camera_T_reference,
                                      const VisibilityOptions& options);

struct SamplingOptions {
  double step = 5.0;          // px between samples along a contour
  int max_samples = 1000;     // the step grows when the contours are longer than this allows
  double image_margin = 2.0;  // px: samples closer to the border are dropped
};

/// Samples along the segments of `contours` (projected with contours->camera_T_model).
ContourSamples sampleContours(std::shared_ptr<const ModelContours> contours,
                              const SamplingOptions& options);

/// Ok when `camera` is a pinhole model without distortion (the trackers work on undistorted
/// images); `what` names the input in the message.
Status checkPinhole(const CameraModel& camera, const char* what);

}  // namespace cdff::tracking
