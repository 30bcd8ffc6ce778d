#include "cdff/types/depth_metres.hpp"

#include <cmath>
#include <limits>

#include "cdff/types/opencv.hpp"

namespace cdff {

Result<cv::Mat> depthMetres(const DepthMap& map) {
  CDFF_RETURN_IF_ERROR(map.validate());
  cv::Mat metres;
  if (map.image.format == PixelFormat::kFloat32)
    metres = toMat(map.image).clone();
  else
    toMat(map.image).convertTo(metres, CV_32F, map.meters_per_unit);
  for (int r = 0; r < metres.rows; ++r) {
    float* row = metres.ptr<float>(r);
    for (int c = 0; c < metres.cols; ++c)
      if (!(row[c] > 0) || !std::isfinite(row[c])) row[c] = std::numeric_limits<float>::quiet_NaN();
  }
  return metres;
}

}  // namespace cdff
