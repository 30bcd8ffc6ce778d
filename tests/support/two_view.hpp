#pragma once
// Two synthetic views of random 3D points with known truth, for the two-view geometry DFNs'
// tests and benchmark (FundamentalMatrixEstimation, EssentialMatrixEstimation, Triangulation,
// PerspectiveNPoint). No GoogleTest: the benchmark compiles it too.
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/features.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"

namespace cdff::testing {

struct TwoViewOptions {
  int points = 200;
  double sigma_px = 0.5;          // Gaussian pixel noise on both views
  double outlier_fraction = 0.0;  // pairs whose second pixel is replaced by a random one
  double baseline = 0.5;          // m, the second camera's distance from the first
  bool planar = false;            // all points on one plane (z = 5 + 0.3 x - 0.2 y)
  std::uint32_t seed = 1;
};

struct TwoViewScene {
  CameraModel camera;                   // both views: 1024 x 768, f = 800 px, no distortion
  Transform first_T_second;             // the second camera's pose in the first camera's frame
  std::vector<Eigen::Vector3d> points;  // m, in the first camera's frame
  Correspondences2D truth;              // noise-free projections (also of the outliers' points)
  Correspondences2D observed;           // with noise and the outliers
  std::vector<bool> inlier;             // false for the injected outliers
};

/// Points in a 3 m x 2 m x 3 m box 4-7 m in front of the first camera (or on a plane), seen in
/// both views; the second camera `baseline` to the side and turned towards the points' centre.
TwoViewScene twoViewScene(const TwoViewOptions& options);

/// The fundamental matrix of the scene, x2^T F x1 = 0, unit Frobenius norm, F(2,2) >= 0.
Eigen::Matrix3d trueFundamental(const TwoViewScene& scene);

/// The distance (px) of pixel x2 to the epipolar line F x1, averaged with that of x1 to F^T x2.
double epipolarDistance(const Eigen::Matrix3d& f, const Eigen::Vector2d& x1,
                        const Eigen::Vector2d& x2);

/// The signed Sampson distance (px) of the pair (x1, x2) to x2^T F x1 = 0: the first-order
/// distance of the pair in the joint 4D space, of variance sigma^2 with iid pixel noise sigma.
double sampsonDistance(const Eigen::Matrix3d& f, const Eigen::Vector2d& x1,
                       const Eigen::Vector2d& x2);

}  // namespace cdff::testing
