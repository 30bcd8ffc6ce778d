#pragma once
// The estimation both FundamentalMatrixEstimation DFIs share; they differ in the robust method.

#include <algorithm>
#include <cmath>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>

#include "FundamentalMatrixEstimation.gen.hpp"
#include "cdff/types/opencv.hpp"
#include "fundamental_refinement.hpp"

namespace cdff::dfn::fundamental {

struct Settings {
  int method = cv::FM_RANSAC;
  const char* method_name = "RANSAC";
  double threshold = 1.0;  // px
  double confidence = 0.999;
  int max_iterations = 2000;
  double max_homography_fraction = 0.9;
  bool refit = false;  // the 8-point fit to the inliers after the sampling (plain RANSAC)
};

template <typename Parameters>
Settings settings(const Parameters& p, int method, const char* method_name, bool refit) {
  return {method,       method_name,      p.threshold,
          p.confidence, p.max_iterations, p.max_homography_fraction,
          refit};
}

/// A 3x3 CV_64F matrix as 3 rows of 3 numbers.
inline nlohmann::json matrixJson(const cv::Mat& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    rows.push_back({m.at<double>(r, 0), m.at<double>(r, 1), m.at<double>(r, 2)});
  return rows;
}

/// The linear (normalised 8-point) fit of F to the inliers of `mask`, and the inliers of that F
/// within the threshold; `f` and `mask` unchanged when the fit fails.
inline Status refitToInliers(const std::vector<cv::Point2d>& a, const std::vector<cv::Point2d>& b,
                             const Settings& s, cv::Mat& f, std::vector<std::uint8_t>& mask) {
  std::vector<cv::Point2d> ia, ib;
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) ia.push_back(a[i]), ib.push_back(b[i]);
  cv::Mat refit;
  try {
    refit = cv::findFundamentalMat(ia, ib, cv::FM_8POINT);
  } catch (const cv::Exception& e) {
    return numericalFailure("FundamentalMatrixEstimation: the 8-point fit to {} inliers failed: {}",
                            ia.size(), e.what());
  }
  if (refit.rows != 3 || refit.cols != 3 || !cv::checkRange(refit)) return Status::ok();
  f = refit;
  const cv::Matx33d fm(f);
  for (std::size_t i = 0; i < a.size(); ++i)
    mask[i] = epipolarDistance(fm, a[i], b[i]) <= s.threshold;
  return Status::ok();
}

/// The homography's error is a 2D transfer distance where F's is a distance to a line: the same
/// noise passes a 2D test at sqrt(chi2_2(0.95) / chi2_1(0.95)) = 1.25 times the 1D threshold.
constexpr double kHomographyThresholdFactor = 1.25;

/// The number of F's inliers (`f_mask`) that one homography, fitted by RANSAC to them and refined
/// by cv::findHomography, maps to their match within 1.25 times the threshold. The test only has
/// to find a homography that explains max_homography_fraction of them when there is one: a
/// 4-pair sample is then all-inlier with probability fraction^4, so RANSAC needs
/// log(1 - confidence) / log(1 - fraction^4) samples (7 at 0.9 and 0.999), not the thousands a
/// general scene's few planar points would call for.
inline Result<int> homographyInliers(const std::vector<cv::Point2d>& a,
                                     const std::vector<cv::Point2d>& b,
                                     const std::vector<std::uint8_t>& f_mask, const Settings& s) {
  const double threshold = kHomographyThresholdFactor * s.threshold;
  std::vector<cv::Point2d> fa, fb;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (f_mask[i]) fa.push_back(a[i]), fb.push_back(b[i]);
  const double all_inlier = std::pow(std::max(s.max_homography_fraction, 0.05), 4);
  const int samples =
      static_cast<int>(std::clamp(std::ceil(std::log(1 - s.confidence) / std::log(1 - all_inlier)),
                                  10.0, static_cast<double>(s.max_iterations)));
  cv::Mat h;
  try {
    h = cv::findHomography(fa, fb, cv::RANSAC, threshold, cv::noArray(), samples, s.confidence);
  } catch (const cv::Exception& e) {
    return numericalFailure(
        "FundamentalMatrixEstimation: the degeneracy test's homography "
        "failed: {}",
        e.what());
  }
  if (h.empty()) return 0;
  const cv::Matx33d hm(h);
  int both = 0;
  for (std::size_t i = 0; i < fa.size(); ++i) {
    const cv::Vec3d p = hm * cv::Vec3d(fa[i].x, fa[i].y, 1);
    both +=
        std::abs(p[2]) > 0 && std::hypot(p[0] / p[2] - fb[i].x, p[1] / p[2] - fb[i].y) <= threshold;
  }
  return both;
}

/// The maximum-likelihood F: refined on the inliers, the inliers classified again under the
/// refined F (within the threshold), repeated until they no longer change (at most 5 rounds).
/// Returns the number of inliers.
inline int refineInRounds(const std::vector<cv::Point2d>& a, const std::vector<cv::Point2d>& b,
                          const Settings& s, cv::Mat& f, std::vector<std::uint8_t>& mask) {
  Eigen::Matrix3d fe;
  for (int i = 0; i < 9; ++i) fe(i / 3, i % 3) = f.at<double>(i / 3, i % 3);
  int count = 0;
  for (int round = 0; round < 5; ++round) {
    refineF(a, b, mask, fe);
    const std::vector<std::uint8_t> before = mask;
    cv::Matx33d fm;
    for (int i = 0; i < 9; ++i) fm.val[i] = fe(i / 3, i % 3);
    count = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      mask[i] = epipolarDistance(fm, a[i], b[i]) <= s.threshold;
      count += mask[i];
    }
    if (mask == before || count < 8) break;
  }
  f = cv::Mat(3, 3, CV_64F);
  for (int i = 0; i < 9; ++i) f.at<double>(i / 3, i % 3) = fe(i / 3, i % 3);
  return count;
}

/// F from the correspondences, its inliers, and the degeneracy test, into `out`.
inline Status estimate(const Correspondences2D& c, const Settings& s,
                       FundamentalMatrixEstimation::Outputs& out) {
  CDFF_RETURN_IF_ERROR(c.validate("input 'correspondences'"));
  if (c.size() < 8)
    return invalidInput(
        "input 'correspondences' has {} pairs; expected at least 8 for a "
        "fundamental matrix",
        c.size());
  const std::vector<cv::Point2d> a = toCvPoints(c.first), b = toCvPoints(c.second);
  std::vector<std::uint8_t> mask;
  cv::Mat f;
  try {
    f = cv::findFundamentalMat(a, b, s.method, s.threshold, s.confidence, s.max_iterations, mask);
  } catch (const cv::Exception& e) {
    return numericalFailure("FundamentalMatrixEstimation: {} failed on {} pairs: {}", s.method_name,
                            c.size(), e.what());
  }
  if (s.refit && f.rows == 3 && f.cols == 3) CDFF_RETURN_IF_ERROR(refitToInliers(a, b, s, f, mask));
  int count = 0;
  for (std::uint8_t m : mask) count += m != 0;
  if (f.rows != 3 || f.cols != 3 || count < 8)
    return numericalFailure(
        "FundamentalMatrixEstimation: {} found {} inliers among {} pairs "
        "(threshold {} px); expected at least 8 agreeing with one F",
        s.method_name, count, c.size(), s.threshold);
  if (s.max_homography_fraction < 1.0) {
    Result<int> h = homographyInliers(a, b, mask, s);
    if (!h) return h.status();
    if (h.value() >= s.max_homography_fraction * count)
      return invalidInput(
          "input 'correspondences': one homography explains {} of F's {} "
          "inliers ({:.3f} >= max_homography_fraction {}): a planar scene or a "
          "camera that did not move, F is not determined; expected points at "
          "several depths seen from two positions",
          h.value(), count, static_cast<double>(h.value()) / count, s.max_homography_fraction);
  }
  count = refineInRounds(a, b, s, f, mask);
  if (count < 8)
    return numericalFailure(
        "FundamentalMatrixEstimation: {} inliers of {} pairs agree with the "
        "refined F (threshold {} px); expected at least 8",
        count, c.size(), s.threshold);
  f /= cv::norm(f);
  if (f.at<double>(2, 2) < 0) f = -f;
  if (!cv::checkRange(f))
    return numericalFailure("FundamentalMatrixEstimation: {} returned a non-finite F",
                            s.method_name);
  Correspondences2D inliers;
  nlohmann::json indices = nlohmann::json::array();
  for (std::size_t i = 0; i < mask.size(); ++i) {
    if (!mask[i]) continue;
    inliers.first.push_back(c.first[i]);
    inliers.second.push_back(c.second[i]);
    indices.push_back(i);
  }
  out.fundamental.set(matrixJson(f));
  out.inliers.set(std::move(inliers));
  out.inlier_indices.set(std::move(indices));
  out.inlier_count.set(count);
  return Status::ok();
}

}  // namespace cdff::dfn::fundamental
