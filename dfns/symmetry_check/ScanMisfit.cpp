// SymmetryCheck/ScanMisfit: the tracked pose against its near-symmetric poses on the LIDAR scan
// (src/cdff/registration/symmetry_check.hpp). This DFI finds the model's near-symmetries when
// the model arrives, maps the parameters onto the library's options and the ports onto its
// calls.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "SymmetryCheck.gen.hpp"
#include "cdff/registration/crop.hpp"
#include "cdff/registration/misfit.hpp"
#include "cdff/registration/model_symmetry.hpp"
#include "cdff/registration/quality.hpp"
#include "cdff/registration/ring_visibility.hpp"
#include "cdff/registration/scan_inputs.hpp"
#include "cdff/registration/shared_model_cache.hpp"
#include "cdff/registration/symmetry_check.hpp"

namespace cdff::dfn {

class SymmetryCheckScanMisfit final : public SymmetryCheckScanMisfitBase {
 protected:
  Status onConfigure() override {
    if (params_.min_correspondence_distance > params_.max_correspondence_distance)
      return invalidParameter(
          "parameter 'min_correspondence_distance' = {} exceeds 'max_correspondence_distance' "
          "= {}; expected min <= max",
          params_.min_correspondence_distance, params_.max_correspondence_distance);
    registration::SymmetryCheckOptions o;
    o.scans = params_.scans;
    o.min_significance = params_.min_significance;
    o.min_relative_advantage = params_.min_relative_advantage;
    o.timeout = params_.timeout;
    o.iterations = params_.iterations;
    o.distinct_angle = params_.distinct_angle;
    o.inlier_distance = params_.inlier_distance;
    o.icp.max_correspondence_distance = params_.max_correspondence_distance;
    o.icp.min_correspondence_distance = params_.min_correspondence_distance;
    o.icp.association.viewpoint =
        Eigen::Vector3f(params_.viewpoint[0], params_.viewpoint[1], params_.viewpoint[2]);
    check_.configure(o);
    model_.index.reset();
    last_check_.reset();
    return Status::ok();
  }

  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(prepare(*in.model));
    if (!in.pose.isFresh()) return Status::ok();
    if (in.source.get() == nullptr)
      return invalidInput(
          "input 'source' is not set; expected the scan the tracked 'pose' was registered on");
    const PointCloud& source = *in.source;
    CDFF_RETURN_IF_ERROR(source.validate("input 'source'"));
    CDFF_RETURN_IF_ERROR(registration::checkSourceTModel(*in.pose, source, *in.model, "pose"));
    const LidarInfo* sensor = in.sensor.get();
    CDFF_RETURN_IF_ERROR(registration::checkScanSensor(source, sensor));
    if (last_check_ && toSeconds(source.stamp - *last_check_) < params_.min_interval &&
        source.stamp >= *last_check_)
      return Status::ok();
    last_check_ = source.stamp;

    cropAround(source, in.pose->isometry());
    // Too few returns near the target to register a rival on: no check (the tracker's own
    // registration would have starved too).
    if (points_.size() < kMinReturns) return Status::ok();
    const bool rings = visibility_.setScan(points_, viewpoint(), lasers_.of(sensor));
    auto misfit = [&](const Eigen::Isometry3d& pose) {
      const double visibility =
          rings ? visibility_.evaluate(*model_.index, spacing_, pose, 3.0 * params_.inlier_distance)
                : std::numeric_limits<double>::quiet_NaN();
      return registration::misfit(points_, *model_.index, pose, params_.inlier_distance,
                                  visibility);
    };
    Result<registration::SymmetryVerdict> verdict =
        check_.check(points_, in.pose->isometry(), source.stamp, misfit);
    if (!verdict) return verdict.status();
    out.advantage.set(verdict->significance);
    out.relative_advantage.set(verdict->relative_advantage);
    if (verdict->better) {
      const registration::Quality quality =
          registration::evaluate(points_, *model_.index, *verdict->better, params_.inlier_distance,
                                 params_.covariance_inflation);
      PoseWithCovariance better;
      better.pose = Transform::fromIsometry(*verdict->better, source.frame_id, in.model->frame_id,
                                            source.stamp);
      better.pose.rotation.normalize();
      better.covariance = quality.covariance;
      warn(fmt::format(
          "the tracked pose is a near-symmetric view of the target: a pose {:.1f} deg from it "
          "explains the last {} checks better by {:.0f} % of the tracked pose's misfit ({:.1f} "
          "square roots of their returns)",
          Eigen::AngleAxisd(in.pose->isometry().linear().transpose() * verdict->better->linear())
                  .angle() *
              180 / M_PI,
          params_.scans, 100 * verdict->relative_advantage, verdict->significance));
      out.pose.set(std::move(better));
    }
    return Status::ok();
  }

 private:
  /// The model's search structures (shared with the process's registrations of the same buffer)
  /// and, for a new model, its near-symmetries.
  Status prepare(const PointCloud& model) {
    Result<std::shared_ptr<const registration::ModelIndex>> index =
        registration::SharedModelCache::index(model, model_.index);
    if (!index) return index.status().withContext("input 'model'");
    if (*index == model_.index) return Status::ok();
    model_.index = std::move(index).value();
    model_.grid = registration::SharedModelCache::grid(*model_.index, {});
    spacing_ = registration::modelSpacing(*model_.index);
    registration::SymmetryOptions options;
    options.min_overlap = params_.min_overlap;
    symmetries_ = registration::motionsOf(registration::nearSymmetries(*model_.index, options));
    check_.setModel(model_, symmetries_);
    out.symmetries.set(static_cast<int>(symmetries_.size()));
    bounds_ = registration::modelBounds(*model_.index);
    return Status::ok();
  }

  /// The returns of `source` within the model's bounding sphere (grown by crop_margin) at
  /// `tracked` or any of its near-symmetric poses, at most max_points of them, into points_.
  void cropAround(const PointCloud& source, const Eigen::Isometry3d& tracked) {
    std::vector<Eigen::Vector3f> centres{(tracked * bounds_.centre()).cast<float>()};
    for (const Eigen::Isometry3d& s : symmetries_)
      centres.push_back((tracked * s * bounds_.centre()).cast<float>());
    registration::pointsWithin(source, centres,
                               static_cast<float>(bounds_.radius() + params_.crop_margin), inside_);
    registration::thinEvenly(inside_, static_cast<std::size_t>(params_.max_points), points_);
  }

  Eigen::Vector3f viewpoint() const {
    return Eigen::Vector3f(params_.viewpoint[0], params_.viewpoint[1], params_.viewpoint[2]);
  }

  /// The least returns a check registers on: the ICP's least correspondences
  /// (registration::IcpOptions::min_correspondences).
  static constexpr std::size_t kMinReturns = 20;

  registration::SymmetryCheck check_;
  registration::ModelSearch model_;
  double spacing_ = 0.01;
  registration::RingVisibility visibility_;
  std::optional<Timestamp> last_check_;
  std::vector<Eigen::Isometry3d> symmetries_;
  registration::ModelBounds bounds_;
  std::vector<Eigen::Vector3f> inside_, points_;
  registration::LaserElevations lasers_;
};

CDFF_REGISTER_DFI(SymmetryCheckScanMisfit);

}  // namespace cdff::dfn
