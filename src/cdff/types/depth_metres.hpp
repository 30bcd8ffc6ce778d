#pragma once
// A depth map as an OpenCV matrix of metres, the form the depth consumers (template detection,
// pose refinement) compute on, and as the points it measured (the point cloud consumers).

#include <opencv2/core.hpp>

#include "cdff/types/image.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff {

/// `map` checked (DepthMap::validate) and converted to 32FC1 metres (a copy), NaN where it has
/// no measurement (0, negative or non-finite).
Result<cv::Mat> depthMetres(const DepthMap& map);

/// The measurements of `map` as points in its frame (the camera's optical frame, z along the
/// axis; stamp and frame_id the map's): each pixel undistorted with the map's calibration and
/// scaled by its depth along the axis, every `stride`-th pixel in each direction, those without
/// a measurement left out. An error when the map is not valid, has no calibration or `stride`
/// is below 1.
Result<PointCloud> pointsOfDepth(const DepthMap& map, int stride = 1);

}  // namespace cdff
