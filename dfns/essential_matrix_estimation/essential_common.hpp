#pragma once
// The estimation both EssentialMatrixEstimation DFIs share; they differ in the robust method.

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "EssentialMatrixEstimation.gen.hpp"
#include "cdff/types/epipolar.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn::essential {

struct Settings {
  int method = cv::RANSAC;
  const char* method_name = "RANSAC";
  double threshold = 1.0;  // px
  double confidence = 0.999;
  int max_iterations = 2000;
  double min_parallax = 0.0;  // rad
  std::string first_frame, second_frame;
  bool refit = false;  // the linear fit to the inliers after the sampling (plain RANSAC)
};

template <typename Parameters>
Settings settings(const Parameters& p, int method, const char* method_name, bool refit) {
  return {method,         method_name,   p.threshold,    p.confidence, p.max_iterations,
          p.min_parallax, p.first_frame, p.second_frame, refit};
}

/// The linear 8-point fit to the inliers of `mask`, projected onto the essential matrices; it
/// replaces `e` (and its inliers `mask`) when it has at least as many inliers within `threshold`.
inline void refitToInliers(const std::vector<cv::Point2d>& a, const std::vector<cv::Point2d>& b,
                           double threshold, cv::Mat& e, std::vector<std::uint8_t>& mask) {
  std::vector<cv::Point2d> ia, ib;
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) ia.push_back(a[i]), ib.push_back(b[i]);
  if (ia.size() < 8) return;
  const cv::Mat f = cv::findFundamentalMat(ia, ib, cv::FM_8POINT);
  if (f.rows != 3 || f.cols != 3 || !cv::checkRange(f)) return;
  cv::SVD svd(f);
  const cv::Mat refit = svd.u * cv::Mat::diag((cv::Mat_<double>(3, 1) << 1, 1, 0)) * svd.vt;
  const cv::Matx33d em(refit);
  std::vector<std::uint8_t> refit_mask(a.size());
  int before = 0, after = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    refit_mask[i] = epipolarDistance(em, a[i], b[i]) <= threshold;
    after += refit_mask[i];
    before += mask[i] != 0;
  }
  if (after < before) return;
  e = refit;
  mask = std::move(refit_mask);
}

/// The median angle (rad) between the rays of the inliers once the rotation is removed.
inline double medianParallax(const std::vector<cv::Point2d>& a, const std::vector<cv::Point2d>& b,
                             const std::vector<std::uint8_t>& mask, const cv::Matx33d& r) {
  std::vector<double> angles;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!mask[i]) continue;
    const cv::Vec3d d1 = cv::normalize(cv::Vec3d(a[i].x, a[i].y, 1));
    // second_R_first maps a first-frame direction into the second frame: compare there.
    const cv::Vec3d d2 = cv::normalize(cv::Vec3d(b[i].x, b[i].y, 1));
    const cv::Vec3d rd1 = r * d1;
    angles.push_back(std::atan2(cv::norm(rd1.cross(d2)), rd1.dot(d2)));
  }
  if (angles.empty()) return 0;
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  return angles[angles.size() / 2];
}

/// The Sampson distances (normalised units) of the inliers under E = [t]x R.
inline Eigen::VectorXd sampsonResiduals(const std::vector<Eigen::Vector3d>& a,
                                        const std::vector<Eigen::Vector3d>& b,
                                        const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
  return sampsonDistances(a, b, skew(t) * r);
}

/// Gauss-Newton on the inliers' Sampson distances over the pose's 5 degrees of freedom (a
/// rotation of second_R_first, the unit translation turned across itself), from the sampled
/// pose: the samplers' estimates are not maximum-likelihood ones. Levenberg-Marquardt steps (kept
/// only when they lower the cost), numerical Jacobian (central differences).
inline void refinePose(const std::vector<cv::Point2d>& pa, const std::vector<cv::Point2d>& pb,
                       const std::vector<std::uint8_t>& mask, Eigen::Matrix3d& r,
                       Eigen::Vector3d& t) {
  std::vector<Eigen::Vector3d> a, b;
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) a.emplace_back(pa[i].x, pa[i].y, 1), b.emplace_back(pb[i].x, pb[i].y, 1);
  using Vector5d = Eigen::Matrix<double, 5, 1>;
  auto perturbed = [&](const Vector5d& d, const Eigen::Matrix<double, 3, 2>& across,
                       Eigen::Matrix3d& rd, Eigen::Vector3d& td) {
    rd = expSO3(d.head<3>()).matrix() * r;
    td = (t + across * d.tail<2>()).normalized();
  };
  double cost = sampsonResiduals(a, b, r, t).squaredNorm();
  double lambda = 1e-6;
  for (int iteration = 0; iteration < 20; ++iteration) {
    Eigen::Matrix<double, 3, 2> across;
    across.col(0) = t.unitOrthogonal();
    across.col(1) = t.cross(across.col(0));
    const Eigen::VectorXd r0 = sampsonResiduals(a, b, r, t);
    Eigen::MatrixXd j(a.size(), 5);
    for (int k = 0; k < 5; ++k) {
      constexpr double kStep = 1e-7;
      Vector5d d = Vector5d::Zero();
      d(k) = kStep;
      Eigen::Matrix3d rp, rm;
      Eigen::Vector3d tp, tm;
      perturbed(d, across, rp, tp);
      perturbed(-d, across, rm, tm);
      j.col(k) = (sampsonResiduals(a, b, rp, tp) - sampsonResiduals(a, b, rm, tm)) / (2 * kStep);
    }
    // Levenberg-Marquardt: the damping grows until a step lowers the cost.
    const Eigen::Matrix<double, 5, 5> h = j.transpose() * j;
    const Vector5d g = -j.transpose() * r0;
    double new_cost = cost;
    Eigen::Matrix3d rn;
    Eigen::Vector3d tn;
    for (; lambda < 1e6 && !(new_cost < cost); lambda *= 10) {
      Eigen::Matrix<double, 5, 5> damped = h;
      damped.diagonal() *= 1 + lambda;
      const Vector5d step = damped.ldlt().solve(g);
      if (!step.allFinite()) return;
      perturbed(step, across, rn, tn);
      new_cost = sampsonResiduals(a, b, rn, tn).squaredNorm();
    }
    if (!(new_cost < cost)) return;
    lambda = std::max(lambda / 100, 1e-9);
    r = rn;
    t = tn;
    const bool converged = new_cost > 0.999999 * cost;
    cost = new_cost;
    if (converged) return;
  }
}

/// The inliers of the refined pose: within `threshold` of its epipolar lines (normalised units)
/// and in front of both cameras (the depths along both rays of their closest points positive).
inline int classify(const std::vector<cv::Point2d>& a, const std::vector<cv::Point2d>& b,
                    const Eigen::Matrix3d& r, const Eigen::Vector3d& t, double threshold,
                    std::vector<std::uint8_t>& mask) {
  Eigen::Matrix3d e = skew(t) * r;
  cv::Matx33d em;
  for (int i = 0; i < 9; ++i) em.val[i] = e(i / 3, i % 3);
  int count = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    // s1 R d1 + t = s2 d2 in the second camera's frame, in the least-squares sense.
    const Eigen::Vector3d rd1 = r * Eigen::Vector3d(a[i].x, a[i].y, 1);
    const Eigen::Vector3d d2(b[i].x, b[i].y, 1);
    Eigen::Matrix<double, 3, 2> m;
    m << rd1, -d2;
    const Eigen::Vector2d depths = m.colPivHouseholderQr().solve(-t);
    mask[i] = depths.x() > 0 && depths.y() > 0 && epipolarDistance(em, a[i], b[i]) <= threshold;
    count += mask[i];
  }
  return count;
}

/// The robust E and its inliers in normalised coordinates, refitted when asked.
inline Status robustEssential(const std::vector<cv::Point2d>& a, const std::vector<cv::Point2d>& b,
                              double threshold, const Settings& s, cv::Mat& e,
                              std::vector<std::uint8_t>& mask) {
  try {
    e = cv::findEssentialMat(a, b, cv::Mat::eye(3, 3, CV_64F), s.method, s.confidence, threshold,
                             s.max_iterations, mask);
    if (e.rows > 3 && e.cols == 3) e = e.rowRange(0, 3).clone();  // the first of several
    if (s.refit && e.rows == 3 && e.cols == 3) refitToInliers(a, b, threshold, e, mask);
  } catch (const cv::Exception& ex) {
    return numericalFailure("EssentialMatrixEstimation: {} failed on {} pairs: {}", s.method_name,
                            a.size(), ex.what());
  }
  if (e.rows != 3 || e.cols != 3 || !cv::checkRange(e) || mask.size() != a.size())
    return numericalFailure(
        "EssentialMatrixEstimation: {} found no essential matrix among {} "
        "pairs (threshold {} px)",
        s.method_name, a.size(), s.threshold);
  return Status::ok();
}

/// first_T_second from second_T_first = (R, t).
inline Transform firstTSecond(const Eigen::Matrix3d& second_R_first,
                              const Eigen::Vector3d& second_t_first, const Settings& s) {
  Transform pose;
  pose.parent_frame = s.first_frame;
  pose.child_frame = s.second_frame;
  pose.rotation = Eigen::Quaterniond(second_R_first.transpose()).normalized();
  pose.translation = -(second_R_first.transpose() * second_t_first).normalized();
  return pose;
}

/// E, the pose, the inliers in front of both cameras, and the checks, into `out`.
inline Status estimate(const Correspondences2D& c, const CameraModel& first,
                       const CameraModel& second, const Settings& s,
                       EssentialMatrixEstimation::Outputs& out) {
  CDFF_RETURN_IF_ERROR(c.validate("input 'correspondences'"));
  if (c.size() < 5)
    return invalidInput(
        "input 'correspondences' has {} pairs; expected at least 5 for an "
        "essential matrix",
        c.size());
  if (Status st = first.validate(); !st.isOk())
    return invalidInput("input 'camera': {}", st.message());
  if (Status st = second.validate(); !st.isOk())
    return invalidInput("input 'second_camera': {}", st.message());
  auto n1 = normalizedCoordinates(first, c.first, "input 'correspondences' (first)");
  if (!n1) return n1.status();
  auto n2 = normalizedCoordinates(second, c.second, "input 'correspondences' (second)");
  if (!n2) return n2.status();
  const std::vector<cv::Point2d> a = toCvPoints(n1.value()), b = toCvPoints(n2.value());
  const double threshold = s.threshold / (0.5 * (first.fx + first.fy));
  cv::Mat e, r, t;
  std::vector<std::uint8_t> mask;
  CDFF_RETURN_IF_ERROR(robustEssential(a, b, threshold, s, e, mask));
  int count = 0;
  try {
    // Before the cheirality test, which a rotation alone fails (every point at infinity): the
    // rotation of E's two that leaves the smaller parallax is the motion's when it is small.
    cv::Mat r1, r2, t_unused;
    cv::decomposeEssentialMat(e, r1, r2, t_unused);
    const double parallax = std::min(medianParallax(a, b, mask, cv::Matx33d(r1)),
                                     medianParallax(a, b, mask, cv::Matx33d(r2)));
    if (parallax < s.min_parallax)
      return invalidInput(
          "input 'correspondences': the median parallax of the inliers is "
          "{:.4f} deg, below min_parallax {:.4f} deg: the camera turned without "
          "moving (or the scene is too far), the translation is not determined; "
          "expected views from two positions",
          parallax * 180 / M_PI, s.min_parallax * 180 / M_PI);
    count = cv::recoverPose(e, a, b, cv::Mat::eye(3, 3, CV_64F), r, t, mask);
  } catch (const cv::Exception& ex) {
    return numericalFailure("EssentialMatrixEstimation: recovering the pose failed: {}", ex.what());
  }
  if (count < 5)
    return numericalFailure(
        "EssentialMatrixEstimation: {} of {} pairs agree with E and lie in "
        "front of both cameras (threshold {} px); expected at least 5",
        count, c.size(), s.threshold);
  Eigen::Matrix3d second_R_first;
  Eigen::Vector3d second_t_first;
  cv::cv2eigen(r, second_R_first);
  cv::cv2eigen(t, second_t_first);
  second_t_first.normalize();
  // The sampled pose's inliers are those of a pose some way off: refine on them, classify again
  // under the refined pose, and repeat until the inliers no longer change (at most 5 rounds).
  for (int round = 0; round < 5; ++round) {
    refinePose(a, b, mask, second_R_first, second_t_first);
    const std::vector<std::uint8_t> before = mask;
    count = classify(a, b, second_R_first, second_t_first, threshold, mask);
    if (mask == before || count < 5) break;
  }
  if (count < 5)
    return numericalFailure(
        "EssentialMatrixEstimation: {} of {} pairs agree with the refined "
        "pose (threshold {} px); expected at least 5",
        count, c.size(), s.threshold);
  // E of the refined pose, [t]x R with |t| = 1, so that the two outputs agree exactly.
  const Eigen::Matrix3d e_refined = skew(second_t_first) * second_R_first;
  nlohmann::json rows = nlohmann::json::array(), indices = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) rows.push_back({e_refined(i, 0), e_refined(i, 1), e_refined(i, 2)});
  Correspondences2D inliers;
  for (std::size_t i = 0; i < mask.size(); ++i) {
    if (!mask[i]) continue;
    inliers.first.push_back(c.first[i]);
    inliers.second.push_back(c.second[i]);
    indices.push_back(i);
  }
  out.essential.set(std::move(rows));
  out.pose.set(firstTSecond(second_R_first, second_t_first, s));
  out.inliers.set(std::move(inliers));
  out.inlier_indices.set(std::move(indices));
  out.inlier_count.set(count);
  return Status::ok();
}

}  // namespace cdff::dfn::essential
