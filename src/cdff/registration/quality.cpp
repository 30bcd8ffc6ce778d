#include "cdff/registration/quality.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace cdff::registration {

Quality evaluate(std::span<const Eigen::Vector3f> source, const ModelIndex& model,
                 const Eigen::Isometry3d& pose, double inlier_distance, double covariance_inflation,
                 const std::vector<std::uint32_t>* hints) {
  Quality q;
  if (source.empty()) return q;
  const Eigen::Matrix3f r_inv = pose.linear().transpose().cast<float>();
  const Eigen::Vector3f t = pose.translation().cast<float>();
  const Eigen::Matrix3d rotation = pose.linear();
  const float max_sq = static_cast<float>(inlier_distance * inlier_distance);
  Matrix6d h = Matrix6d::Zero();
  double sum_r2 = 0;
  const bool hinted = hints != nullptr && hints->size() == source.size();
  for (std::size_t i = 0; i < source.size(); ++i) {
    const Eigen::Vector3f& p = source[i];
    const Eigen::Vector3f pm = r_inv * (p - t);
    KdTree3f::Neighbour nn;
    float bound = max_sq;
    if (hinted && (*hints)[i] != ~std::uint32_t{0})
      bound =
          std::min(max_sq, (model.points[(*hints)[i]].vec() - pm).squaredNorm() * 1.0001f + 1e-12f);
    if (!model.tree.nearest(pm, bound, nn) &&
        !(bound < max_sq && model.tree.nearest(pm, max_sq, nn)))
      continue;
    const Eigen::Vector3f nm = model.normals[nn.index].vec();
    const double r = nm.dot(pm - model.points[nn.index].vec());
    const Eigen::Vector3d n = rotation * nm.cast<double>();
    Vector6d j;
    j << -n, n.cross(p.cast<double>() - pose.translation());
    h.selfadjointView<Eigen::Lower>().rankUpdate(j);
    sum_r2 += r * r;
    ++q.inliers;
  }
  q.fitness = static_cast<double>(q.inliers) / static_cast<double>(source.size());
  if (q.inliers == 0) return q;
  q.inlier_rms = std::sqrt(sum_r2 / static_cast<double>(q.inliers));
  h = h.selfadjointView<Eigen::Lower>();
  if (q.inliers <= 6) {
    q.degenerate = true;
    return q;
  }
  const double sigma2 = sum_r2 / static_cast<double>(q.inliers - 6);
  // A tiny ridge keeps directions the scan does not constrain finite but very uncertain.
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(h);
  const double largest = eigen.eigenvalues().maxCoeff();
  q.degenerate = !(eigen.eigenvalues().minCoeff() > 1e-6 * largest);
  const Matrix6d regularised = h + Matrix6d::Identity() * (1e-9 * largest + 1e-12);
  q.covariance = covariance_inflation * sigma2 * regularised.ldlt().solve(Matrix6d::Identity());
  q.covariance = 0.5 * (q.covariance + q.covariance.transpose());
  return q;
}

}  // namespace cdff::registration
