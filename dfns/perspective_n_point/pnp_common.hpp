#pragma once
// The estimation both PerspectiveNPoint DFIs share; they differ in the solver of the final fit.

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "PerspectiveNPoint.gen.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn::pnp {

struct Fit {
  std::vector<int> inliers;
  cv::Mat rvec, tvec;  // camera_T_model
};

/// The pairs in front of the camera and within `threshold` (normalised units) of their ray under
/// the fit's pose, increasing.
inline std::vector<int> inliersOf(const std::vector<cv::Point3d>& points,
                                  const std::vector<cv::Point2d>& rays, const Fit& fit,
                                  double threshold) {
  cv::Matx33d r;
  cv::Rodrigues(fit.rvec, r);
  const cv::Vec3d t(fit.tvec.at<double>(0), fit.tvec.at<double>(1), fit.tvec.at<double>(2));
  std::vector<int> out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const cv::Vec3d pc = r * cv::Vec3d(points[i].x, points[i].y, points[i].z) + t;
    if (pc[2] > 0 && std::hypot(pc[0] / pc[2] - rays[i].x, pc[1] / pc[2] - rays[i].y) <= threshold)
      out.push_back(static_cast<int>(i));
  }
  return out;
}

/// RANSAC, the solver's fit to the inliers, and the LM refinement, in normalised coordinates.
template <typename Parameters>
Result<Fit> robustFit(const std::vector<cv::Point3d>& points, const std::vector<cv::Point2d>& rays,
                      const Parameters& p, double focal, int flags, const char* solver) {
  Fit fit;
  const cv::Mat k = cv::Mat::eye(3, 3, CV_64F);
  try {
    const bool found =
        cv::solvePnPRansac(points, rays, k, cv::noArray(), fit.rvec, fit.tvec, false,
                           p.max_iterations, p.threshold / focal, p.confidence, fit.inliers, flags);
    if (!found || static_cast<int>(fit.inliers.size()) < p.min_inliers)
      return numericalFailure(
          "PerspectiveNPoint: RANSAC ({}) found {} inliers among {} pairs "
          "(threshold {} px); expected at least min_inliers = {}",
          solver, fit.inliers.size(), points.size(), p.threshold, p.min_inliers);
    fit.rvec.convertTo(fit.rvec, CV_64F);
    fit.tvec.convertTo(fit.tvec, CV_64F);
    // Refine on the inliers, classify again under the refined pose (RANSAC's inliers are its
    // sample's), until they no longer change (at most 5 rounds).
    for (int round = 0; round < 5; ++round) {
      std::vector<cv::Point3d> in_points;
      std::vector<cv::Point2d> in_rays;
      for (int i : fit.inliers) in_points.push_back(points[i]), in_rays.push_back(rays[i]);
      cv::solvePnPRefineLM(in_points, in_rays, k, cv::noArray(), fit.rvec, fit.tvec);
      const std::vector<int> before = fit.inliers;
      fit.inliers = inliersOf(points, rays, fit, p.threshold / focal);
      if (fit.inliers == before || static_cast<int>(fit.inliers.size()) < p.min_inliers) break;
    }
    if (static_cast<int>(fit.inliers.size()) < p.min_inliers)
      return numericalFailure(
          "PerspectiveNPoint: {} of {} pairs agree with the refined pose "
          "(threshold {} px); expected at least min_inliers = {}",
          fit.inliers.size(), points.size(), p.threshold, p.min_inliers);
  } catch (const cv::Exception& e) {
    return numericalFailure("PerspectiveNPoint: {} failed on {} pairs: {}", solver, points.size(),
                            e.what());
  }
  return fit;
}

/// sigma^2 (J^T J)^-1 of the inliers' reprojection errors (px) for camera_T_model = (R, t) with
/// respect to [dt, dtheta]: p_c = exp(dtheta) R p_m + t + dt.
inline Result<Matrix6d> covariance(const std::vector<cv::Point3d>& points,
                                   const std::vector<cv::Point2d>& rays, const Fit& fit,
                                   const Eigen::Matrix3d& r, const Eigen::Vector3d& t,
                                   const CameraModel& camera) {
  Matrix6d jtj = Matrix6d::Zero();
  double sum2 = 0;
  for (int i : fit.inliers) {
    const Eigen::Vector3d q = r * Eigen::Vector3d(points[i].x, points[i].y, points[i].z);
    const Eigen::Vector3d pc = q + t;
    if (!(pc.z() > 0))
      return invalidInput(
          "input 'correspondences' point {} is {} m behind the camera under the "
          "fitted pose; expected every inlier in front of it",
          i, -pc.z());
    Eigen::Matrix<double, 2, 3> proj;
    proj << camera.fx / pc.z(), 0, -camera.fx * pc.x() / (pc.z() * pc.z()), 0, camera.fy / pc.z(),
        -camera.fy * pc.y() / (pc.z() * pc.z());
    Eigen::Matrix<double, 2, 6> j;
    j.leftCols<3>() = proj;
    j.rightCols<3>() = -proj * skew(q);
    jtj += j.transpose() * j;
    const Eigen::Vector2d residual(camera.fx * (pc.x() / pc.z() - rays[i].x),
                                   camera.fy * (pc.y() / pc.z() - rays[i].y));
    sum2 += residual.squaredNorm();
  }
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(jtj);
  const double smallest = eig.eigenvalues()(0), largest = eig.eigenvalues()(5);
  if (!(smallest > 1e-12 * largest))
    return numericalFailure(
        "PerspectiveNPoint: the {} inliers do not determine the pose (the "
        "normal matrix's eigenvalues {} and {}: collinear points?); expected "
        "points spread in at least two directions",
        fit.inliers.size(), smallest, largest);
  const double sigma2 = sum2 / (2.0 * static_cast<double>(fit.inliers.size()) - 6.0);
  Matrix6d cov = sigma2 * jtj.inverse();
  return Matrix6d(0.5 * (cov + cov.transpose()));
}

/// The pose, its covariance and the inliers, into `out`.
template <typename Parameters>
Status estimate(const Correspondences2D3D& c, const CameraModel& camera, const Parameters& p,
                int flags, const char* solver, PerspectiveNPoint::Outputs& out) {
  CDFF_RETURN_IF_ERROR(c.validate("input 'correspondences'"));
  if (c.size() < 4)
    return invalidInput("input 'correspondences' has {} pairs; expected at least 4 for a pose",
                        c.size());
  if (Status s = camera.validate(); !s.isOk())
    return invalidInput("input 'camera': {}", s.message());
  auto normalised = normalizedCoordinates(camera, c.pixels, "input 'correspondences'");
  if (!normalised) return normalised.status();
  std::vector<cv::Point3d> points;
  for (const Eigen::Vector3d& p : c.points) points.emplace_back(p.x(), p.y(), p.z());
  const std::vector<cv::Point2d> rays = toCvPoints(normalised.value());
  Result<Fit> fit = robustFit(points, rays, p, 0.5 * (camera.fx + camera.fy), flags, solver);
  if (!fit) return fit.status();
  cv::Mat rm;
  cv::Rodrigues(fit.value().rvec, rm);
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  cv::cv2eigen(rm, r);
  cv::cv2eigen(fit.value().tvec, t);
  if (!r.allFinite() || !t.allFinite())
    return numericalFailure("PerspectiveNPoint: {} returned a non-finite pose", solver);
  Result<Matrix6d> cov = covariance(points, rays, fit.value(), r, t, camera);
  if (!cov) return cov.status();
  PoseWithCovariance pose;
  pose.pose.parent_frame = p.camera_frame;
  pose.pose.child_frame = p.model_frame;
  pose.pose.rotation = Eigen::Quaterniond(r).normalized();
  pose.pose.translation = t;
  pose.covariance = cov.value();
  out.pose.set(std::move(pose));
  out.inlier_indices.set(nlohmann::json(fit.value().inliers));
  out.inlier_count.set(static_cast<int>(fit.value().inliers.size()));
  return Status::ok();
}

}  // namespace cdff::dfn::pnp
