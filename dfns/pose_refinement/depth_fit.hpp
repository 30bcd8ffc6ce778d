#pragma once
// What PoseRefinement/DepthIcp measures a pose against: the measured points near the target
// (from a depth map), the model's shape (its bounding sphere and a subsample of its surface),
// and the two-sided score of a pose at the depth's noise.

#include <cmath>
#include <cstddef>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "cdff/registration/model_index.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff::pose_refinement {

/// The depth's noise, 1 sigma: constant + quadratic z^2 (a ToF camera's description; for stereo
/// the disparity noise over f B).
struct DepthNoise {
  double constant = 0.005;    // m
  double quadratic = 0.0017;  // 1/m
  double sigma(double z) const { return constant + quadratic * z * z; }
};

/// A depth map as metres (32FC1, NaN where none) with its camera.
struct MeasuredDepth {
  cv::Mat metres;
  CameraModel camera;
};

/// The depth map checked (a distortion-free camera model, 32FC1 metres or 16UC1 units) and
/// converted; `port` names it in errors.
Result<MeasuredDepth> measuredDepth(const DepthMap& map, const std::string& port);

/// The measured points (camera frame) within `radius` of `centre`, evenly strided to at most
/// `max_points`, into `out`.
void pointsNear(const MeasuredDepth& depth, const Eigen::Vector3d& centre, double radius,
                std::size_t max_points, std::vector<Eigen::Vector3f>& out);

/// The model's shape: bounding sphere (of its axis-aligned box), a strided subsample of its
/// points and normals and that subsample's spacing.
struct ModelShape {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0;
  std::vector<Eigen::Vector3f> points, normals;
  std::vector<float> reflectivity;  // per subsample point; empty when the model has none
  double spacing = 0;               // m, between neighbouring subsample points
};

/// The shape of `index`'s model with a subsample of about `samples` points; `reflectivity`:
/// per point of the index (the model cloud's intensity), or empty.
ModelShape modelShape(const registration::ModelIndex& index, std::size_t samples,
                      std::span<const float> reflectivity = {});

/// What a depth camera returns: a ToF camera measures a surface only where its return,
/// reflectivity x |cos(incidence)| / range^2, reaches min_amplitude (0: everywhere).
struct DepthReturn {
  double min_amplitude = 0;  // 1/m^2
  /// Whether the camera surely measures point `p` (camera frame) of normal `n` and reflectivity
  /// `reflectivity`: its return at least twice the threshold (the model's reflectivities are
  /// nominal).
  bool sure(const Eigen::Vector3d& p, const Eigen::Vector3d& n, float reflectivity) const {
    return min_amplitude <= 0 || predicted(p, n, reflectivity) >= 2 * min_amplitude;
  }
  /// The return of point `p` (camera frame) of normal `n`: reflectivity x |cos| / range^2.
  static double predicted(const Eigen::Vector3d& p, const Eigen::Vector3d& n, float reflectivity) {
    const double r2 = p.squaredNorm();
    return reflectivity * std::abs(n.dot(p)) / (r2 * std::sqrt(r2));
  }
};

/// The starts of a candidate camera_T_model: itself and itself moved by each of `symmetries`
/// (model_T_model motions x -> s x: the candidate times s).
std::vector<Eigen::Isometry3d> startsOf(const Eigen::Isometry3d& candidate,
                                        std::span<const Eigen::Isometry3d> symmetries);

/// How well a pose explains the depth (the output ports' fitness, confirmed and misfit).
struct Score {
  double misfit = 0;     // mean cost per measured point and shown model point, (r/sigma)^2 <= 9
  double fitness = 0;    // measured points with a model point within 3 sigma
  double confirmed = 0;  // shown model points whose depth agrees within 3 sigma
  std::size_t measured = 0, shown = 0;
};

/// The cost of a point without a counterpart, (3 sigma / sigma)^2.
inline constexpr double kUnexplainedCost = 9.0;

/// The model side of the score at camera_T_model `pose`: the subsample points facing the camera,
/// inside the image and not hidden behind nearer ones (a z-buffer whose cells span the
/// subsample's spacing), compared with the measured depth at their pixel; one without a depth
/// costs `missing_cost` where the camera surely measures it (`returns`; elsewhere none is
/// expected and it costs 1, a right point's expected cost). Returns their summed cost and sets
/// score.shown and score.confirmed (of the shown points with a depth or a sure return).
double shownModelCost(const Eigen::Isometry3d& pose, const ModelShape& shape,
                      const MeasuredDepth& depth, double sigma, double missing_cost,
                      const DepthReturn& returns, Score& score);

}  // namespace cdff::pose_refinement
