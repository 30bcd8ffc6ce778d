#pragma once
// Shared by the StereoMatching DFIs: the checks that the pair is rectified, the disparity search
// range from the rig and the depth range, the pyramid, and the conversion of OpenCV's fixed-point
// disparity into the published disparity and depth, so that both DFIs differ only in the matcher.

#include <cmath>
#include <limits>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "cdff/types/image.hpp"
#include "cdff/types/opencv.hpp"
#include "cdff/types/status.hpp"

namespace cdff::dfn::stereo_matching {

/// The rig at the matching resolution and the disparity search that covers the depth range.
struct Search {
  CameraModel left;          // the left rectified camera at the matching resolution
  double baseline = 0;       // m
  double offset = 0;         // px, cx_left - cx_right at the matching resolution
  int min_disparity = 0;     // px, the search's first disparity
  int num_disparities = 16;  // px, a multiple of 16
  // px: the matches kept. A surface outside the search still gets a cost minimum at its end, so
  // the search reaches a pixel beyond each end of the depth range and matches there are dropped
  // (but at disparity 0, infinity, which nothing lies beyond).
  double lowest = 0, highest = 0;
  double min_depth = 0, max_depth = 0;  // m (max 0: infinity)
};

/// The camera of an image halved `level` times by cv::pyrDown.
inline CameraModel halved(const CameraModel& camera, int level) {
  return cameraAfterPyrDown(camera, level);
}

inline bool differ(double a, double b) {
  return std::abs(a - b) > 1e-6 * std::max({1.0, std::abs(a), std::abs(b)});
}

/// What both DFIs check at configure (their generated parameters share these names): the depth
/// range, max_depth beyond min_depth or 0 (infinity), and an odd block.
template <typename Params>
Status checkParameters(const Params& p) {
  if (p.max_depth > 0 && !(p.max_depth > p.min_depth))
    return invalidParameter(
        "parameter 'max_depth' ({} m) is not beyond 'min_depth' ({} m); expected max_depth > "
        "min_depth, or 0 for infinity",
        p.max_depth, p.min_depth);
  if (p.block_size % 2 == 0)
    return invalidParameter("parameter 'block_size' is {}; expected an odd number of pixels",
                            p.block_size);
  return Status::ok();
}

/// Sets what every cv::StereoMatcher has: the disparity search and the post-filters.
template <typename Params>
void setSearchAndFilters(cv::StereoMatcher& matcher, const Search& search, const Params& p) {
  matcher.setMinDisparity(search.min_disparity);
  matcher.setNumDisparities(search.num_disparities);
  matcher.setSpeckleWindowSize(p.speckle_window_size);
  matcher.setSpeckleRange(p.speckle_range);
  matcher.setDisp12MaxDiff(p.left_right_max_difference);
}

/// Checks the pair (formats, sizes, rectified geometry) and derives the disparity search for
/// the depths [min_depth, max_depth] (max_depth 0: infinity) at pyramid `level`; `block_size`
/// is the matcher's, which needs the search plus its block to fit the image's width.
inline Result<Search> prepare(const StereoImagePair& pair, double min_depth, double max_depth,
                              int level, int block_size) {
  CDFF_RETURN_IF_ERROR(pair.validate().withContext("input 'rectified'"));
  for (const auto& [image, what] : {std::pair{&pair.left, "input 'rectified' left image"},
                                    std::pair{&pair.right, "input 'rectified' right image"}}) {
    CDFF_RETURN_IF_ERROR(image->validate(what, {PixelFormat::kGray8, PixelFormat::kBgr8}));
    if (image->camera->hasDistortion())  // both have one: StereoImagePair::validate
      return invalidInput(
          "{} camera has {} distortion; expected a rectified, distortion-free "
          "pinhole model (rectify the pair first: StereoRectification)",
          what, toString(image->camera->distortion_model));
  }
  const Image& l = pair.left;
  const Image& r = pair.right;
  if (l.width != r.width || l.height != r.height)
    return invalidInput(
        "input 'rectified' images differ in size: left {}x{}, right {}x{}; "
        "expected the same size",
        l.width, l.height, r.width, r.height);
  if (l.format != r.format)
    return invalidInput(
        "input 'rectified' images differ in pixel format: left {}, right {}; "
        "expected the same format",
        toString(l.format), toString(r.format));
  const CameraModel& cl = *l.camera;
  const CameraModel& cr = *r.camera;
  if (differ(cl.fx, cr.fx) || differ(cl.fy, cr.fy) || differ(cl.cy, cr.cy))
    return invalidInput(
        "input 'rectified' cameras differ: left fx {} fy {} cy {}, right fx {} fy {} cy {}; "
        "expected the same fx, fy and cy (row-aligned rectified cameras)",
        cl.fx, cl.fy, cl.cy, cr.fx, cr.fy, cr.cy);
  const Eigen::Vector3d t = pair.right_T_left.translation;
  const double turn = Eigen::AngleAxisd(pair.right_T_left.rotation.normalized()).angle();
  if (turn > 1e-6 || std::abs(t.y()) > 1e-6 * std::abs(t.x()) ||
      std::abs(t.z()) > 1e-6 * std::abs(t.x()) || !(t.x() < 0))
    return invalidInput(
        "input 'rectified' right_T_left is a {:.3g} rad rotation and translation ({:.4g}, "
        "{:.4g}, {:.4g}) m; expected no rotation and a translation (-baseline, 0, 0), the right "
        "camera on the left's +x side (rectify the pair first: StereoRectification)",
        turn, t.x(), t.y(), t.z());

  Search s;
  s.left = halved(cl, level);
  s.baseline = -t.x();
  s.offset = halved(cl, level).cx - halved(cr, level).cx;
  s.min_depth = min_depth;
  s.max_depth = max_depth;
  const double f_b = s.left.fx * s.baseline;
  const double far = max_depth > 0 ? f_b / max_depth : 0.0;
  s.min_disparity = static_cast<int>(std::floor(far + s.offset)) - (max_depth > 0 ? 1 : 0);
  const int largest = static_cast<int>(std::ceil(f_b / min_depth + s.offset)) + 1;
  s.num_disparities = (largest - s.min_disparity) / 16 * 16 + 16;
  s.lowest = s.min_disparity + (max_depth > 0 ? 1 : 0);
  s.highest = s.min_disparity + s.num_disparities - 2;
  // OpenCV needs the search and the block inside the image: a pixel x has candidates x - d for
  // every d of the search.
  const int room = s.left.width - block_size;
  if (s.num_disparities + std::max(0, s.min_disparity) >= room)
    return invalidInput(
        "min_depth {} m needs disparities up to {} px (fx {:.1f} px x baseline {:.4g} m / "
        "min_depth, at pyramid level {}), which with the {} px block does not fit the {} px "
        "wide image; expected min_depth >= {:.3g} m or a higher pyramid_level",
        min_depth, static_cast<int>(std::ceil(f_b / min_depth + s.offset)), s.left.fx, s.baseline,
        level, block_size, s.left.width, f_b / std::max(1.0, room - 16.0 - s.offset));
  return s;
}

/// The image halved `level` times (cv::pyrDown), shared when level is 0.
inline cv::Mat pyramidLevel(const Image& image, int level) {
  return pyrDownTimes(toMat(image), level);
}

/// Marks as unmatched (below every searched disparity) the pixels of `fixed_point` whose
/// `block` x `block` neighbourhood in `left` (8-bit, the matched level) has a grey-level standard
/// deviation below `min_texture`.
inline void dropUntextured(cv::Mat& fixed_point, const cv::Mat& left, int block,
                           double min_texture) {
  if (min_texture <= 0) return;
  cv::Mat grey, mean, mean_sq;
  left.convertTo(grey, CV_32F);
  if (grey.channels() == 3) cv::cvtColor(grey, grey, cv::COLOR_BGR2GRAY);
  cv::boxFilter(grey, mean, CV_32F, cv::Size(block, block));
  cv::boxFilter(grey.mul(grey), mean_sq, CV_32F, cv::Size(block, block));
  const float threshold = static_cast<float>(min_texture * min_texture);
  for (int y = 0; y < fixed_point.rows; ++y) {
    std::int16_t* d = fixed_point.ptr<std::int16_t>(y);
    const float* m = mean.ptr<float>(y);
    const float* m2 = mean_sq.ptr<float>(y);
    for (int x = 0; x < fixed_point.cols; ++x)
      if (m2[x] - m[x] * m[x] < threshold) d[x] = std::numeric_limits<std::int16_t>::min();
  }
}

/// Publishes OpenCV's CV_16S disparity (1/16 px; below min_disparity: no match) as the
/// disparity and depth images, matches outside [lowest, highest] and the depth range dropped;
/// returns the fraction of pixels with a depth.
template <typename Outputs>
Result<double> publish(const cv::Mat& fixed_point, const Search& s, const Image& left,
                       Outputs& out) {
  cv::Mat disparity(fixed_point.size(), CV_32FC1);
  cv::Mat depth(fixed_point.size(), CV_32FC1);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const double f_b = s.left.fx * s.baseline;
  const double far = s.max_depth > 0 ? s.max_depth : std::numeric_limits<double>::infinity();
  std::size_t valid = 0;
  for (int y = 0; y < fixed_point.rows; ++y) {
    const std::int16_t* in = fixed_point.ptr<std::int16_t>(y);
    float* d = disparity.ptr<float>(y);
    float* z = depth.ptr<float>(y);
    for (int x = 0; x < fixed_point.cols; ++x) {
      const double value = in[x] / 16.0;
      const double shifted = value - s.offset;
      const double range = shifted > 0 ? f_b / shifted : 0.0;
      if (value < s.lowest || value > s.highest || !(shifted > 0) || range < s.min_depth ||
          range > far) {
        d[x] = nan;
        z[x] = nan;
        continue;
      }
      d[x] = static_cast<float>(value);
      z[x] = static_cast<float>(range);
      ++valid;
    }
  }
  Result<Image> disparity_image = fromMat(disparity, left.stamp, left.frame_id);
  if (!disparity_image) return disparity_image.status();
  Result<Image> depth_image = fromMat(depth, left.stamp, left.frame_id);
  if (!depth_image) return depth_image.status();
  disparity_image->camera = s.left;
  depth_image->camera = s.left;
  const double fraction =
      static_cast<double>(valid) / std::max<double>(1.0, static_cast<double>(depth.total()));
  out.disparity.set(std::move(disparity_image).value());
  out.depth.set(DepthMap{std::move(depth_image).value(), 1.0});
  out.valid_fraction.set(fraction);
  out.left_image.set(left);
  return fraction;
}

}  // namespace cdff::dfn::stereo_matching
