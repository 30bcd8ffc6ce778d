#pragma once
// Synthetic images of polygon models with exact ground truth, for the model-based tracking tests:
// an anti-aliased grey image (supersampled z-buffer, flat-shaded faces), a depth map, and a few
// simple models.

#include <cstdint>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "cdff/types/image.hpp"
#include "cdff/types/polygon_model.hpp"

namespace cdff::testing {

struct RenderOptions {
  double background = 30;  // grey level behind the model
  int supersample = 4;     // sub-pixels per pixel along each axis (anti-aliasing)
  double noise_sigma = 0;  // grey levels of white Gaussian noise
  std::uint32_t seed = 1;
  double gain = 1.0;  // scales the shaded intensities (under- and over-exposure)
};

/// 8UC1 image of `model` seen from camera_T_model: faces flat-shaded by their orientation to a
/// light along the camera's view, both sides, nearest surface wins.
cv::Mat renderModel(const PolygonModel& model, const CameraModel& camera,
                    const Eigen::Isometry3d& camera_T_model, const RenderOptions& options = {});
/// 32FC1 depth (z, metres) of the nearest surface at each pixel centre, 0 where none.
cv::Mat renderDepth(const PolygonModel& model, const CameraModel& camera,
                    const Eigen::Isometry3d& camera_T_model);

/// A closed box of the given edge lengths centred at the origin (6 faces, outward normals).
PolygonModel boxModel(const Eigen::Vector3d& size);
/// An L-shaped prism: a non-convex model whose parts hide one another.
PolygonModel lShapeModel(double size);

/// camera_T_model for a camera at `eye` (model frame) looking at `target` with the image's y axis
/// as close to `down` as possible.
Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                         const Eigen::Vector3d& down = Eigen::Vector3d(0, 0, -1));

}  // namespace cdff::testing
