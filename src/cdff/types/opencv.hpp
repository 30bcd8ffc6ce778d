#pragma once
// Conversions between CDFF types and OpenCV. Views share memory; the functions that copy say so.

#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/types.hpp>

#include "cdff/types/features.hpp"
#include "cdff/types/image.hpp"

namespace cdff {

/// The OpenCV type (CV_8UC1, ...) of a pixel format.
int cvType(PixelFormat format);

/// A cv::Mat header over the image's pixels (no copy). The Mat keeps the pixels alive. CDFF
/// images are immutable: do not write through the returned Mat (clone() it first).
cv::Mat toMat(const Image& image);

/// Wraps a cv::Mat as an Image without copying; the Image keeps the Mat's data alive. The caller
/// must not write into `mat` afterwards. Fails for types other than 8UC1, 8UC3, 16UC1, 32FC1.
Result<Image> fromMat(const cv::Mat& mat, Timestamp stamp = 0, std::string frame_id = {});

/// K as a 3x3 CV_64F matrix and the distortion coefficients as a 1xN CV_64F row (copies).
cv::Mat cameraMatrix(const CameraModel& camera);
cv::Mat distortionCoefficients(const CameraModel& camera);

/// The normalised image coordinates (x/z, y/z in the optical frame) of `pixels` seen by
/// `camera`, its distortion removed (cv::undistortPoints; cv::fisheye::undistortPoints for the
/// equidistant model). Copies. A camera model that does not validate, a non-finite pixel or an
/// OpenCV failure is an error naming `what`.
Result<std::vector<Eigen::Vector2d>> normalizedCoordinates(
    const CameraModel& camera, const std::vector<Eigen::Vector2d>& pixels, const char* what);

/// The camera of an image halved `levels` times by cv::pyrDown: (w + 1) / 2 pixels, output pixel
/// j the Gaussian-weighted input centred on pixel 2j, so x' = x / 2 (distortion kept as it is,
/// meaningful only without).
CameraModel cameraAfterPyrDown(CameraModel camera, int levels);
/// `image` halved `levels` times by cv::pyrDown (the same Mat when levels is 0).
cv::Mat pyrDownTimes(const cv::Mat& image, int levels);

/// Descriptor views (no copy) and wrap (no copy; keeps the Mat alive).
cv::Mat toMat(const DescriptorMatrix& descriptors);
Result<DescriptorMatrix> descriptorsFromMat(const cv::Mat& mat);

/// Points as OpenCV points (copies).
std::vector<cv::Point2d> toCvPoints(const std::vector<Eigen::Vector2d>& points);

/// Keypoint conversions (copies: the layouts differ).
std::vector<cv::KeyPoint> toCvKeypoints(const std::vector<Keypoint2D>& keypoints);
std::vector<Keypoint2D> fromCvKeypoints(const std::vector<cv::KeyPoint>& keypoints);

}  // namespace cdff
