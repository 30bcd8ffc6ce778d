#pragma once
// Shared by the ImageUndistortion DFIs: input checks, the new camera matrix and publishing, so
// that both DFIs produce the same camera model for the same input.

#include <cmath>
#include <optional>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "cdff/dfn/port.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn::undistortion {

inline Status validateInput(const Image& image) {
  CDFF_RETURN_IF_ERROR(image.validate(
      "input 'image'",
      {PixelFormat::kGray8, PixelFormat::kBgr8, PixelFormat::kGray16, PixelFormat::kFloat32}));
  if (!image.camera)
    return invalidInput(
        "input 'image' ({}x{}) has no camera model; expected the calibrated "
        "model of the camera that took it",
        image.width, image.height);
  return Status::ok();
}

inline bool sameCalibration(const CameraModel& a, const CameraModel& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.distortion_model == b.distortion_model &&
         a.distortion == b.distortion;
}

/// With no distortion and K kept, undistortion is the identity: the pixels can be shared.
inline bool isIdentity(const CameraModel& camera, const std::string& policy) {
  return !camera.hasDistortion() && policy == "keep";
}

/// The undistorted camera's K (3x3 CV_64F) for `policy` ("keep" or "optimal") and `alpha`.
inline Result<cv::Mat> newCameraMatrix(const CameraModel& camera, const std::string& policy,
                                       double alpha) {
  const cv::Mat k = cameraMatrix(camera);
  if (policy == "keep") return k;
  const cv::Size size(camera.width, camera.height);
  cv::Mat new_k;
  if (camera.distortion_model == DistortionModel::kEquidistant) {
    cv::fisheye::estimateNewCameraMatrixForUndistortRectify(
        k, distortionCoefficients(camera), size, cv::Mat::eye(3, 3, CV_64F), new_k, alpha, size);
  } else {
    const cv::Mat d = camera.distortion_model == DistortionModel::kNone
                          ? cv::Mat()
                          : distortionCoefficients(camera);
    new_k = cv::getOptimalNewCameraMatrix(k, d, size, alpha, size, nullptr, false);
  }
  new_k.convertTo(new_k, CV_64F);
  const double fx = new_k.at<double>(0, 0), fy = new_k.at<double>(1, 1);
  // A distortion so strong that the model folds over inside the image gives a degenerate matrix.
  if (!cv::checkRange(new_k) || !(fx > 0) || !(fy > 0))
    return numericalFailure(
        "optimal new camera matrix (alpha {}) is degenerate (fx={}, fy={}); "
        "expected finite focal lengths > 0: is the distortion model valid "
        "over the whole {}x{} image?",
        alpha, fx, fy, camera.width, camera.height);
  return new_k;
}

/// The distortion-free pinhole model of K = new_k for images of the camera's size.
inline CameraModel pinholeModel(const CameraModel& camera, const cv::Mat& new_k) {
  CameraModel out;
  out.width = camera.width;
  out.height = camera.height;
  out.fx = new_k.at<double>(0, 0);
  out.fy = new_k.at<double>(1, 1);
  out.cx = new_k.at<double>(0, 2);
  out.cy = new_k.at<double>(1, 2);
  out.distortion_model = DistortionModel::kNone;
  return out;
}

inline Status publish(const Image& input, const cv::Mat& undistorted, const CameraModel& camera,
                      OutputPort<Image>& out) {
  Result<Image> image = fromMat(undistorted, input.stamp, input.frame_id);
  if (!image) return image.status();
  image->camera = camera;
  out.set(std::move(image).value());
  return Status::ok();
}

/// Shares the input's pixels, relabelled with the distortion-free model.
inline void publishIdentity(const Image& input, OutputPort<Image>& out) {
  Image image = input;
  image.camera = pinholeModel(*input.camera, cameraMatrix(*input.camera));
  out.set(std::move(image));
}

inline int interpolationFlag(const std::string& name) {
  if (name == "nearest") return cv::INTER_NEAREST;
  if (name == "cubic") return cv::INTER_CUBIC;
  return cv::INTER_LINEAR;
}

}  // namespace cdff::dfn::undistortion
