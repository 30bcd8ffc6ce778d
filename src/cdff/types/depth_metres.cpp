#include "cdff/types/depth_metres.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/calib3d.hpp>

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

Result<PointCloud> pointsOfDepth(const DepthMap& map, int stride) {
  if (stride < 1) return invalidParameter("stride is {}; expected 1 or more pixels", stride);
  if (!map.image.camera)
    return invalidInput(
        "depth map '{}' at {} us has no calibration; expected its camera model to project its "
        "pixels",
        map.image.frame_id, map.image.stamp);
  Result<cv::Mat> metres = depthMetres(map);
  if (!metres) return metres.status();
  std::vector<cv::Point2f> pixels;
  std::vector<float> depth;
  for (int v = 0; v < metres->rows; v += stride)
    for (int u = 0; u < metres->cols; u += stride)
      if (const float d = metres->at<float>(v, u); std::isfinite(d)) {
        pixels.emplace_back(static_cast<float>(u), static_cast<float>(v));
        depth.push_back(d);
      }
  std::vector<cv::Point2f> normalised;
  const CameraModel& camera = *map.image.camera;
  if (!pixels.empty() && camera.distortion_model == DistortionModel::kEquidistant)
    cv::fisheye::undistortPoints(pixels, normalised, cameraMatrix(camera),
                                 distortionCoefficients(camera));
  else if (!pixels.empty())
    cv::undistortPoints(pixels, normalised, cameraMatrix(camera), distortionCoefficients(camera));
  std::vector<Eigen::Vector3f> xyz;
  xyz.reserve(pixels.size());
  for (std::size_t i = 0; i < normalised.size(); ++i)
    xyz.emplace_back(normalised[i].x * depth[i], normalised[i].y * depth[i], depth[i]);
  return PointCloud::fromXyz(xyz, map.image.frame_id, map.image.stamp);
}

}  // namespace cdff
