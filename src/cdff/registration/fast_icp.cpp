#include "cdff/registration/fast_icp.hpp"

#include <cmath>
#include <limits>
#include <utility>

#include "cdff/registration/misfit.hpp"
#include "cdff/registration/shared_model_cache.hpp"

namespace cdff::registration {

void FastIcp::configure(const FastIcpOptions& options) {
  // The lookup grid is fetched again at the next prepare() only when its options change (a
  // registration that retunes its correspondence distances per call keeps it).
  if (options.grid.cell != options_.grid.cell || options.grid.band != options_.grid.band)
    grid_model_ = 0;
  options_ = options;
  ConfirmationOptions& confirmation = options_.confirmation;
  confirmation.inlier_distance = options.quality.inlier_distance;
  confirmation.min_correspondence_distance = options.icp.min_correspondence_distance;
  confirmation.max_correspondence_distance = options.icp.max_correspondence_distance;
  icp_.configure(options_.icp);
  confirmation_.configure(confirmation);
}

Result<ModelPreparation> FastIcp::prepare(const PointCloud& model) {
  Result<std::shared_ptr<const ModelIndex>> index = SharedModelCache::index(model, model_.index);
  if (!index) return index.status();
  model_.index = std::move(index).value();
  const std::uint64_t builds = model_.index->builds;
  ModelPreparation preparation;
  if (grid_model_ != builds) {
    grid_model_ = builds;
    model_.grid = SharedModelCache::grid(*model_.index, options_.grid);
    preparation.grid_too_large = options_.grid.cell > 0 && !model_.grid;
  }
  if (options_.visibility_check && spacing_for_ != builds) {
    model_spacing_ = modelSpacing(*model_.index);
    spacing_for_ = builds;
  }
  icp_.setModel(model_);
  return preparation;
}

double FastIcp::visibilityAt(const Eigen::Isometry3d& pose) {
  return visibility_.evaluate(*model_.index, model_spacing_, pose,
                              3.0 * options_.quality.inlier_distance);
}

const std::vector<Eigen::Matrix3d>& FastIcp::turns() {
  const MultiStartOptions& o = options_.multi_start;
  if (static_cast<int>(turns_.size()) != o.hypotheses) turns_ = startTurns(o.hypotheses, o.angle);
  return turns_;
}

Result<ConfirmationResult> FastIcp::acquire(
    std::span<const Eigen::Vector3f> points, const Eigen::Isometry3d& guess, Timestamp stamp,
    bool visibility_check, const std::optional<Eigen::Matrix3d>& position_covariance) {
  const MultiStartOptions& o = options_.multi_start;
  std::vector<Eigen::Vector3d> positions;
  // Hypotheses being followed need no new starts (the search is most of the cost).
  if (!confirmation_.following(stamp)) {
    positions.push_back(guess.translation());
    if (o.centroid) {
      if (centroid_for_ != model_.index->builds) {
        model_centroid_ = modelCentroid(*model_.index);
        centroid_for_ = model_.index->builds;
      }
      const Eigen::Vector3d centred =
          centredPosition(points, guess, model_centroid_, options_.icp.association.viewpoint);
      if (position_covariance)
        for (const Eigen::Vector3d& p :
             depthStarts(centred, *position_covariance, options_.icp.association.viewpoint,
                         options_.quality.inlier_distance))
          positions.push_back(p);
      else
        positions.push_back(centred);
    }
  }
  Result<std::vector<Start>> starts =
      runStarts(icp_, points, *model_.index, guess, positions, turns(), o, options_.quality);
  if (!starts) return starts.status();
  if (confirmation_.enabled()) {
    ScanEvidence scan;
    scan.stamp = stamp;
    scan.returns = points.size();
    scan.misfit = [&](const Eigen::Isometry3d& pose) {
      return misfit(
          points, *model_.index, pose, options_.quality.inlier_distance,
          visibility_check ? visibilityAt(pose) : std::numeric_limits<double>::quiet_NaN());
    };
    scan.run = [&](const IcpRun& start) { return icp_.iterate(points, start, o.iterations); };
    return confirmation_.update(scan, guess, *starts);
  }
  // Every start explains the returns about as well on a sparse scan; those that also have a
  // return wherever they put visible model surface (visibility >= min_visibility) are the
  // candidates, the best fit among them wins.
  ConfirmationResult chosen;
  std::function<double(const Eigen::Isometry3d&)> visibility;
  if (visibility_check)
    visibility = [&](const Eigen::Isometry3d& pose) { return visibilityAt(pose); };
  chosen.best = chooseStart(*starts, visibility, o.min_visibility);
  return chosen;
}

Result<Registration> FastIcp::registerScan(
    std::span<const Eigen::Vector3f> points, const Eigen::Isometry3d& guess, Timestamp stamp,
    std::span<const double> lasers,
    const std::optional<Eigen::Matrix3d>& guess_position_covariance) {
  const bool visibility_check =
      options_.visibility_check &&
      visibility_.setScan(points, options_.icp.association.viewpoint, lasers);
  Registration r;
  IcpRun search = IcpRun::startingAt(guess, options_.icp.max_correspondence_distance);
  if (options_.multi_start.hypotheses > 1) {
    Result<ConfirmationResult> chosen =
        acquire(points, guess, stamp, visibility_check, guess_position_covariance);
    if (!chosen) return chosen.status();
    r.ambiguous = chosen->ambiguous;
    if (chosen->best) {
      search = *chosen->best;
      search.converged = false;
    }
  }
  Result<IcpRun> run = icp_.iterate(points, search, options_.max_iterations);
  if (!run) return run.status();
  search = std::move(run).value();
  if (search.converged && model_.grid && options_.exact_refinement_iterations > 0) {
    search.converged = false;
    run = icp_.iterate(points, search, options_.exact_refinement_iterations, NearestPoints::kExact);
    if (!run) return run.status();
    search = std::move(run).value();
    // Refinement steps that have not shrunk below the epsilons still end at a better pose than
    // the grid's; the registration converged with the grid already.
    if (!search.starved) search.converged = true;
  }
  r.run = search;
  const Eigen::Matrix3d rotation = search.pose.linear();
  r.pose.linear() = Eigen::Quaterniond(rotation).normalized().toRotationMatrix();
  r.pose.translation() = search.pose.translation();
  if (search.starved) r.pose = guess;
  r.quality = evaluate(points, *model_.index, r.pose, options_.quality.inlier_distance,
                       options_.quality.covariance_inflation,
                       search.starved ? nullptr : &icp_.lastMatches());
  r.visibility = visibility_check ? visibilityAt(r.pose) : std::numeric_limits<double>::quiet_NaN();
  return r;
}

}  // namespace cdff::registration
