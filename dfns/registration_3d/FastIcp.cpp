#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Cholesky>

#include "Registration3D.gen.hpp"
#include "registration_common.hpp"

namespace cdff::dfn {

namespace {

enum class Kernel { kNone, kHuber, kTukey, kGemanMcClure };

Kernel parseKernel(const std::string& name) {
  if (name == "huber") return Kernel::kHuber;
  if (name == "tukey") return Kernel::kTukey;
  if (name == "geman_mcclure") return Kernel::kGemanMcClure;
  return Kernel::kNone;
}

// Iteratively reweighted least squares weights w(r) = rho'(r) / r, with each kernel's usual
// tuning constant expressed in units of the residual scale s (95 % efficiency on Gaussian noise
// for Huber and Tukey).
double weight(Kernel kernel, double r, double s) {
  switch (kernel) {
    case Kernel::kNone:
      return 1.0;
    case Kernel::kHuber: {
      const double k = 1.345 * s;
      return std::abs(r) <= k ? 1.0 : k / std::abs(r);
    }
    case Kernel::kTukey: {
      const double c = 4.685 * s;
      if (std::abs(r) >= c) return 0.0;
      const double u = 1.0 - (r / c) * (r / c);
      return u * u;
    }
    case Kernel::kGemanMcClure: {
      const double c = 2.0 * s;
      const double u = c * c / (c * c + r * r);
      return u * u;
    }
  }
  return 1.0;
}

double median(std::vector<float>& values) {
  if (values.empty()) return 0.0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

}  // namespace

class Registration3DFastIcp final : public Registration3DFastIcpBase {
 protected:
  Status onConfigure() override {
    if (params_.min_correspondence_distance > params_.max_correspondence_distance)
      return invalidParameter(
          "parameter 'min_correspondence_distance' = {} exceeds 'max_correspondence_distance' "
          "= {}; expected min <= max",
          params_.min_correspondence_distance, params_.max_correspondence_distance);
    kernel_ = parseKernel(params_.robust_kernel);
    viewpoint_ = Eigen::Vector3f(params_.viewpoint[0], params_.viewpoint[1], params_.viewpoint[2]);
    return Status::ok();
  }

  Status onProcess() override {
    const PointCloud& source = *in.source;
    const PointCloud& model = *in.model;
    Result<Eigen::Isometry3d> guess =
        registration::checkInputs(source, model, in.initial_guess.get());
    if (!guess) return guess.status();
    CDFF_RETURN_IF_ERROR(index_.update(model));
    registration::selectSource(source, params_.max_source_points, points_);
    const std::vector<Eigen::Vector3f>& points = points_;

    Eigen::Matrix3d rotation = guess->linear();
    Eigen::Vector3d translation = guess->translation();
    double distance = params_.max_correspondence_distance;
    bool converged = false, starved = false;
    int iterations = 0;
    std::size_t last_pairs = 0;
    for (; iterations < params_.max_iterations; ++iterations) {
      if (!associate(points, rotation, translation, distance, iterations == 0)) {
        starved = true;
        last_pairs = pairs_.size();
        break;
      }
      const double scale = params_.kernel_scale > 0 ? params_.kernel_scale
                                                    : std::max(params_.min_kernel_scale,
                                                               1.4826 * median(abs_residuals_));
      Matrix6d h = Matrix6d::Zero();
      Vector6d g = Vector6d::Zero();
      if (distance > params_.point_to_point_above && params_.point_to_point_above > 0) {
        // Coarse phase: point-to-point, whose basin of convergence is wider. The residual
        // e = (R q + t) - p has the Jacobian [I, -[R q]x] in the pose perturbation.
        const double pp_scale =
            std::max(params_.min_kernel_scale, 1.4826 * median(pair_distances_));
        for (const Pair& pair : pairs_) {
          const double w = weight(kernel_, pair.offset.norm(), pp_scale);
          if (w <= 0) continue;
          Eigen::Matrix<double, 3, 6> j;
          j << Eigen::Matrix3d::Identity(), -skew(pair.rq);
          h.noalias() += w * j.transpose() * j;
          g.noalias() += w * j.transpose() * pair.offset;
        }
      } else {
        for (const Pair& pair : pairs_) {
          const double w = weight(kernel_, pair.r, scale);
          if (w <= 0) continue;
          h.selfadjointView<Eigen::Lower>().rankUpdate(pair.j, w);
          g += w * pair.r * pair.j;
        }
      }
      h = h.selfadjointView<Eigen::Lower>();
      // A relative ridge keeps the step finite when the scan leaves a direction unconstrained
      // (e.g. one flat face): that direction then stays at the guess instead of jumping.
      h.diagonal().array() += 1e-9 * h.diagonal().maxCoeff() + 1e-12;
      const Vector6d step = -h.ldlt().solve(g);
      if (!step.allFinite())
        return numericalFailure(
            "the Gauss-Newton step of iteration {} is not finite ({} correspondences); the "
            "problem is degenerate",
            iterations + 1, pairs_.size());
      translation += step.head<3>();
      rotation = expSO3(step.tail<3>()).toRotationMatrix() * rotation;
      // Shrink the correspondence distance as the alignment improves: three robust standard
      // deviations of the point-to-point distances, never below the configured floor.
      distance = std::clamp(3.0 * 1.4826 * median(pair_distances_),
                            params_.min_correspondence_distance, distance);
      if (step.head<3>().norm() < params_.translation_epsilon &&
          step.tail<3>().norm() < params_.rotation_epsilon) {
        converged = true;
        ++iterations;
        break;
      }
    }
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::Quaterniond(rotation).normalized().toRotationMatrix();
    pose.translation() = translation;
    if (starved) {
      warn(fmt::format(
          "only {} source points of {} have a model point within {:.3g} m (iteration {}); "
          "expected at least min_correspondences = {}: no overlap with the model",
          last_pairs, points.size(), distance, iterations + 1, params_.min_correspondences));
      pose = *guess;
    }
    const registration::Quality quality = registration::evaluate(
        points, index_, pose, params_.inlier_distance, params_.covariance_inflation);
    if (converged && quality.degenerate)
      warn(
          "the scan constrains some direction of the pose poorly (degenerate geometry); its "
          "covariance is large there");
    registration::publish(out, source, model, pose, quality, converged && !starved, iterations);
    return Status::ok();
  }

 private:
  struct Pair {
    Vector6d j;              // point-to-plane Jacobian
    double r;                // point-to-plane residual, m
    Eigen::Vector3d offset;  // R q + t - p, the point-to-point residual
    Eigen::Vector3d rq;      // R q
  };

  /// Pairs every source point with its nearest (visible) model point within `distance`; false
  /// when there are fewer than min_correspondences pairs.
  bool associate(const std::vector<Eigen::Vector3f>& points, const Eigen::Matrix3d& rotation,
                 const Eigen::Vector3d& translation, double distance, bool first) {
    pairs_.clear();
    abs_residuals_.clear();
    pair_distances_.clear();
    if (first) previous_.assign(points.size(), kNoMatch);
    const Eigen::Matrix3f r_inv = rotation.transpose().cast<float>();
    const Eigen::Vector3f t = translation.cast<float>();
    const float max_sq = static_cast<float>(distance * distance);
    // The viewpoint in the model frame: visible model points have normals facing it.
    const Eigen::Vector3f eye = r_inv * (viewpoint_ - t);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3f& p = points[i];
      const Eigen::Vector3f pm = r_inv * (p - t);
      KdTree3f::Neighbour nn;
      if (!nearestVisible(pm, eye, max_sq, previous_[i], nn)) {
        previous_[i] = kNoMatch;
        continue;
      }
      previous_[i] = nn.index;
      const Eigen::Vector3f nm = index_.normals[nn.index].vec();
      const float r = nm.dot(pm - index_.points[nn.index].vec());
      const Eigen::Vector3d n = rotation * nm.cast<double>();
      Pair pair;
      pair.j << -n, n.cross(p.cast<double>() - translation);
      pair.r = r;
      pair.rq = rotation * index_.points[nn.index].vec().cast<double>();
      pair.offset = pair.rq + translation - p.cast<double>();
      pairs_.push_back(pair);
      abs_residuals_.push_back(std::abs(r));
      pair_distances_.push_back(std::sqrt(nn.squared_distance));
    }
    return pairs_.size() >= static_cast<std::size_t>(params_.min_correspondences);
  }

  bool facesEye(std::uint32_t index, const Eigen::Vector3f& eye) const {
    return index_.normals[index].vec().dot(eye - index_.points[index].vec()) > 0;
  }

  /// The nearest model point to `q` within sqrt(max_sq) (that faces `eye` when back faces are
  /// rejected, unless none does: the pose is then still far off and the plain nearest pulls the
  /// right way). `previous` (the match of the last iteration, or kNoMatch) bounds the search:
  /// the pose moved little, so the new match is at most about as far as the old one.
  bool nearestVisible(const Eigen::Vector3f& q, const Eigen::Vector3f& eye, float max_sq,
                      std::uint32_t previous, KdTree3f::Neighbour& found) const {
    const bool facing = params_.back_face_rejection;
    float bound = max_sq;
    if (previous != kNoMatch && (!facing || facesEye(previous, eye))) {
      const float d = (index_.points[previous].vec() - q).squaredNorm();
      bound = std::min(max_sq, d * 1.0001f + 1e-12f);
    }
    auto search = [&](float b) {
      return facing ? index_.tree.nearestFacing(q, eye, b, found)
                    : index_.tree.nearest(q, b, found);
    };
    if (search(bound) || (bound < max_sq && search(max_sq))) return true;
    return facing && index_.tree.nearest(q, max_sq, found);
  }

  static constexpr std::uint32_t kNoMatch = ~std::uint32_t{0};
  Kernel kernel_ = Kernel::kGemanMcClure;
  registration::ModelIndex index_;
  // Scratch kept between calls, so that a warmed-up DFI does not allocate.
  std::vector<Eigen::Vector3f> points_;
  std::vector<Pair> pairs_;
  std::vector<float> abs_residuals_, pair_distances_;
  std::vector<std::uint32_t> previous_;
  Eigen::Vector3f viewpoint_ = Eigen::Vector3f::Zero();
};

CDFF_REGISTER_DFI(Registration3DFastIcp);

}  // namespace cdff::dfn
