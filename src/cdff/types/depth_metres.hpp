#pragma once
// A depth map as an OpenCV matrix of metres, the form the depth consumers (template detection,
// pose refinement) compute on.

#include <opencv2/core.hpp>

#include "cdff/types/image.hpp"
#include "cdff/types/status.hpp"

namespace cdff {

/// `map` checked (DepthMap::validate) and converted to 32FC1 metres (a copy), NaN where it has
/// no measurement (0, negative or non-finite).
Result<cv::Mat> depthMetres(const DepthMap& map);

}  // namespace cdff
