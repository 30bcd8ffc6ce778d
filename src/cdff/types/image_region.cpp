#include "cdff/types/image_region.hpp"

#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

namespace cdff {

ImageRegion ImageRegion::box(double x, double y, int width, int height) {
  ImageRegion r;
  r.homography(0, 2) = x;
  r.homography(1, 2) = y;
  r.width = width;
  r.height = height;
  return r;
}

Eigen::Vector2d ImageRegion::map(double x, double y) const {
  const Eigen::Vector3d p = homography * Eigen::Vector3d(x, y, 1.0);
  return p.head<2>() / p.z();
}

Eigen::Vector2d ImageRegion::centre() const {
  return map(0.5 * (width - 1), 0.5 * (height - 1));
}

double ImageRegion::scale() const {
  // The Jacobian of the mapping at the centre, by central differences of one pixel.
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1);
  const Eigen::Vector2d dx = 0.5 * (map(cx + 1, cy) - map(cx - 1, cy));
  const Eigen::Vector2d dy = 0.5 * (map(cx, cy + 1) - map(cx, cy - 1));
  const double area = dx.x() * dy.y() - dx.y() * dy.x();
  return area > 0 ? std::sqrt(area) : std::numeric_limits<double>::quiet_NaN();
}

Status ImageRegion::validate() const {
  const std::string what =
      fmt::format("image region in '{}' ({})", frame_id, source.empty() ? "no source" : source);
  if (width <= 0 || height <= 0)
    return invalidInput("{}: template size is {}x{} px; expected a positive size", what, width,
                        height);
  if (!homography.allFinite() || std::abs(homography.determinant()) < 1e-12)
    return invalidInput(
        "{}: homography [{}, {}, {}; {}, {}, {}; {}, {}, {}] is {}; expected a finite invertible "
        "3x3 matrix",
        what, homography(0, 0), homography(0, 1), homography(0, 2), homography(1, 0),
        homography(1, 1), homography(1, 2), homography(2, 0), homography(2, 1), homography(2, 2),
        homography.allFinite() ? "singular" : "not finite");
  if (const double s = scale(); !(s > 0))
    return invalidInput(
        "{}: the homography [{}, {}, {}; {}, {}, {}; {}, {}, {}] maps the {}x{} template's centre "
        "with a scale of {}; expected a positive scale (it folds the template there)",
        what, homography(0, 0), homography(0, 1), homography(0, 2), homography(1, 0),
        homography(1, 1), homography(1, 2), homography(2, 0), homography(2, 1), homography(2, 2),
        width, height, s);
  if (!std::isnan(score) && (score < -1 || score > 1))
    return invalidInput("{}: score is {}; expected NaN or a value in [-1, 1]", what, score);
  if (!covariance.allFinite() || std::abs(covariance(0, 1) - covariance(1, 0)) > 1e-9 ||
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(covariance).eigenvalues().minCoeff() < -1e-12)
    return invalidInput(
        "{}: centre covariance [{}, {}; {}, {}] px^2; expected finite, symmetric, positive "
        "semi-definite",
        what, covariance(0, 0), covariance(0, 1), covariance(1, 0), covariance(1, 1));
  return Status::ok();
}

}  // namespace cdff
