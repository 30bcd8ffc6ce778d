#include "template_track.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "cdff/types/opencv.hpp"

namespace cdff::dfn::template_matching {
namespace {

Eigen::Matrix3d translation(double x, double y) {
  Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
  t(0, 2) = x;
  t(1, 2) = y;
  return t;
}

Eigen::Vector2d apply(const Eigen::Matrix3d& h, double x, double y) {
  const Eigen::Vector3d p = h * Eigen::Vector3d(x, y, 1.0);
  return p.head<2>() / p.z();
}

/// The grey value of one full-range step of the format (8-bit: 1; 16-bit: 1; float: 0).
double quantum(PixelFormat format) {
  return format == PixelFormat::kFloat32 ? 0.0 : 1.0;
}

/// Median and normalised median absolute deviation of a float patch.
std::pair<double, double> medianAndMad(const cv::Mat& patch) {
  std::vector<float> v(patch.begin<float>(), patch.end<float>());
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  const double median = *mid;
  for (float& x : v) x = std::abs(x - static_cast<float>(median));
  std::nth_element(v.begin(), mid, v.end());
  return {median, 1.4826 * *mid};
}

/// Twice the radius of gyration of the template's contrast |T - median| (template pixels).
double contrastExtent(const cv::Mat& t, double median) {
  double w = 0, wx = 0, wy = 0, wxx = 0;
  for (int y = 0; y < t.rows; ++y)
    for (int x = 0; x < t.cols; ++x) {
      const double c = std::abs(t.at<float>(y, x) - median);
      w += c;
      wx += c * x;
      wy += c * y;
      wxx += c * (x * x + y * y);
    }
  if (w <= 0) return 0;
  const double mx = wx / w, my = wy / w;
  return 2.0 * std::sqrt(std::max(0.0, wxx / w - mx * mx - my * my));
}

}  // namespace

Eigen::Matrix3d Crop::imageToLevel(int m) const {
  const double f = std::ldexp(1.0, -m);
  Eigen::Matrix3d h = Eigen::Matrix3d::Identity();
  h(0, 0) = h(1, 1) = f;
  h(0, 2) = (0.5 - origin.x) * f - 0.5;
  h(1, 2) = (0.5 - origin.y) * f - 0.5;
  return h;
}

Result<Crop> cropOf(const Image& image, double x0, double y0, double x1, double y1, int levels) {
  const int align = 1 << levels;
  const int ix0 = std::max(0, static_cast<int>(std::floor(x0)) / align * align);
  const int iy0 = std::max(0, static_cast<int>(std::floor(y0)) / align * align);
  const int ix1 = std::min(image.width, static_cast<int>(std::ceil(x1)) + 1);
  const int iy1 = std::min(image.height, static_cast<int>(std::ceil(y1)) + 1);
  if (ix1 - ix0 < 2 || iy1 - iy0 < 2)
    return invalidInput("the region [{:.1f}, {:.1f}] x [{:.1f}, {:.1f}] is outside the {}x{} image",
                        x0, x1, y0, y1, image.width, image.height);
  const cv::Mat roi = toMat(image)(cv::Rect(ix0, iy0, ix1 - ix0, iy1 - iy0));
  Crop crop;
  crop.origin = {ix0, iy0};
  cv::Mat grey;
  if (roi.channels() == 3)
    cv::cvtColor(roi, grey, cv::COLOR_BGR2GRAY);
  else
    grey = roi;
  crop.levels.resize(1);
  grey.convertTo(crop.levels[0], CV_32F);
  for (int m = 1; m <= levels; ++m) {
    const cv::Mat& prev = crop.levels.back();
    if (prev.cols < 4 || prev.rows < 4) break;
    cv::Mat half;
    cv::resize(prev(cv::Rect(0, 0, prev.cols & ~1, prev.rows & ~1)), half,
               cv::Size(prev.cols / 2, prev.rows / 2), 0, 0, cv::INTER_AREA);
    crop.levels.push_back(half);
  }
  return crop;
}

cv::Rect2d footprint(const ImageRegion& region, double margin) {
  const double w = region.width - 0.5, h = region.height - 0.5;
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const auto& [x, y] : {std::pair{-0.5, -0.5}, {w, -0.5}, {-0.5, h}, {w, h}}) {
    const Eigen::Vector2d p = region.map(x, y);
    x0 = std::min(x0, p.x());
    y0 = std::min(y0, p.y());
    x1 = std::max(x1, p.x());
    y1 = std::max(y1, p.y());
  }
  return {x0 - margin, y0 - margin, x1 - x0 + 2 * margin, y1 - y0 + 2 * margin};
}

int levelFor(const ImageRegion& region) {
  const double s = region.scale();
  return std::isfinite(s) && s > 1 ? std::max(0, static_cast<int>(std::lround(std::log2(s)))) : 0;
}

Result<Template> takeTemplate(const Image& image, const ImageRegion& region, const Settings& s) {
  const double scale = region.scale();
  int k = 1;
  while (std::max(region.width, region.height) * scale / k > s.max_template_size) k *= 2;
  const int level = static_cast<int>(std::lround(std::log2(k)));
  const int w = std::max(3, static_cast<int>(std::lround(region.width * scale / k)));
  const int h = std::max(3, static_cast<int>(std::lround(region.height * scale / k)));
  // New template pixel -> old template pixel, the centres kept on each other.
  const double sigma = k / scale;
  Eigen::Matrix3d a = Eigen::Matrix3d::Identity();
  a(0, 0) = a(1, 1) = sigma;
  a(0, 2) = 0.5 * (region.width - 1) - sigma * 0.5 * (w - 1);
  a(1, 2) = 0.5 * (region.height - 1) - sigma * 0.5 * (h - 1);
  Template t;
  t.region = region;
  t.region.homography = region.homography * a;
  t.region.width = w;
  t.region.height = h;
  const cv::Rect2d box = footprint(t.region, 2.0 * k);
  if (box.x + 2.0 * k < -0.5 || box.y + 2.0 * k < -0.5 ||
      box.br().x - 2.0 * k > image.width - 0.5 || box.br().y - 2.0 * k > image.height - 0.5)
    return invalidInput(
        "the region [{:.1f}, {:.1f}] x [{:.1f}, {:.1f}] leaves the {}x{} image; expected a region "
        "inside it",
        box.x + 2.0 * k, box.br().x - 2.0 * k, box.y + 2.0 * k, box.br().y - 2.0 * k, image.width,
        image.height);
  Result<Crop> cropped = cropOf(image, box.x, box.y, box.br().x, box.br().y, level);
  if (!cropped) return cropped.status();
  const Crop& crop = *cropped;
  if (static_cast<int>(crop.levels.size()) <= level)
    return invalidInput("the region is too small for its resolution level {}", level);
  std::vector<Eigen::Vector2f> xy;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) xy.emplace_back(x, y);
  const Eigen::VectorXf values =
      sampleAt(crop.levels[level], crop.imageToLevel(level) * t.region.homography, xy);
  if (!values.allFinite())
    return invalidInput("the region leaves the {}x{} image; expected a region inside it",
                        image.width, image.height);
  t.pixels = cv::Mat(h, w, CV_32F);
  std::copy(values.data(), values.data() + values.size(), t.pixels.ptr<float>());
  const auto [median, mad] = medianAndMad(t.pixels);
  double max_value = 0;
  cv::minMaxLoc(t.pixels, nullptr, &max_value);
  const double floor = 5.0 * std::max(mad, quantum(image.format));
  if (max_value - median <= floor)
    return invalidInput(
        "the region {:.0f}x{:.0f} px at ({:.1f}, {:.1f}) holds nothing to follow: its brightest "
        "pixel is {:.2f} above its median, not more than 5 noise deviations ({:.2f}); expected a "
        "target brighter than its background (empty sky?)",
        region.width * scale, region.height * scale, region.centre().x(), region.centre().y(),
        max_value - median, floor);
  t.scale_at_taking = t.region.scale();
  t.extent_at_taking = contrastExtent(t.pixels, median) * k;
  t.estimates_scale = t.extent_at_taking >= s.min_extent_for_scale;
  return t;
}

Eigen::VectorXf sampleAt(const cv::Mat& level, const Eigen::Matrix3d& h,
                         const std::vector<Eigen::Vector2f>& xy) {
  Eigen::VectorXf out(static_cast<Eigen::Index>(xy.size()));
  const int w = level.cols, hgt = level.rows;
  for (std::size_t i = 0; i < xy.size(); ++i) {
    const Eigen::Vector2d p = apply(h, xy[i].x(), xy[i].y());
    const int x0 = static_cast<int>(std::floor(p.x())), y0 = static_cast<int>(std::floor(p.y()));
    if (x0 < 0 || y0 < 0 || x0 + 1 >= w || y0 + 1 >= hgt) {
      out[static_cast<Eigen::Index>(i)] = std::numeric_limits<float>::quiet_NaN();
      continue;
    }
    const float fx = static_cast<float>(p.x() - x0), fy = static_cast<float>(p.y() - y0);
    const float* r0 = level.ptr<float>(y0) + x0;
    const float* r1 = level.ptr<float>(y0 + 1) + x0;
    out[static_cast<Eigen::Index>(i)] =
        (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
  }
  return out;
}

NormalisedTemplate normalise(const Template& t) {
  NormalisedTemplate n;
  n.dof = t.estimates_scale ? 4 : 2;
  const cv::Mat& p = t.pixels;
  n.centre = {0.5f * (p.cols - 1), 0.5f * (p.rows - 1)};
  // Interior pixels: their gradients are central differences.
  for (int y = 1; y + 1 < p.rows; ++y)
    for (int x = 1; x + 1 < p.cols; ++x) n.xy.emplace_back(x, y);
  const Eigen::Index count = static_cast<Eigen::Index>(n.xy.size());
  n.values.resize(count);
  Eigen::MatrixXf grad(count, 2);
  for (Eigen::Index i = 0; i < count; ++i) {
    const int x = static_cast<int>(n.xy[i].x()), y = static_cast<int>(n.xy[i].y());
    n.values[i] = p.at<float>(y, x);
    grad(i, 0) = 0.5f * (p.at<float>(y, x + 1) - p.at<float>(y, x - 1));
    grad(i, 1) = 0.5f * (p.at<float>(y + 1, x) - p.at<float>(y - 1, x));
  }
  const float mean = n.values.mean();
  n.values.array() -= mean;
  const float norm = std::max(n.values.norm(), 1e-12f);
  n.values /= norm;
  grad /= norm;
  n.steepest.resize(count, n.dof);
  for (Eigen::Index i = 0; i < count; ++i) {
    const float gx = grad(i, 0), gy = grad(i, 1);
    const float xc = n.xy[i].x() - n.centre.x(), yc = n.xy[i].y() - n.centre.y();
    n.steepest(i, 0) = gx;
    n.steepest(i, 1) = gy;
    if (n.dof == 4) {
      n.steepest(i, 2) = gx * xc + gy * yc;   // scale
      n.steepest(i, 3) = -gx * yc + gy * xc;  // rotation
    }
  }
  return n;
}

Eigen::Matrix3d warpOf(const Eigen::VectorXd& p, const Eigen::Vector2f& centre) {
  Eigen::Matrix3d w = Eigen::Matrix3d::Identity();
  w(0, 2) = p[0];
  w(1, 2) = p[1];
  if (p.size() == 4) {
    w(0, 0) = w(1, 1) = 1 + p[2];
    w(0, 1) = -p[3];
    w(1, 0) = p[3];
  }
  return translation(centre.x(), centre.y()) * w * translation(-centre.x(), -centre.y());
}

std::optional<Coarse> coarseSearch(const Image& image, const Template& t,
                                   const Eigen::Matrix3d& warp, const Eigen::Vector2d& centre,
                                   double radius) {
  const Eigen::Vector2d tc(0.5 * (t.pixels.cols - 1), 0.5 * (t.pixels.rows - 1));
  const Eigen::Vector2d moved = centre - apply(warp, tc.x(), tc.y());
  ImageRegion r = t.region;
  r.homography = translation(moved.x(), moved.y()) * warp;
  const cv::Rect2d fp = footprint(r, 0);
  const int level =
      std::max(0, static_cast<int>(std::floor(std::log2(std::min(fp.width, fp.height) / 8.0))));
  const double margin = radius + std::ldexp(2.0, level);
  Result<Crop> crop =
      cropOf(image, fp.x - margin, fp.y - margin, fp.br().x + margin, fp.br().y + margin, level);
  if (!crop) return std::nullopt;
  const int l = std::min(level, static_cast<int>(crop->levels.size()) - 1);
  const cv::Mat& window = crop->levels[l];
  // The template as it should look at level l, rendered image-aligned; a template finer than
  // the level is averaged down first (no aliasing).
  Eigen::Matrix3d m = crop->imageToLevel(l) * r.homography;
  cv::Mat source = t.pixels;
  const double pixel = std::sqrt(std::abs(m.topLeftCorner<2, 2>().determinant()));
  int d = 1;
  while (pixel * d < 0.75 && source.cols / (2 * d) >= 2 && source.rows / (2 * d) >= 2) d *= 2;
  if (d > 1) {
    cv::resize(t.pixels(cv::Rect(0, 0, t.pixels.cols / d * d, t.pixels.rows / d * d)), source,
               cv::Size(t.pixels.cols / d, t.pixels.rows / d), 0, 0, cv::INTER_AREA);
    Eigen::Matrix3d a = Eigen::Matrix3d::Identity();
    a(0, 0) = a(1, 1) = d;
    a(0, 2) = a(1, 2) = 0.5 * (d - 1);
    m = m * a;
  }
  ImageRegion level_region = r;
  level_region.homography = m;
  level_region.width = source.cols;
  level_region.height = source.rows;
  const cv::Rect2d box = footprint(level_region, 0);
  const int px0 = static_cast<int>(std::floor(box.x + 0.5)),
            py0 = static_cast<int>(std::floor(box.y + 0.5));
  const int pw = std::max(2, static_cast<int>(std::ceil(box.width))),
            ph = std::max(2, static_cast<int>(std::ceil(box.height)));
  if (pw >= window.cols || ph >= window.rows) return std::nullopt;
  const Eigen::Matrix3d to_patch = translation(-px0, -py0) * m;
  cv::Mat map(2, 3, CV_64F);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) map.at<double>(i, j) = to_patch(i, j);
  cv::Scalar fill = cv::mean(source);
  cv::Mat patch;
  cv::warpAffine(source, patch, map, cv::Size(pw, ph), cv::INTER_LINEAR, cv::BORDER_CONSTANT, fill);
  cv::Mat score;
  cv::matchTemplate(window, patch, score, cv::TM_CCOEFF_NORMED);
  // Placements within the radius of the expected one (level pixels).
  const double radius_l = radius * std::ldexp(1.0, -l);
  double best = -2;
  cv::Point at(-1, -1);
  for (int y = 0; y < score.rows; ++y)
    for (int x = 0; x < score.cols; ++x) {
      const float v = score.at<float>(y, x);
      if (!std::isfinite(v) || v <= best || std::hypot(x - px0, y - py0) > radius_l + 1) continue;
      best = v;
      at = {x, y};
    }
  if (at.x < 0) return std::nullopt;
  auto peak = [&](float lo, float mid, float hi) {
    const double den = lo - 2.0 * mid + hi;
    return den < 0 ? std::clamp(0.5 * (lo - hi) / den, -0.5, 0.5) : 0.0;
  };
  double sx = at.x, sy = at.y;
  if (at.x > 0 && at.x + 1 < score.cols)
    sx +=
        peak(score.at<float>(at.y, at.x - 1), score.at<float>(at), score.at<float>(at.y, at.x + 1));
  if (at.y > 0 && at.y + 1 < score.rows)
    sy +=
        peak(score.at<float>(at.y - 1, at.x), score.at<float>(at), score.at<float>(at.y + 1, at.x));
  const double f = std::ldexp(1.0, l);
  return Coarse{translation((sx - px0) * f, (sy - py0) * f) * r.homography, best};
}

Fit evaluateFit(const Crop& crop, int level, const Template& t, const Eigen::Matrix3d& homography,
                const Settings& s) {
  Fit fit;
  const NormalisedTemplate n = normalise(t);
  Eigen::VectorXf sampled = sampleAt(crop.levels[static_cast<std::size_t>(level)],
                                     crop.imageToLevel(level) * homography, n.xy);
  if (!sampled.allFinite()) return fit;
  fit.inside = true;
  sampled.array() -= sampled.mean();
  const float norm = sampled.norm();
  if (norm <= 0) return fit;
  sampled /= norm;
  fit.score = sampled.dot(n.values);
  const Eigen::VectorXd e = (sampled - n.values).cast<double>();
  const Eigen::MatrixXd sd = n.steepest.cast<double>();
  const double dof = static_cast<double>(e.size() - n.dof);
  if (dof <= 0) return fit;
  // The image distance one template pixel spans at the centre.
  ImageRegion r = t.region;
  r.homography = homography;
  const double pixel = r.scale();
  const double sigma_t = s.pixel_correlation / pixel;  // the blur in template pixels
  const double correlation = std::max(1.0, 4.0 * M_PI * sigma_t * sigma_t);
  const Eigen::MatrixXd cov_p =
      (e.squaredNorm() / dof * correlation) * (sd.transpose() * sd).inverse();
  // Template centre displacement -> image: the homography's Jacobian at the centre.
  const double cx = 0.5 * (t.pixels.cols - 1), cy = 0.5 * (t.pixels.rows - 1);
  Eigen::Matrix2d j;
  j.col(0) = 0.5 * (apply(homography, cx + 1, cy) - apply(homography, cx - 1, cy));
  j.col(1) = 0.5 * (apply(homography, cx, cy + 1) - apply(homography, cx, cy - 1));
  fit.covariance = j * cov_p.topLeftCorner<2, 2>() * j.transpose();
  fit.covariance = 0.5 * (fit.covariance + fit.covariance.transpose()).eval();
  return fit;
}

namespace {

/// The image sampled on the template's grid at `match` (the level its pixels are at); empty when
/// the match reaches outside the image.
cv::Mat alignedSample(const Image& image, const Template& t, const ImageRegion& match) {
  const int level = levelFor(match);
  const cv::Rect2d box = footprint(match, 2.0 * std::ldexp(1.0, level));
  Result<Crop> crop = cropOf(image, box.x, box.y, box.br().x, box.br().y, level);
  if (!crop || static_cast<int>(crop->levels.size()) <= level) return {};
  std::vector<Eigen::Vector2f> xy;
  for (int y = 0; y < t.pixels.rows; ++y)
    for (int x = 0; x < t.pixels.cols; ++x) xy.emplace_back(x, y);
  const Eigen::VectorXf v = sampleAt(crop->levels[static_cast<std::size_t>(level)],
                                     crop->imageToLevel(level) * match.homography, xy);
  if (!v.allFinite()) return {};
  cv::Mat out(t.pixels.rows, t.pixels.cols, CV_32F);
  std::copy(v.data(), v.data() + v.size(), out.ptr<float>());
  return out;
}

}  // namespace

Result<Template> afterMatch(const Image& image, Template t, const ImageRegion& match,
                            const Settings& s) {
  t.region = match;
  if (match.score < s.min_update_score) return t;
  // A template too small to estimate scale is the running mean of the confident matches, aligned
  // on its grid: the noise of a faint target averages out and the mean of aligned samples keeps
  // the tracked point where it was. A larger template is not averaged: the alignment of a growing
  // target by an estimated scale would blur it and move the point.
  // A template is taken again when the target has grown by update_scale_ratio: measured by the
  // scale for a template that estimates it, by the target's extent (or its filling half the box,
  // where the box clips what it measures) for one too small to. The image is sampled on the
  // template's grid once, and only when it is needed.
  if (t.estimates_scale && match.scale() < s.update_scale_ratio * t.scale_at_taking) return t;
  const cv::Mat sample = alignedSample(image, t, match);
  if (sample.empty()) return t;
  if (!t.estimates_scale) {
    t.averaged = std::min(t.averaged + 1, s.template_memory);
    cv::addWeighted(t.pixels, 1.0 - 1.0 / t.averaged, sample, 1.0 / t.averaged, 0.0, t.pixels);
  }
  const double extent = contrastExtent(sample, medianAndMad(sample).first) * match.scale();
  const double box = std::min(match.width, match.height) * match.scale();
  if (!t.estimates_scale && extent < s.update_scale_ratio * t.extent_at_taking &&
      extent < 0.5 * box)
    return t;
  // The new box: a margin of one target extent around the tracked point (twice the extent plus 6
  // px), never smaller than a small template's box, and clipped to the image about the point.
  const Eigen::Vector2d c = match.centre();
  double side = 2.0 * extent + 6.0;
  if (!t.estimates_scale) side = std::max(side, box);
  const double room =
      2.0 * std::min({c.x(), image.width - 1 - c.x(), c.y(), image.height - 1 - c.y()}) - 4.0;
  side = std::min(side, room);
  if (side < 5) return t;  // the point is at the image's edge: keep the template
  const int n = static_cast<int>(std::floor(side));
  ImageRegion region = match;
  region.homography = translation(c.x() - 0.5 * (n - 1), c.y() - 0.5 * (n - 1));
  region.width = region.height = n;
  Result<Template> again = takeTemplate(image, region, s);
  if (!again) return t;  // e.g. the grown region reaches the image's edge: keep the old one
  return again;
}

}  // namespace cdff::dfn::template_matching

namespace cdff::dfn::template_matching {
namespace {

/// The search's centre and radius: the prediction's centre within search_sigmas of its
/// uncertainty, or the last match within the smallest radius.
std::pair<Eigen::Vector2d, double> searchArea(const Template& t, const ImageRegion* prediction,
                                              const Settings& s) {
  if (!prediction) return {t.region.centre(), s.min_search_radius};
  const double sigma =
      std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(prediction->covariance)
                                  .eigenvalues()
                                  .maxCoeff()));
  return {prediction->centre(),
          std::clamp(s.search_sigmas * sigma, s.min_search_radius, s.max_search_radius)};
}

}  // namespace

Result<StepResult> step(const Image& image, const ImageRegion* designation,
                        const ImageRegion* prediction, const Settings& s,
                        std::optional<Template>& track, const Refine& refine) {
  CDFF_RETURN_IF_ERROR(image.validate(
      "input 'image'", {PixelFormat::kGray8, PixelFormat::kBgr8, PixelFormat::kGray16}));
  StepResult result;
  if (designation) {
    CDFF_RETURN_IF_ERROR(designation->validate().withContext("input 'designation'"));
    Result<Template> taken = takeTemplate(image, *designation, s);
    if (!taken) return taken.status().withContext("input 'designation'");
    track = std::move(taken).value();
    ImageRegion match = *designation;
    match.stamp = image.stamp;
    match.frame_id = image.frame_id;
    match.score = 1.0;
    result.match = match;
    result.score = 1.0;
    return result;
  }
  if (!track) return result;
  if (prediction) CDFF_RETURN_IF_ERROR(prediction->validate().withContext("input 'prediction'"));
  const auto [centre, radius] = searchArea(*track, prediction, s);
  const std::optional<Coarse> coarse =
      coarseSearch(image, *track, track->region.homography, centre, radius);
  if (!coarse) return result;
  result.score = coarse->score;
  if (coarse->score < s.min_score - 0.2) return result;
  ImageRegion start = track->region;
  start.homography = coarse->homography;
  const int level = levelFor(start);
  const cv::Rect2d area = footprint(start, 6.0 * std::ldexp(1.0, level));
  Result<Crop> crop = cropOf(image, area.x, area.y, area.br().x, area.br().y, level);
  if (!crop || static_cast<int>(crop->levels.size()) <= level) return result;
  const std::optional<Eigen::Matrix3d> refined =
      refine(*crop, level, *track, coarse->homography, s);
  if (!refined) return result;
  const Fit fit = evaluateFit(*crop, level, *track, *refined, s);
  result.score = fit.inside ? fit.score : coarse->score;
  if (!fit.inside || fit.score < s.min_score) return result;
  ImageRegion match = track->region;
  match.stamp = image.stamp;
  match.frame_id = image.frame_id;
  match.homography = *refined;
  match.score = fit.score;
  match.covariance = fit.covariance;
  match.source = "match";
  result.match = match;
  Result<Template> next = afterMatch(image, std::move(*track), match, s);
  if (!next) return next.status();
  track = std::move(next).value();
  return result;
}

}  // namespace cdff::dfn::template_matching
