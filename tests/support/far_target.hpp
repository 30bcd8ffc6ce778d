#pragma once
// A synthetic far-range target for the template matcher's tests and benchmark: a bright bus with
// a radiator and a dish between two solar wings with cells, with soft edges (0.3 px) so that the
// rendered image is a smooth function of its sub-pixel position, rendered by 4 x 4 supersampling
// through a Gaussian blur of 0.7 px with read noise (background 3 DN, 1.5 DN RMS).
#include <random>

#include <Eigen/Core>

#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"

namespace cdff::testing {

/// A `size` x `size` 8-bit image of the target centred at `centre` (px), `scale` px per target
/// unit (the bus spans 2 units, the wings 6.4), turned by `angle` (rad) in the image plane.
Image renderFarTarget(const Eigen::Vector2d& centre, double scale, double angle, std::mt19937& rng,
                      Timestamp stamp, int size = 256);

/// far_range_approach's narrow-angle camera: 35 mm, 5.5 um pixels, 1024 x 1024, no distortion.
CameraModel farCamera();
/// Its mounting servicer_T_camera_far_optical: looking along the servicer's x (optical x = -y,
/// y = -z), 0.45 m forward and 0.05 m up.
Transform farCameraMount();
/// A servicer attitude lvlh_R_servicer whose x axis points at `p` (lvlh) with its z as close to
/// radial up as it can be (far_range_approach's target pointing), turned by `jitter` (rad, its
/// own axes).
Eigen::Matrix3d servicerPointingAt(const Eigen::Vector3d& p,
                                   const Eigen::Vector3d& jitter = Eigen::Vector3d::Zero());

}  // namespace cdff::testing
