#include "support/far_target.hpp"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "cdff/types/opencv.hpp"

namespace cdff::testing {
namespace {

/// A soft edge: 0 outside, 1 inside, `d` the signed distance inside (px), 0.3 px wide, so that
/// the rendered image is a smooth function of the target's sub-pixel position (a hard edge
/// sampled on a grid moves in steps of the grid).
double inside(double d) {
  return 0.5 + 0.5 * std::tanh(d / 0.3);
}

/// Brightness of the target at target coordinates (u, v), `scale` px per unit: a bus spanning
/// [-1, 1] x [-0.8, 0.8] with a radiator and a dish, between two solar wings with cells.
double targetAt(double u, double v, double scale) {
  auto box = [&](double cu, double cv, double hu, double hv) {
    return inside((hu - std::abs(u - cu)) * scale) * inside((hv - std::abs(v - cv)) * scale);
  };
  const double bus = box(0, 0, 1.0, 0.8), radiator = box(0.4, -0.3, 0.15, 0.2);
  const double dish = inside((0.2 - std::hypot(u + 0.5, v - 0.4)) * scale);
  const double wings = box(0, 0, 3.2, 0.35) * (1 - bus);
  return bus * (180 + 60 * radiator - 90 * dish) + wings * (90 + 25 * std::cos(2 * M_PI * u / 0.5));
}

}  // namespace

/// The target with its centre at `centre` (px) and `scale` px per target unit, in-plane angle
/// `angle`; 4x4 supersampling, a Gaussian blur of 0.7 px, background 3 DN, read noise 1.5 DN.
Image renderFarTarget(const Eigen::Vector2d& centre, double scale, double angle, std::mt19937& rng,
                      Timestamp stamp, int size) {
  cv::Mat fine(size * 4, size * 4, CV_32F);
  const double c = std::cos(angle), s = std::sin(angle);
  for (int y = 0; y < fine.rows; ++y)
    for (int x = 0; x < fine.cols; ++x) {
      const double px = (x + 0.5) / 4.0 - 0.5 - centre.x(), py = (y + 0.5) / 4.0 - 0.5 - centre.y();
      fine.at<float>(y, x) = static_cast<float>(
          targetAt((c * px + s * py) / scale, (-s * px + c * py) / scale, scale));
    }
  cv::Mat pixels;
  cv::resize(fine, pixels, cv::Size(size, size), 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(pixels, pixels, cv::Size(0, 0), 0.7);
  std::normal_distribution<float> noise(3.0f, 1.5f);
  for (float& p : cv::Mat_<float>(pixels)) p += noise(rng);
  cv::Mat bytes;
  pixels.convertTo(bytes, CV_8U);
  Result<Image> image = fromMat(bytes, stamp, "camera_far_optical");
  return image ? std::move(image).value() : Image{};  // an 8-bit Mat always converts
}

CameraModel farCamera() {
  CameraModel c;
  c.width = c.height = 1024;
  c.fx = c.fy = 0.035 / 5.5e-6;
  c.cx = c.cy = 511.5;
  return c;
}

Transform farCameraMount() {
  Transform t = Transform::identity("servicer", "camera_far_optical");
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d(0, -1, 0);  // optical x: right = -servicer y
  r.col(1) = Eigen::Vector3d(0, 0, -1);  // optical y: down = -servicer z
  r.col(2) = Eigen::Vector3d(1, 0, 0);   // optical z: forward = servicer x
  t.rotation = Eigen::Quaterniond(r);
  t.translation = Eigen::Vector3d(0.45, 0, 0.05);
  return t;
}

Eigen::Matrix3d servicerPointingAt(const Eigen::Vector3d& p, const Eigen::Vector3d& jitter) {
  const Eigen::Vector3d x = p.normalized();
  const Eigen::Vector3d y = Eigen::Vector3d::UnitX().cross(x).normalized();
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = y;
  r.col(2) = x.cross(y);
  return r * expSO3(jitter).toRotationMatrix();
}

}  // namespace cdff::testing
