#pragma once
// Shared by the Registration3D DFIs: input checks, the model index kept between calls, and the
// quality measures and covariance, computed the same way for every DFI at its final pose.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "Registration3D.gen.hpp"
#include "cdff/types/kd_tree.hpp"

namespace cdff::dfn::registration {

/// A model cloud and the KD-tree over it, rebuilt only when a cloud with another point buffer
/// arrives (Buffer::sharesMemoryWith: the index keeps its buffers alive, so an equal address
/// always means the same points).
struct ModelIndex {
  Buffer<Point4f> points;
  Buffer<Point4f> normals;
  KdTree3f tree;
  std::uint64_t builds = 0;  // a number unique to each build in the process (0: none)

  bool holds(const PointCloud& model) const {
    return !points.empty() && points.sharesMemoryWith(model.points) &&
           normals.sharesMemoryWith(model.normals) && points.size() == model.points.size();
  }

  /// Checks `model` and (re)builds the index when it is a new cloud.
  Status update(const PointCloud& model) {
    if (holds(model)) return Status::ok();
    CDFF_RETURN_IF_ERROR(model.validate("input 'model'"));
    if (!model.hasNormals())
      return invalidInput(
          "input 'model' ({} points, frame '{}') has no normals; expected one unit normal per "
          "point for the point-to-plane error (sample the model from a mesh with "
          "ModelPointCloud, or run NormalsEstimation on it)",
          model.size(), model.frame_id);
    for (std::size_t i = 0; i < model.normals.size(); ++i) {
      const Point4f& n = model.normals[i];
      const float norm = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
      if (!std::isfinite(norm) || std::abs(norm - 1.0f) > 1e-2f)
        return invalidInput(
            "input 'model' normal {} is ({}, {}, {}) with norm {}; expected a finite unit vector",
            i, n.x, n.y, n.z, norm);
    }
    points = model.points;
    normals = model.normals;
    tree.build(model.points.span(), 12, model.normals.span());
    static std::atomic<std::uint64_t> generation{0};
    builds = ++generation;
    return Status::ok();
  }
};

/// The ModelIndex of `model`, shared by every DFI instance of the process that registers against
/// the same model buffer (a DFPC's acquisition and tracking registrations): the first to see the
/// model builds it, the others reuse it, so a registration that starts later (tracking, after the
/// acquisition) does not spend its first call building the same structures. `current` is
/// returned as it is when it holds the model. The index is immutable once built.
inline Result<std::shared_ptr<const ModelIndex>> sharedIndex(
    const PointCloud& model, const std::shared_ptr<const ModelIndex>& current) {
  if (current && current->holds(model)) return current;
  static std::mutex mutex;
  static std::vector<std::weak_ptr<const ModelIndex>> live;
  const std::lock_guard<std::mutex> lock(mutex);
  std::erase_if(live, [](const std::weak_ptr<const ModelIndex>& w) { return w.expired(); });
  for (const std::weak_ptr<const ModelIndex>& w : live)
    if (std::shared_ptr<const ModelIndex> index = w.lock(); index && index->holds(model))
      return index;
  auto fresh = std::make_shared<ModelIndex>();
  CDFF_RETURN_IF_ERROR(fresh->update(model));
  live.push_back(fresh);
  return std::shared_ptr<const ModelIndex>(std::move(fresh));
}

/// Checks the scan and the guess; returns the starting pose source_T_model.
inline Result<Eigen::Isometry3d> checkInputs(const PointCloud& source, const PointCloud& model,
                                             const Transform* initial_guess) {
  CDFF_RETURN_IF_ERROR(source.validate("input 'source'"));
  if (initial_guess == nullptr) return Eigen::Isometry3d::Identity();
  CDFF_RETURN_IF_ERROR(initial_guess->validate().withContext("input 'initial_guess'"));
  const bool parent_ok = initial_guess->parent_frame.empty() || source.frame_id.empty() ||
                         initial_guess->parent_frame == source.frame_id;
  const bool child_ok = initial_guess->child_frame.empty() || model.frame_id.empty() ||
                        initial_guess->child_frame == model.frame_id;
  if (!parent_ok || !child_ok)
    return invalidInput(
        "input 'initial_guess' is {}_T_{}; expected source_T_model = {}_T_{} (the frames of "
        "'source' and 'model')",
        initial_guess->parent_frame, initial_guess->child_frame, source.frame_id, model.frame_id);
  return initial_guess->isometry();
}

/// The source points a DFI uses, into `out`: all, or at most `max_points` evenly strided ones.
inline void selectSource(const PointCloud& source, int max_points,
                         std::vector<Eigen::Vector3f>& out) {
  const std::size_t n = source.size();
  const std::size_t keep =
      max_points > 0 ? std::min<std::size_t>(n, static_cast<std::size_t>(max_points)) : n;
  out.clear();
  out.reserve(keep);
  for (std::size_t k = 0; k < keep; ++k) out.push_back(source.points[k * n / keep].vec());
}

struct Quality {
  double fitness = 0;
  double inlier_rms = std::numeric_limits<double>::quiet_NaN();
  std::size_t inliers = 0;
  Matrix6d covariance = Matrix6d::Zero();  // [dt, dtheta] in the source frame
  bool degenerate = false;                 // some direction is barely constrained
};

/// Quality measures of source_T_model `pose`: fitness, inlier RMS and the Gauss-Newton
/// covariance of the point-to-plane problem over the inliers.
///
/// Residual of a source point p (source frame) paired with the model point q and normal n (model
/// frame), with n' = R n and q' = R q + t in the source frame: r = n' . (p - q'). Perturbing the
/// pose as the conventions do (t + dt, exp(dtheta) R) gives the Jacobian
/// dr/d[dt, dtheta] = [-n', n' x (p - t)].
///
/// `hints` (one model index per source point, or ~0u) are earlier matches that bound each
/// search: the result is the same, found faster.
inline Quality evaluate(std::span<const Eigen::Vector3f> source, const ModelIndex& model,
                        const Eigen::Isometry3d& pose, double inlier_distance,
                        double covariance_inflation,
                        const std::vector<std::uint32_t>* hints = nullptr) {
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

/// Writes every output of a Registration3D DFI.
inline void publish(Registration3D::Outputs& out, const PointCloud& source, const PointCloud& model,
                    const Eigen::Isometry3d& pose, const Quality& quality, bool converged,
                    int iterations) {
  Transform t = Transform::fromIsometry(pose, source.frame_id, model.frame_id, source.stamp);
  t.rotation.normalize();
  PoseWithCovariance pwc;
  pwc.pose = t;
  pwc.covariance = quality.covariance;
  out.transform.set(std::move(t));
  out.pose.set(std::move(pwc));
  out.fitness.set(quality.fitness);
  out.inlier_rms.set(quality.inlier_rms);
  out.converged.set(converged);
  out.iterations.set(iterations);
}

}  // namespace cdff::dfn::registration
