#pragma once
// The refinement of F shared by both FundamentalMatrixEstimation DFIs: Levenberg-Marquardt on
// the inliers' Sampson distances (px) over F's 7 degrees of freedom, with a Cauchy loss so that
// the few outliers within the threshold do not pull it.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Dense>
#include <opencv2/core.hpp>

#include "cdff/types/epipolar.hpp"
#include "cdff/types/geometry.hpp"

namespace cdff::dfn::fundamental {

/// The Jacobians of the Sampson distances with respect to F's 9 entries (row-major), analytic:
/// r = N / D with N = b^T F a and D^2 = (Fa)_0^2 + (Fa)_1^2 + (F^T b)_0^2 + (F^T b)_1^2.
inline Eigen::Matrix<double, Eigen::Dynamic, 9> sampsonJacobian(
    const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
    const Eigen::Matrix3d& f) {
  Eigen::Matrix<double, Eigen::Dynamic, 9> j(a.size(), 9);
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Eigen::Vector3d fa = f * a[i], fb = f.transpose() * b[i];
    const double d2 = fa.head<2>().squaredNorm() + fb.head<2>().squaredNorm();
    const double d = std::sqrt(d2), n = b[i].dot(fa);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        // dD/dF_rc = ((Fa)_r a_c [r < 2] + (F^T b)_c b_r [c < 2]) / D
        const double dd = ((r < 2 ? fa(r) * a[i](c) : 0.0) + (c < 2 ? fb(c) * b[i](r) : 0.0)) / d;
        j(static_cast<Eigen::Index>(i), 3 * r + c) = b[i](r) * a[i](c) / d - n * dd / d2;
      }
  }
  return j;
}

/// Hartley's normalisation of a point set: the centroid to the origin, mean distance sqrt(2).
inline Eigen::Matrix3d normalisation(const std::vector<Eigen::Vector3d>& p) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& x : p) mean += x.head<2>();
  mean /= static_cast<double>(p.size());
  double spread = 0;
  for (const auto& x : p) spread += (x.head<2>() - mean).norm();
  const double scale = std::sqrt(2.0) * static_cast<double>(p.size()) / std::max(spread, 1e-12);
  Eigen::Matrix3d t;
  t << scale, 0, -scale * mean.x(), 0, scale, -scale * mean.y(), 0, 0, 1;
  return t;
}

/// Cauchy weights of the residuals, their scale c = 2.385 times the robust sigma (1.4826 times the
/// median absolute residual, at least `min_sigma`): an outlier that the threshold let in counts
/// 1 / (1 + (r / c)^2), e.g. 1/38 at 6 sigma.
inline Eigen::VectorXd cauchyWeights(const Eigen::VectorXd& r, double min_sigma, double& c) {
  std::vector<double> abs(r.size());
  for (Eigen::Index i = 0; i < r.size(); ++i) abs[i] = std::abs(r(i));
  std::nth_element(abs.begin(), abs.begin() + abs.size() / 2, abs.end());
  c = 2.385 * std::max(1.4826 * abs[abs.size() / 2], min_sigma);
  return (1.0 + (r.array() / c).square()).inverse().matrix();
}

/// The Cauchy cost sum c^2 / 2 log(1 + (r / c)^2).
inline double cauchyCost(const Eigen::VectorXd& r, double c) {
  return 0.5 * c * c * (1.0 + (r.array() / c).square()).log().sum();
}

/// F = T2^T U diag(1, s, 0) V^T T1 (U, V rotations, in Hartley-normalised coordinates): F's 7
/// degrees of freedom, perturbed as U exp(d0..2), V exp(d3..5), s + d6.
struct FactoredF {
  Eigen::Matrix3d u, v;
  double s = 1;
  Eigen::Matrix3d t1, t2;

  Eigen::Matrix3d matrix() const {
    return t2.transpose() * u * Eigen::Vector3d(1, s, 0).asDiagonal() * v.transpose() * t1;
  }
  FactoredF perturbed(const Eigen::Matrix<double, 7, 1>& d) const {
    FactoredF p = *this;
    p.u = u * expSO3(d.segment<3>(0)).matrix();
    p.v = v * expSO3(d.segment<3>(3)).matrix();
    p.s = s + d(6);
    return p;
  }
  static FactoredF of(const Eigen::Matrix3d& f, const Eigen::Matrix3d& t1,
                      const Eigen::Matrix3d& t2) {
    const Eigen::Matrix3d fn = t2.transpose().inverse() * f * t1.inverse();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(fn, Eigen::ComputeFullU | Eigen::ComputeFullV);
    FactoredF x;
    x.u = svd.matrixU();
    x.v = svd.matrixV();
    // The third singular vectors meet a zero singular value: their signs make U, V rotations.
    if (x.u.determinant() < 0) x.u.col(2) *= -1;
    if (x.v.determinant() < 0) x.v.col(2) *= -1;
    x.s = svd.singularValues()(1) / svd.singularValues()(0);
    x.t1 = t1;
    x.t2 = t2;
    return x;
  }
};

/// Levenberg-Marquardt from `f` on the Cauchy cost of the Sampson distances of the pairs of `mask`
/// (iteratively reweighted; steps kept only when they lower the cost; the Jacobian analytic in F,
/// F's by central differences). `f` becomes rank 2.
inline void refineF(const std::vector<cv::Point2d>& pa, const std::vector<cv::Point2d>& pb,
                    const std::vector<std::uint8_t>& mask, Eigen::Matrix3d& f) {
  std::vector<Eigen::Vector3d> a, b;
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) a.emplace_back(pa[i].x, pa[i].y, 1), b.emplace_back(pb[i].x, pb[i].y, 1);
  if (a.size() < 8) return;
  using Vector7d = Eigen::Matrix<double, 7, 1>;
  FactoredF x = FactoredF::of(f, normalisation(a), normalisation(b));
  // Iteratively reweighted: the Cauchy scale from the starting residuals, then fixed, the
  // weights from each iteration's residuals.
  double c = 1;
  cauchyWeights(sampsonDistances(a, b, x.matrix()), 1e-3, c);
  double cost = cauchyCost(sampsonDistances(a, b, x.matrix()), c), lambda = 1e-6;
  for (int iteration = 0; iteration < 200; ++iteration) {
    const Eigen::VectorXd r0 = sampsonDistances(a, b, x.matrix());
    const Eigen::VectorXd w = (1.0 + (r0.array() / c).square()).inverse().matrix();
    // J = dr/dF (analytic) dF/dd (central differences of the 3x3 matrix: cheap).
    Eigen::Matrix<double, 9, 7> df;
    for (int k = 0; k < 7; ++k) {
      constexpr double kStep = 1e-7;
      const Vector7d d = Vector7d::Unit(k) * kStep;
      const Eigen::Matrix3d diff =
          (x.perturbed(d).matrix() - x.perturbed(-d).matrix()) / (2 * kStep);
      for (int e = 0; e < 9; ++e) df(e, k) = diff(e / 3, e % 3);
    }
    const Eigen::MatrixXd j = sampsonJacobian(a, b, x.matrix()) * df;
    const Eigen::Matrix<double, 7, 7> h = j.transpose() * w.asDiagonal() * j;
    const Vector7d g = -j.transpose() * w.cwiseProduct(r0);
    double new_cost = cost;
    FactoredF next = x;
    for (; lambda < 1e6 && !(new_cost < cost); lambda *= 10) {
      Eigen::Matrix<double, 7, 7> damped = h;
      damped.diagonal() *= 1 + lambda;
      const Vector7d step = damped.ldlt().solve(g);
      if (!step.allFinite()) break;
      next = x.perturbed(step);
      new_cost = cauchyCost(sampsonDistances(a, b, next.matrix()), c);
    }
    if (!(new_cost < cost)) break;
    lambda = std::max(lambda / 100, 1e-9);
    x = next;
    // Converged when a step gains less than 1e-4 of one residual's variance (sigma = c / 2.385):
    // statistically nothing.
    const double sigma = c / 2.385;
    const bool converged = cost - new_cost < 1e-4 * 0.5 * sigma * sigma;
    cost = new_cost;
    if (converged) break;
  }
  f = x.matrix();
}

}  // namespace cdff::dfn::fundamental
