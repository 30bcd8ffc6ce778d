// PoseRefinement/DepthIcp: every candidate's starts registered on the measured depth by
// FastIcp's point-to-plane ICP (src/cdff/registration), scored both ways at the depth's noise
// (depth_fit.hpp); the best one is the output.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "PoseRefinement.gen.hpp"
#include "cdff/registration/fast_icp.hpp"
#include "cdff/registration/model_symmetry.hpp"
#include "cdff/registration/shared_model_cache.hpp"
#include "depth_fit.hpp"

namespace cdff::dfn {

using namespace pose_refinement;

class PoseRefinementDepthIcp final : public PoseRefinementDepthIcpBase {
 protected:
  Status onConfigure() override {
    noise_ = {params_.depth_noise_constant, params_.depth_noise_quadratic};
    returns_ = {params_.min_amplitude};
    shape_for_ = 0;  // the symmetries follow symmetry_starts and min_symmetry_overlap
    return Status::ok();
  }

  Status onProcess() override {
    const Detections& detections = *in.detections;
    CDFF_RETURN_IF_ERROR(detections.validate().withContext("input 'detections'"));
    Result<MeasuredDepth> depth = measuredDepth(*in.depth, "input 'depth'");
    if (!depth) return depth.status();
    if (!detections.frame_id.empty() && !in.depth->image.frame_id.empty() &&
        detections.frame_id != in.depth->image.frame_id)
      return invalidInput(
          "input 'detections' are in frame '{}' but input 'depth' is in frame '{}'; expected the "
          "depth of the detections' image (the same optical frame)",
          detections.frame_id, in.depth->image.frame_id);
    CDFF_RETURN_IF_ERROR(prepareModel(*in.model));

    // Every start gets a short run on an eighth of the points and a quarter of the iterations;
    // the `finalists` best continue on all of them until converged, and the best of those wins.
    std::vector<Trial> trials;
    const int count = std::min<int>(params_.candidates, detections.detections.size());
    const int short_iterations = std::max(5, params_.max_iterations / 4);
    std::vector<Eigen::Isometry3d> tried;
    for (int i = 0; i < count; ++i) {
      const Eigen::Isometry3d candidate = detections.detections[i].pose.isometry();
      // The starts of a candidate share its bounding centre, so its measured points.
      cropAbout(candidate, *depth, params_.max_points / 8);
      for (const Eigen::Isometry3d& start : startsOf(candidate, symmetries_)) {
        // Template matches of a near-symmetric target are often near-symmetric poses of one
        // another: a start next to one already run would end in the same minimum.
        if (std::any_of(tried.begin(), tried.end(),
                        [&](const Eigen::Isometry3d& t) { return sameBasin(t, start); }))
          continue;
        tried.push_back(start);
        Result<Fit> fit = refine(start, *depth, short_iterations);
        if (!fit) return fit.status();
        trials.push_back({*fit, i});
      }
    }
    std::sort(trials.begin(), trials.end(), [](const Trial& a, const Trial& b) {
      return a.fit.score.misfit < b.fit.score.misfit;
    });
    trials.resize(std::min<std::size_t>(trials.size(), params_.finalists));
    Trial best;
    best.fit.score.misfit = std::numeric_limits<double>::infinity();
    std::vector<Trial> finals;
    for (const Trial& t : trials) {
      cropAbout(detections.detections[t.candidate].pose.isometry(), *depth, params_.max_points);
      Result<Fit> fit = refine(t.fit.pose, *depth, params_.max_iterations);
      if (!fit) return fit.status();
      finals.push_back({*fit, t.candidate});
      if (fit->score.misfit < best.fit.score.misfit) best = {*fit, t.candidate};
    }
    const double rival_margin = rivalMargin(best, finals);
    out.candidates.set(finalistsOf(std::move(finals), detections));
    out.candidate.set(best.candidate);
    if (best.candidate < 0) {
      out.refined.set(false);
      out.fitness.set(std::numeric_limits<double>::quiet_NaN());
      out.confirmed.set(std::numeric_limits<double>::quiet_NaN());
      out.misfit.set(std::numeric_limits<double>::quiet_NaN());
      out.rival_margin.set(std::numeric_limits<double>::quiet_NaN());
      return Status::ok();
    }
    PoseWithCovariance pose;
    pose.pose = Transform::fromIsometry(best.fit.pose, in.depth->image.frame_id, in.model->frame_id,
                                        detections.stamp);
    pose.pose.rotation.normalize();
    // The Gauss-Newton covariance counts every point as an independent measurement; the depth's
    // errors are correlated (a stereo matcher's block and smoothing, the model's own error), so
    // it is scaled to independent_points of them.
    const double n = static_cast<double>(best.fit.score.measured);
    pose.covariance = best.fit.quality.covariance * std::max(1.0, n / params_.independent_points);
    out.pose.set(std::move(pose));
    out.fitness.set(best.fit.score.fitness);
    out.confirmed.set(best.fit.score.confirmed);
    out.misfit.set(best.fit.score.misfit);
    out.rival_margin.set(rival_margin);
    out.refined.set(best.fit.score.fitness >= params_.min_fitness &&
                    best.fit.score.confirmed >= params_.min_confirmed &&
                    (params_.max_misfit <= 0 || best.fit.score.misfit <= params_.max_misfit) &&
                    rival_margin >= params_.min_rival_margin);
    return Status::ok();
  }

 private:
  struct Fit {
    Eigen::Isometry3d pose;
    Score score;
    registration::Quality quality;
  };
  struct Trial {
    Fit fit;
    int candidate = -1;
  };

  /// The misfit of the nearest rival of `best` less best's: the lowest among the finalists that
  /// are another pose (more than the template grid's reach from it in attitude), e.g. a half
  /// turn of a near-symmetric target; +inf without one.
  static double rivalMargin(const Trial& best, const std::vector<Trial>& finals) {
    double margin = std::numeric_limits<double>::infinity();
    if (best.candidate < 0) return margin;
    for (const Trial& t : finals)
      if (Eigen::AngleAxisd(best.fit.pose.linear().transpose() * t.fit.pose.linear()).angle() >
          kSameBasinAngle)
        margin = std::min(margin, t.fit.score.misfit - best.fit.score.misfit);
    return margin;
  }

  /// The finalists' refined poses, best first, as detections of the depth's frame (fitness as the
  /// similarity, the confirmed fraction as the depth agreement).
  Detections finalistsOf(std::vector<Trial> finals, const Detections& detections) const {
    std::stable_sort(finals.begin(), finals.end(), [](const Trial& a, const Trial& b) {
      return a.fit.score.misfit < b.fit.score.misfit;
    });
    Detections refined;
    refined.stamp = detections.stamp;
    refined.frame_id = in.depth->image.frame_id;
    for (const Trial& t : finals) {
      Detection d = detections.detections[t.candidate];
      d.pose = Transform::fromIsometry(t.fit.pose, in.depth->image.frame_id, in.model->frame_id,
                                       detections.stamp);
      d.pose.rotation.normalize();
      d.similarity =
          std::isfinite(t.fit.score.fitness) ? std::clamp(t.fit.score.fitness, 0.0, 1.0) : 0.0;
      d.depth_agreement = t.fit.score.confirmed;
      refined.detections.push_back(std::move(d));
    }
    return refined;
  }

  /// The model's shape and search structures, rebuilt when a cloud with other buffers arrives;
  /// the lookup grid follows the model's size.
  Status prepareModel(const PointCloud& model) {
    Result<std::shared_ptr<const registration::ModelIndex>> index =
        registration::SharedModelCache::index(model, index_);
    if (!index) return Status(index.status().code(), "input 'model': " + index.status().message());
    index_ = std::move(index).value();
    if (shape_for_ != index_->builds) {
      shape_ = modelShape(*index_, 3 * static_cast<std::size_t>(params_.max_points),
                          model.intensity.span());
      shape_for_ = index_->builds;
      model_spacing_ = registration::modelSpacing(*index_);
      symmetries_.clear();
      if (params_.symmetry_starts) {
        registration::SymmetryOptions symmetry;
        symmetry.min_overlap = params_.min_symmetry_overlap;
        symmetries_ = registration::motionsOf(registration::nearSymmetries(*index_, symmetry));
      }
      registration_.configure(options(noise_.sigma(1.0), params_.max_iterations));
    }
    Result<registration::ModelPreparation> prepared = registration_.prepare(model);
    if (!prepared) return prepared.status();
    if (prepared->grid_too_large)
      warn("the model's lookup grid would be too large; the KD-tree alone is used");
    return Status::ok();
  }

  /// ICP settings at depth noise `sigma`: correspondences from a third of the model's radius
  /// (a 15 degree error at its rim plus a few percent of the range) down to 3 sigma (and twice
  /// the model's spacing); a lookup grid of a 60th of the radius (coarser than the depth's
  /// noise at any range of use) that reaches as far as the correspondences.
  registration::FastIcpOptions options(double sigma, int iterations) const {
    registration::FastIcpOptions o;
    registration::IcpOptions& icp = o.icp;
    const double reach = shape_.radius / 3;
    icp.max_correspondence_distance = reach;
    icp.min_correspondence_distance = std::min(reach, std::max(3 * sigma, 2 * model_spacing_));
    icp.point_to_point_above = icp.max_correspondence_distance / 2;
    icp.min_kernel_scale = sigma;
    icp.association.back_face_rejection = true;
    icp.association.viewpoint = Eigen::Vector3f::Zero();
    o.max_iterations = iterations;
    o.quality = {3 * sigma, 1.0};
    o.grid = {shape_.radius / 60, reach};
    return o;
  }

  /// Whether two starts are close enough to end in the same minimum: within the template grid's
  /// reach in attitude (10 degrees) and a tenth of the model's radius apart at its centre.
  bool sameBasin(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) const {
    return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() < kSameBasinAngle &&
           ((a * shape_.centre) - (b * shape_.centre)).norm() < 0.1 * shape_.radius;
  }

  /// The measured points within 1.25 bounding radii of `candidate`'s bounding centre (its
  /// error is a few percent of the range), at most `points` of them, into measured_.
  void cropAbout(const Eigen::Isometry3d& candidate, const MeasuredDepth& depth, int points) {
    pointsNear(depth, candidate * shape_.centre, 1.25 * shape_.radius,
               static_cast<std::size_t>(points), measured_);
  }

  /// One start registered on measured_ and scored at its final pose.
  Result<Fit> refine(const Eigen::Isometry3d& start, const MeasuredDepth& depth, int iterations) {
    const double sigma = noise_.sigma((start * shape_.centre).z());
    registration_.configure(options(sigma, iterations));  // the model stays prepared
    Fit fit{start, {}, {}};
    if (measured_.size() >= kMinimumPoints) {
      Result<registration::Registration> r = registration_.registerScan(measured_, start, 0);
      if (!r) return r.status();
      fit.pose = r->pose;
      fit.quality = r->quality;
    }
    // The mean cost of the measured points plus that of the shown model points: each side
    // counts the same however many points it has.
    const double n = static_cast<double>(measured_.size());
    double measured_cost = (n - static_cast<double>(fit.quality.inliers)) * kUnexplainedCost;
    if (fit.quality.inliers > 0)
      measured_cost += fit.quality.inliers * std::pow(fit.quality.inlier_rms / sigma, 2);
    const double shown_cost = shownModelCost(fit.pose, shape_, depth, sigma,
                                             params_.missing_depth_cost, returns_, fit.score);
    fit.score.measured = measured_.size();
    fit.score.fitness = fit.quality.fitness;
    fit.score.misfit = n > 0 && fit.score.shown > 0
                           ? measured_cost / n + shown_cost / static_cast<double>(fit.score.shown)
                           : std::numeric_limits<double>::infinity();
    return fit;
  }

  static constexpr std::size_t kMinimumPoints = 20;
  static constexpr double kSameBasinAngle = 10 * M_PI / 180;

  DepthNoise noise_;
  DepthReturn returns_;
  std::shared_ptr<const registration::ModelIndex> index_;
  std::uint64_t shape_for_ = 0;
  ModelShape shape_;
  std::vector<Eigen::Isometry3d> symmetries_;  // of the model, x -> s x (symmetry_starts)
  double model_spacing_ = 0.01;
  registration::FastIcp registration_;
  std::vector<Eigen::Vector3f> measured_;
};

CDFF_REGISTER_DFI(PoseRefinementDepthIcp);

}  // namespace cdff::dfn
