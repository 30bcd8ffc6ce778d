#include <cmath>
#include <optional>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "StereoRectification.gen.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn {

namespace {

bool sameCalibration(const CameraModel& a, const CameraModel& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.distortion_model == b.distortion_model &&
         a.distortion == b.distortion;
}

bool sameExtrinsics(const Transform& a, const Transform& b) {
  return a.translation == b.translation && a.rotation.coeffs() == b.rotation.coeffs();
}

cv::Mat distortionOf(const CameraModel& camera) {
  return camera.distortion_model == DistortionModel::kNone ? cv::Mat()
                                                           : distortionCoefficients(camera);
}

// The distortion-free model of a rectified camera, from its 3x4 projection matrix.
CameraModel rectifiedModel(const cv::Mat& p, int width, int height) {
  CameraModel camera;
  camera.width = width;
  camera.height = height;
  camera.fx = p.at<double>(0, 0);
  camera.fy = p.at<double>(1, 1);
  camera.cx = p.at<double>(0, 2);
  camera.cy = p.at<double>(1, 2);
  camera.distortion_model = DistortionModel::kNone;
  return camera;
}

std::string rectifiedFrame(const std::string& frame) {
  return frame.empty() ? frame : frame + "_rectified";
}

}  // namespace

class StereoRectificationOpenCV final : public StereoRectificationOpenCVBase {
 protected:
  Status onConfigure() override {
    // The maps depend on alpha, zero_disparity and (rounding) interpolation.
    cache_.reset();
    return Status::ok();
  }

  Status onProcess() override {
    const StereoImagePair& pair = *in.stereo;
    CDFF_RETURN_IF_ERROR(pair.validate().withContext("input 'stereo'"));
    for (const auto& [image, what] : {std::pair{&pair.left, "input 'stereo' left image"},
                                      std::pair{&pair.right, "input 'stereo' right image"}}) {
      CDFF_RETURN_IF_ERROR(image->validate(what, {PixelFormat::kGray8, PixelFormat::kBgr8,
                                                  PixelFormat::kGray16, PixelFormat::kFloat32}));
    }
    if (pair.left.format != pair.right.format)
      return invalidInput(
          "input 'stereo' images differ in pixel format: left {}, right {}; expected the same "
          "format",
          toString(pair.left.format), toString(pair.right.format));
    const CameraModel& left = *pair.left.camera;
    const CameraModel& right = *pair.right.camera;
    const bool left_fisheye = left.distortion_model == DistortionModel::kEquidistant;
    const bool right_fisheye = right.distortion_model == DistortionModel::kEquidistant;
    if (left_fisheye != right_fisheye)
      return invalidInput(
          "input 'stereo' mixes distortion models: left {}, right {}; expected both "
          "equidistant or neither",
          toString(left.distortion_model), toString(right.distortion_model));
    const double baseline = pair.right_T_left.translation.norm();
    if (!(baseline >= params_.min_baseline))
      return invalidInput(
          "input 'stereo' baseline |right_T_left.translation| is {} m; expected >= "
          "min_baseline ({} m)",
          baseline, params_.min_baseline);

    if (!cache_ || !sameCalibration(cache_->left, left) || !sameCalibration(cache_->right, right) ||
        !sameExtrinsics(cache_->right_T_left, pair.right_T_left)) {
      CDFF_RETURN_IF_ERROR(buildMaps(left, right, pair.right_T_left, left_fisheye));
    }
    const Calibration& calibration = *cache_;

    const int interpolation = params_.interpolation == "nearest" ? cv::INTER_NEAREST
                              : params_.interpolation == "cubic" ? cv::INTER_CUBIC
                                                                 : cv::INTER_LINEAR;
    cv::Mat left_rect, right_rect;
    cv::remap(toMat(pair.left), left_rect, left_map1_, left_map2_, interpolation,
              cv::BORDER_CONSTANT, cv::Scalar::all(0));
    cv::remap(toMat(pair.right), right_rect, right_map1_, right_map2_, interpolation,
              cv::BORDER_CONSTANT, cv::Scalar::all(0));

    StereoImagePair rectified;
    Result<Image> l = fromMat(left_rect, pair.left.stamp, rectifiedFrame(pair.left.frame_id));
    if (!l) return l.status();
    Result<Image> r = fromMat(right_rect, pair.right.stamp, rectifiedFrame(pair.right.frame_id));
    if (!r) return r.status();
    rectified.left = std::move(l).value();
    rectified.right = std::move(r).value();
    rectified.left.camera = calibration.left_rectified;
    rectified.right.camera = calibration.right_rectified;
    rectified.right_T_left.stamp = pair.right_T_left.stamp;
    rectified.right_T_left.parent_frame = rectifiedFrame(pair.right_T_left.parent_frame);
    rectified.right_T_left.child_frame = rectifiedFrame(pair.right_T_left.child_frame);
    rectified.right_T_left.translation = Eigen::Vector3d(calibration.tx, 0, 0);
    out.rectified.set(std::move(rectified));
    out.baseline.set(std::abs(calibration.tx));
    Transform left_T_rectified;
    left_T_rectified.stamp = pair.left.stamp;
    left_T_rectified.parent_frame = pair.left.frame_id;
    left_T_rectified.child_frame = rectifiedFrame(pair.left.frame_id);
    left_T_rectified.rotation = calibration.left_q_rectified;
    out.rectified_frame.set(std::move(left_T_rectified));
    return Status::ok();
  }

 private:
  struct Calibration {
    CameraModel left, right;
    Transform right_T_left;
    CameraModel left_rectified, right_rectified;
    double tx = 0;  // m, x of the left rectified origin in the right rectified frame
    // The rectified left frame's attitude in the original left optical frame: R1^T, R1 being
    // OpenCV's rotation of points from the original into the rectified frame.
    Eigen::Quaterniond left_q_rectified = Eigen::Quaterniond::Identity();
  };

  Status buildMaps(const CameraModel& left, const CameraModel& right, const Transform& right_T_left,
                   bool fisheye) {
    // A failed rebuild must not leave maps that claim to belong to the new calibration.
    cache_.reset();
    const cv::Size size(left.width, left.height);
    const Eigen::Matrix3d rotation = right_T_left.rotation.normalized().toRotationMatrix();
    const Eigen::Vector3d translation = right_T_left.translation;
    cv::Mat r(3, 3, CV_64F), t(3, 1, CV_64F);
    for (int i = 0; i < 3; ++i) {
      t.at<double>(i) = translation(i);
      for (int j = 0; j < 3; ++j) r.at<double>(i, j) = rotation(i, j);
    }
    const cv::Mat k1 = cameraMatrix(left), k2 = cameraMatrix(right);
    const cv::Mat d1 = distortionOf(left), d2 = distortionOf(right);
    const int flags = params_.zero_disparity ? cv::CALIB_ZERO_DISPARITY : 0;
    cv::Mat r1, r2, p1, p2, q;
    Calibration calibration;
    if (fisheye) {
      cv::fisheye::stereoRectify(k1, d1, k2, d2, size, r, t, r1, r2, p1, p2, q, flags, size,
                                 params_.alpha, 1.0);
    } else {
      cv::stereoRectify(k1, d1, k2, d2, size, r, t, r1, r2, p1, p2, q, flags, params_.alpha, size);
    }
    p1.convertTo(p1, CV_64F);
    p2.convertTo(p2, CV_64F);
    if (!cv::checkRange(p1) || !cv::checkRange(p2) || !(p1.at<double>(0, 0) > 0) ||
        !(p1.at<double>(1, 1) > 0))
      return numericalFailure(
          "stereo rectification gave a degenerate projection (left fx={}, fy={}); expected "
          "finite focal lengths > 0: is the calibration consistent?",
          p1.at<double>(0, 0), p1.at<double>(1, 1));
    // OpenCV rectifies vertical rigs column-wise (the offset lands in P2(1,3)): not row-aligned.
    if (std::abs(p2.at<double>(1, 3)) > std::abs(p2.at<double>(0, 3)))
      return invalidInput(
          "input 'stereo' baseline ({:.4g}, {:.4g}, {:.4g}) m is mostly vertical; expected a "
          "horizontal rig (|x| >= |y|) for row-aligned rectification",
          translation.x(), translation.y(), translation.z());
    buildMap(k1, d1, r1, p1, size, fisheye, left_map1_, left_map2_);
    buildMap(k2, d2, r2, p2, size, fisheye, right_map1_, right_map2_);
    calibration.left = left;
    calibration.right = right;
    calibration.right_T_left = right_T_left;
    calibration.left_rectified = rectifiedModel(p1, left.width, left.height);
    calibration.right_rectified = rectifiedModel(p2, right.width, right.height);
    calibration.tx = p2.at<double>(0, 3) / p2.at<double>(0, 0);
    cv::Mat r1d;
    r1.convertTo(r1d, CV_64F);
    Eigen::Matrix3d rectify;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) rectify(i, j) = r1d.at<double>(i, j);
    calibration.left_q_rectified = Eigen::Quaterniond(rectify.transpose()).normalized();
    cache_ = std::move(calibration);
    return Status::ok();
  }

  // Fixed-point maps (CV_16SC2 + CV_16UC1, remap's fastest form). Built directly, they round
  // each coordinate to 1/32 px but keep its integer part truncated, which nearest-neighbour
  // remap uses as is (half a pixel of bias): for nearest, float maps are rounded by convertMaps
  // instead. Buffers are reused across rebuilds (fresh pages cost more than the maps).
  void buildMap(const cv::Mat& k, const cv::Mat& d, const cv::Mat& r, const cv::Mat& p,
                const cv::Size& size, bool fisheye, cv::Mat& map1, cv::Mat& map2) {
    const bool nearest = params_.interpolation == "nearest";
    const int type = nearest ? CV_32FC1 : CV_16SC2;
    cv::Mat& x = nearest ? scratch_x_ : map1;
    cv::Mat& y = nearest ? scratch_y_ : map2;
    if (fisheye)
      cv::fisheye::initUndistortRectifyMap(k, d, r, p, size, type, x, y);
    else
      cv::initUndistortRectifyMap(k, d, r, p, size, type, x, y);
    if (nearest) cv::convertMaps(scratch_x_, scratch_y_, map1, map2, CV_16SC2, true);
  }

  std::optional<Calibration> cache_;  // what the maps belong to; none: no valid maps
  cv::Mat left_map1_, left_map2_, right_map1_, right_map2_;
  cv::Mat scratch_x_, scratch_y_;  // float maps, for nearest only
};

CDFF_REGISTER_DFI(StereoRectificationOpenCV);

}  // namespace cdff::dfn
