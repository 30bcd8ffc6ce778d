#include <opencv2/calib3d.hpp>

#include "ImageUndistortion.gen.hpp"
#include "cdff/types/opencv.hpp"
#include "undistortion_common.hpp"

namespace cdff::dfn {

class ImageUndistortionDirect final : public ImageUndistortionDirectBase {
 protected:
  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(undistortion::validateInput(*in.image));
    const Image& image = *in.image;
    const CameraModel& camera = *image.camera;
    if (undistortion::isIdentity(camera, params_.new_camera_matrix)) {
      undistortion::publishIdentity(image, out.undistorted);
      return Status::ok();
    }
    Result<cv::Mat> new_k =
        undistortion::newCameraMatrix(camera, params_.new_camera_matrix, params_.alpha);
    if (!new_k) return new_k.status();
    const cv::Mat k = cameraMatrix(camera);
    const cv::Mat src = toMat(image);
    cv::Mat undistorted;
    if (camera.distortion_model == DistortionModel::kEquidistant) {
      cv::fisheye::undistortImage(src, undistorted, k, distortionCoefficients(camera), *new_k,
                                  src.size());
    } else {
      const cv::Mat d = camera.distortion_model == DistortionModel::kNone
                            ? cv::Mat()
                            : distortionCoefficients(camera);
      cv::undistort(src, undistorted, k, d, *new_k);
    }
    return undistortion::publish(image, undistorted, undistortion::pinholeModel(camera, *new_k),
                                 out.undistorted);
  }
};

CDFF_REGISTER_DFI(ImageUndistortionDirect);

}  // namespace cdff::dfn
