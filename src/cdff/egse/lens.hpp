#pragma once
// Lens distortion of cdff::CameraModel (OpenCV's conventions: radial-tangential k1 k2 p1 p2
// [k3 [k4 k5 k6]], equidistant fisheye k1..k4), forwards and inverted.

#include <Eigen/Core>

#include "cdff/types/image.hpp"

namespace cdff::egse {

/// Distorts normalised pinhole coordinates (x/z, y/z).
Eigen::Vector2d distortNormalised(const CameraModel& camera, const Eigen::Vector2d& undistorted);
/// Inverts distortNormalised by Newton iterations (converges to 1e-12 for the distortion of
/// real lenses inside the image).
Eigen::Vector2d undistortNormalised(const CameraModel& camera, const Eigen::Vector2d& distorted);
/// The same from an initial guess (e.g. the neighbouring pixel's solution).
Eigen::Vector2d undistortNormalised(const CameraModel& camera, const Eigen::Vector2d& distorted,
                                    const Eigen::Vector2d& initial);
/// Pixel of a camera-frame point with distortion, as cv::projectPoints computes it.
Eigen::Vector2d projectWithDistortion(const CameraModel& camera, const Eigen::Vector3d& p_camera);
/// Unit ray (camera frame) of the distorted pixel (u, v).
Eigen::Vector3d pixelRay(const CameraModel& camera, double u, double v);

}  // namespace cdff::egse
