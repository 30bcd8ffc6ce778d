#include "cdff/registration/icp.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "cdff/registration/median.hpp"

namespace cdff::registration {

IcpRun IcpRun::startingAt(const Eigen::Isometry3d& pose, double distance) {
  IcpRun run;
  run.setPose(pose);
  run.distance = distance;
  return run;
}

void IcpRun::setPose(const Eigen::Isometry3d& at) {
  pose.linear() = at.linear();
  pose.translation() = at.translation();
}

Vector6d IcpRun::fromAnchor() const {
  const Eigen::Matrix3d rotation = pose.linear();
  Vector6d d;
  d.head<3>() = pose.translation() - anchor.translation();
  d.tail<3>() = logSO3(Eigen::Quaterniond(rotation * anchor.linear().transpose()));
  return d;
}

void Icp::configure(const IcpOptions& options) {
  options_ = options;
  association_.configure(options.association);
}

void Icp::setModel(const ModelSearch& model) {
  association_.setModel(model);
}

Icp::NormalEquations Icp::normalEquations(Correspondences& c, const IcpRun& run) {
  const IcpOptions& o = options_;
  const double scale = o.kernel_scale > 0
                           ? o.kernel_scale
                           : std::max(o.min_kernel_scale, 1.4826 * median(c.abs_residuals));
  NormalEquations e;
  Matrix6d& h = e.h;
  Vector6d& g = e.g;
  if (run.distance > o.point_to_point_above && o.point_to_point_above > 0) {
    // Coarse phase: point-to-point, whose basin of convergence is wider. The residual
    // e = (R q + t) - p has the Jacobian [I, -[R q]x] in the pose perturbation.
    const double pp_scale = std::max(o.min_kernel_scale, 1.4826 * median(c.distances));
    for (const Correspondence& pair : c.pairs) {
      const double w = robustWeight(o.kernel, pair.offset.norm(), pp_scale);
      if (w <= 0) continue;
      Eigen::Matrix<double, 3, 6> j;
      j << Eigen::Matrix3d::Identity(), -skew(pair.rq);
      h.noalias() += w * j.transpose() * j;
      g.noalias() += w * j.transpose() * pair.offset;
    }
  } else {
    e.point_to_plane = true;
    for (const Correspondence& pair : c.pairs) {
      const double w = robustWeight(o.kernel, pair.r, scale);
      if (w <= 0) continue;
      h.selfadjointView<Eigen::Lower>().rankUpdate(pair.j, w);
      g += w * pair.r * pair.j;
      e.weighted_r2 += w * pair.r * pair.r;
      e.weight_sum += w;
    }
  }
  h = h.selfadjointView<Eigen::Lower>();
  if (!run.anchor_precision.isZero()) {
    h.diagonal() += run.anchor_precision;
    g += run.anchor_precision.cwiseProduct(run.fromAnchor());
  }
  // A relative ridge keeps the step finite when the scan leaves a direction unconstrained
  // (e.g. one flat face): that direction then stays at the guess instead of jumping.
  h.diagonal().array() += 1e-9 * h.diagonal().maxCoeff() + 1e-12;
  return e;
}

Result<IcpRun> Icp::iterate(std::span<const Eigen::Vector3f> points, IcpRun s, int max_iterations,
                            NearestPoints nearest) {
  const IcpOptions& o = options_;
  bool first = true;
  const int stop = s.iterations + max_iterations;
  for (; s.iterations < stop; ++s.iterations) {
    Correspondences& c = association_.match(points, s.pose, s.distance, first, nearest);
    if (c.pairs.size() < static_cast<std::size_t>(o.min_correspondences)) {
      s.starved = true;
      s.last_pairs = c.pairs.size();
      break;
    }
    first = false;
    const NormalEquations e = normalEquations(c, s);
    const Matrix6d& h = e.h;
    const Vector6d step = -h.ldlt().solve(e.g);
    if (!step.allFinite())
      return numericalFailure(
          "the Gauss-Newton step of iteration {} is not finite ({} correspondences); the "
          "problem is degenerate",
          s.iterations + 1, c.pairs.size());
    // Converged when the step is below the epsilons, or below convergence_sigma standard
    // deviations of the estimate (its length under the Gauss-Newton covariance): moving by a
    // small fraction of the uncertainty cannot improve the estimate. Correspondences that flip
    // between neighbouring model points can also make the pose hop back and forth: a step that
    // undoes the previous one ends the iterations halfway between the two.
    const double variance = e.weighted_r2 / std::max(1.0, e.weight_sum - 6.0);
    auto small = [&](const Vector6d& d) {
      if (d.head<3>().norm() < o.translation_epsilon && d.tail<3>().norm() < o.rotation_epsilon)
        return true;
      return e.point_to_plane && o.convergence_sigma > 0 && variance > 0 &&
             d.dot(h * d) / variance < o.convergence_sigma * o.convergence_sigma;
    };
    const bool hop_back = s.iterations > 0 && small(step + s.previous_step);
    const Vector6d applied = hop_back ? Vector6d(0.5 * step) : step;
    s.pose.translation() += applied.head<3>();
    const Eigen::Matrix3d rotation =
        expSO3(applied.tail<3>()).toRotationMatrix() * Eigen::Matrix3d(s.pose.linear());
    s.pose.linear() = rotation;
    s.previous_step = step;
    // Shrink the correspondence distance as the alignment improves: three robust standard
    // deviations of the point-to-point distances, never below the configured floor.
    s.distance =
        std::clamp(3.0 * 1.4826 * median(c.distances), o.min_correspondence_distance, s.distance);
    if (hop_back || small(step)) {
      s.converged = true;
      ++s.iterations;
      break;
    }
  }
  return s;
}

}  // namespace cdff::registration
