#pragma once
// What model-based edge trackers pass between their steps: the contours of a polygon model that
// one camera sees from a pose (visibility determination), points sampled along them (contour
// sampling) with the image edges found near each point (edge matching), and the tracking status.

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

/// Why a model edge shows as a contour in the image.
enum class ContourKind : std::uint8_t {
  kCrease,      // between two faces seen from the front that meet at an angle
  kSilhouette,  // between a face seen from the front and one seen from the back
  kBoundary,    // the free border of a face (open models)
  kLine,        // an explicit 3D line of the model
};

const char* toString(ContourKind kind);

/// The visible part of one model edge, in the model frame.
struct ContourSegment {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();  // m
  Eigen::Vector3d b = Eigen::Vector3d::Zero();  // m
  std::uint32_t edge = 0;                       // index of the model edge it belongs to
  ContourKind kind = ContourKind::kCrease;
};

/// A model face seen from its front: its plane (normal . x = offset) and outline, model frame.
struct VisibleFace {
  std::uint32_t face = 0;  // index into PolygonModel::faces (after tessellation)
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, pointing out of the object
  double offset = 0;                                  // m
  std::vector<Eigen::Vector3d> outline;               // m, counter-clockwise from outside
};

/// The contours of a model seen by one camera from one pose.
struct ModelContours {
  Timestamp stamp = 0;
  CameraModel camera;            // pinhole intrinsics of the (undistorted) image
  Transform camera_T_model;      // the pose the contours were computed for
  Transform camera_T_reference;  // this camera in the rig (identity for the reference camera)
  std::vector<ContourSegment> segments;
  std::vector<VisibleFace> faces;

  /// Ok when the camera and both transforms are valid and the points finite.
  Status validate(const char* what = "contours") const;
};

/// An image edge found along a sample's normal: `offset` pixels from the sample's projection
/// (positive along the normal), with the gradient magnitude along the normal.
struct EdgeCandidate {
  float offset = 0;    // px
  float strength = 0;  // grey levels per pixel
};

struct ContourSample {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // on the contour, model frame, m
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();    // its projection at contours->camera_T_model
  Eigen::Vector2d normal = Eigen::Vector2d::UnitX();  // unit normal of the projected contour
  std::uint32_t segment = 0;                          // index into contours->segments
  std::uint32_t first_candidate = 0;                  // into ContourSamples::candidates
  std::uint32_t candidate_count = 0;
};

/// Points sampled along the contours, and after edge matching the candidate image edges of each
/// (strongest first).
struct ContourSamples {
  std::shared_ptr<const ModelContours> contours;
  std::vector<ContourSample> samples;
  std::vector<EdgeCandidate> candidates;
  bool matched = false;  // true once edge matching has searched the image

  std::size_t matchedCount() const;
  /// Ok when `contours` is set and valid, and every sample's segment and candidates are in range.
  Status validate(const char* what = "samples") const;
};

/// The status a tracker reports with each pose (seed Table 10: success or failure with a code).
enum class TrackingStatus : int {
  kTracking = 0,  // pose estimated from enough consistent measurements
  kDegraded = 1,  // pose estimated, but a camera failed or the inlier ratio is low
  kLost = 2,      // no trustworthy pose: re-initialise (the pose output is the prediction)
};

const char* toString(TrackingStatus status);

}  // namespace cdff
