#pragma once
// A region of an image that follows a template (far-range tracking, seed §4.1.1): where the
// template's pixels lie in one image, as a homography, with how well they matched and how well
// the region's centre is known. A user's designation, a filter's prediction and a matcher's
// result are all regions.

#include <limits>
#include <string>

#include <Eigen/Core>

#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

struct ImageRegion {
  Timestamp stamp = 0;
  std::string frame_id;  // the camera's optical frame
  /// Template pixel (x, y, 1) -> image pixel, up to scale. Pixel centres are at integer
  /// coordinates in both (OpenCV's convention).
  Eigen::Matrix3d homography = Eigen::Matrix3d::Identity();
  int width = 0, height = 0;  // the template's size (px); the region is its image
  /// How well the template matched (ZNCC in [-1, 1]); NaN for a designation or a prediction.
  double score = std::numeric_limits<double>::quiet_NaN();
  /// Covariance of the centre's image position (px^2); zero when unknown.
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  /// Who made it: "user" or "automatic" (designations), "prediction", "match".
  std::string source;

  /// A designation of the box [x, x + width) x [y, y + height) of an image.
  static ImageRegion box(double x, double y, int width, int height);
  /// The image position of the template's centre ((width - 1) / 2, (height - 1) / 2).
  Eigen::Vector2d centre() const;
  /// The image position of template pixel (x, y).
  Eigen::Vector2d map(double x, double y) const;
  /// The region's scale: the square root of the homography's area ratio at the centre.
  double scale() const;

  /// Ok when the size is positive, the homography finite and invertible (at the centre: positive
  /// area ratio), the score NaN or in [-1, 1], the covariance finite, symmetric and positive
  /// semi-definite; the error names the field and its value.
  Status validate() const;
};

}  // namespace cdff
