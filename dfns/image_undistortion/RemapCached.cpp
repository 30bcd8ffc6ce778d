#include <optional>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "ImageUndistortion.gen.hpp"
#include "cdff/types/opencv.hpp"
#include "undistortion_common.hpp"

namespace cdff::dfn {

class ImageUndistortionRemapCached final : public ImageUndistortionRemapCachedBase {
 protected:
  Status onConfigure() override {
    // The maps depend on new_camera_matrix, alpha and (rounding) interpolation.
    source_.reset();
    return Status::ok();
  }

  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(undistortion::validateInput(*in.image));
    const Image& image = *in.image;
    const CameraModel& camera = *image.camera;
    if (undistortion::isIdentity(camera, params_.new_camera_matrix)) {
      undistortion::publishIdentity(image, out.undistorted);
      return Status::ok();
    }
    if (!source_ || !undistortion::sameCalibration(*source_, camera)) {
      CDFF_RETURN_IF_ERROR(buildMaps(camera));
    }
    cv::Mat undistorted;
    cv::remap(toMat(image), undistorted, map1_, map2_,
              undistortion::interpolationFlag(params_.interpolation), cv::BORDER_CONSTANT,
              cv::Scalar::all(0));
    return undistortion::publish(image, undistorted, target_, out.undistorted);
  }

 private:
  Status buildMaps(const CameraModel& camera) {
    // A failed rebuild must not leave maps that claim to belong to the new camera.
    source_.reset();
    Result<cv::Mat> new_k =
        undistortion::newCameraMatrix(camera, params_.new_camera_matrix, params_.alpha);
    if (!new_k) return new_k.status();
    const cv::Mat k = cameraMatrix(camera);
    const cv::Mat r = cv::Mat::eye(3, 3, CV_64F);
    const cv::Size size(camera.width, camera.height);
    const bool fisheye = camera.distortion_model == DistortionModel::kEquidistant;
    const cv::Mat d = camera.distortion_model == DistortionModel::kNone
                          ? cv::Mat()
                          : distortionCoefficients(camera);
    // Fixed-point maps built directly round each coordinate to 1/32 px but keep its integer
    // part truncated, which nearest-neighbour remap uses as is (half a pixel of bias): for
    // nearest, float maps are rounded by convertMaps instead. The buffers are reused from one
    // rebuild to the next (allocating 10-20 MB of fresh pages each time costs more than
    // computing the maps).
    const bool nearest = params_.interpolation == "nearest";
    const int type = nearest ? CV_32FC1 : CV_16SC2;
    cv::Mat& x = nearest ? scratch_x_ : map1_;
    cv::Mat& y = nearest ? scratch_y_ : map2_;
    if (fisheye)
      cv::fisheye::initUndistortRectifyMap(k, d, r, *new_k, size, type, x, y);
    else
      cv::initUndistortRectifyMap(k, d, r, *new_k, size, type, x, y);
    if (nearest) cv::convertMaps(scratch_x_, scratch_y_, map1_, map2_, CV_16SC2, true);
    source_ = camera;
    target_ = undistortion::pinholeModel(camera, *new_k);
    return Status::ok();
  }

  std::optional<CameraModel> source_;  // the camera the maps belong to; none: no valid maps
  CameraModel target_;                 // the undistorted model the maps produce
  cv::Mat map1_, map2_;                // fixed point (CV_16SC2 + CV_16UC1): remap's fastest form
  cv::Mat scratch_x_, scratch_y_;      // float maps, for nearest only
};

CDFF_REGISTER_DFI(ImageUndistortionRemapCached);

}  // namespace cdff::dfn
