#pragma once
// Robust pose estimation from contour matches in N calibrated cameras and, optionally, depth
// points on the model's faces: iteratively re-weighted Gauss-Newton on the pose reference_T_model
// with Tukey's biweight M-estimator.
//
// Edge residual: the signed distance in pixels from a matched image edge point to the projection
// of the model edge it belongs to (the line through the projected segment ends, exact under
// perspective: the plane through the camera centre and the 3D segment). Each iteration picks,
// per sample, the candidate nearest to the current projection. Depth residual: the distance in
// metres from a depth point to the plane of the face it was associated with. Each kind is
// normalised by its own robust scale (1.4826 x the median absolute residual, floored), so both
// contribute in one set of normal equations.
//
// Perturbations follow docs/conventions.md: t = t_hat + dt, R = exp(dtheta) R_hat in the
// reference frame; the covariance is ordered [dt, dtheta].
//
// Covariance: the samples of one contour are not independent measurements. Their errors come
// mostly from what the contour shares (its rendering or blur, a model edge off by a fraction of a
// pixel, a shadow or a texture next to it), so the inverse of the weighted information, which
// counts every sample as independent, shrinks with the number of samples per contour while the
// true error does not (a covariance 20 times too small in variance at close range). The
// covariance is therefore estimated from the residuals with each contour chain as one
// measurement (a cluster): the samples of the segments that continue one another turning by
// less than chain_angle at shared ends (one straight edge, or a tessellated curve), in every
// camera that sees them (what makes the error is the edge's, seen by both cameras of a rig), and
// the depth points of one face. The estimate is the jackknife over the clusters: the sum over
// clusters c of (H - H_c)^-1 g_c g_c^T (H - H_c)^-1, where H is the weighted information, H_c and
// g_c the information and the weighted residual gradient of cluster c's samples (to first order,
// how the estimate moves when cluster c is left out). It follows the errors as they are,
// correlated along a contour or not, and counts a contour that alone fixes a direction (whose
// residuals the fit absorbs) by the uncertainty of leaving it out. Relative to the inverse of the
// information it is inflated by at least its mean factor in every direction, as a handful of
// clusters (close range) leaves directions unsampled, and never shrunk below it.

#include <cmath>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/types/contours.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/status.hpp"

namespace cdff::tracking {

/// One camera's matched samples; camera_T_reference and intrinsics come from samples->contours.
struct EdgeView {
  const ContourSamples* samples = nullptr;
};

/// Depth points (reference frame) with the face plane (model frame) each was associated with.
struct DepthPoints {
  std::vector<Eigen::Vector3d> points;  // reference frame, m
  std::vector<Eigen::Vector4d> planes;  // model frame: (normal, offset), normal . x = offset
};

struct DepthAssociationOptions {
  int step_x = 4, step_y = 4;  // px between the depth pixels used
  double max_distance = 0.02;  // m: points farther from their face (at the prediction) are dropped
  double min_depth = 0.0;      // m: depths outside (min, max] are no measurement
  double max_depth = 1e9;      // m
};

/// Associates depth pixels with the faces seen from the depth camera at reference_T_model: each
/// used pixel is cast through the faces (nearest hit wins) and kept when its measured depth is
/// within max_distance of the hit. `faces` are the visible faces (model frame) for this camera,
/// `depth_T_reference` the depth camera in the rig; the depth image carries its intrinsics.
Result<DepthPoints> associateDepth(const DepthMap& depth,
                                   const Eigen::Isometry3d& depth_T_reference,
                                   std::span<const VisibleFace> faces,
                                   const Eigen::Isometry3d& reference_T_model,
                                   const DepthAssociationOptions& options);

struct PoseSolverOptions {
  int max_iterations = 30;
  double convergence_translation = 1e-5;  // m: an update smaller than this in both ...
  double convergence_rotation = 1e-5;     // rad: ... translation and rotation has converged
  double divergence_translation = 0.1;    // m: moving farther from the initial pose diverges
  double divergence_rotation = 0.35;      // rad
  double tukey_constant = 4.6851;         // in robust standard deviations
  double min_edge_sigma = 0.3;            // px: floor of the edge residuals' robust scale
  double min_depth_sigma = 0.0005;        // m: floor of the depth residuals' robust scale
  /// The depth points together weigh as much as depth_weight times the edge residuals (when
  /// there are edges): dense depth errors are correlated, their count says little.
  double depth_weight = 1.0;
  double inlier_threshold = 2.0;  // px: a matched sample this close at the end is an inlier
  int min_measurements = 12;      // fewer usable residuals: no estimate
  /// Only the translation across the reference frame's z axis (the reference camera's optical
  /// axis) moves; range and attitude stay. Acquisition's first coarse pass: the lateral offset
  /// moves the model's image most, and range and attitude, weakly observed from a wrong
  /// association at a coarse level, would run away with the update.
  bool lateral_only = false;
  /// true: the covariance is the jackknife over the contour chains (above); false: the inverse of
  /// the weighted information, every sample an independent measurement (optimistic).
  bool edge_cluster_covariance = true;
  /// rad: contour segments that continue each other turning by less than this at a shared end
  /// are one chain. A curve tessellated into n segments turns by 360/n degrees at each (10 for
  /// the 36 facets of the tracking model's cylinders and circles), the corners of a spacecraft's
  /// parts by 45 degrees or more.
  double chain_angle = 30.0 * M_PI / 180.0;
};

struct ViewStatistics {
  std::size_t samples = 0;  // contour samples
  std::size_t matched = 0;  // samples with at least one candidate
  std::size_t inliers = 0;  // matched samples within inlier_threshold at the end
};

struct PoseSolution {
  Eigen::Isometry3d reference_T_model = Eigen::Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Zero();  // [dt, dtheta], reference frame
  /// The inverse of the weighted information (every sample independent), whatever
  /// edge_cluster_covariance says.
  Matrix6d information_covariance = Matrix6d::Zero();
  std::size_t clusters = 0;  // contour chains and depth faces with residuals
  int iterations = 0;
  bool converged = false;
  bool diverged = false;
  std::vector<ViewStatistics> views;
  std::size_t samples = 0, inliers = 0;  // over all views
  std::size_t depth_points = 0, depth_inliers = 0;
  double edge_rms = 0;   // px, over the inliers
  double depth_rms = 0;  // m, over the depth inliers
  double inlierRatio() const { return samples ? double(inliers) / double(samples) : 0.0; }
};

/// Refines `initial` (reference_T_model). Fails (kNumericalFailure) when there are fewer than
/// min_measurements residuals or the normal equations are singular; divergence is reported in
/// the solution, which then holds the last iterate.
Result<PoseSolution> solvePose(const Eigen::Isometry3d& initial, std::span<const EdgeView> views,
                               const DepthPoints* depth, const PoseSolverOptions& options);

/// The sample's matched point of candidate `k` in pixels.
inline Eigen::Vector2d candidatePixel(const ContourSample& s, const EdgeCandidate& c) {
  return s.pixel + static_cast<double>(c.offset) * s.normal;
}

}  // namespace cdff::tracking
