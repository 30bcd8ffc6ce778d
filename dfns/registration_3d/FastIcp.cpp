// Registration3D/FastIcp: our point-to-plane ICP, multi-start acquisition and multi-scan
// confirmation (src/cdff/registration/fast_icp.hpp). This DFI maps the parameters onto the
// library's options and the ports onto its calls, and turns what the library reports into
// warnings.
#include <algorithm>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "Registration3D.gen.hpp"
#include "cdff/registration/fast_icp.hpp"
#include "registration_ports.hpp"

namespace cdff::dfn {

class Registration3DFastIcp final : public Registration3DFastIcpBase {
 protected:
  Status onConfigure() override {
    if (params_.min_correspondence_distance > params_.max_correspondence_distance)
      return invalidParameter(
          "parameter 'min_correspondence_distance' = {} exceeds 'max_correspondence_distance' "
          "= {}; expected min <= max",
          params_.min_correspondence_distance, params_.max_correspondence_distance);
    registration_.configure(options());
    return Status::ok();
  }

  Status onProcess() override {
    floorKernelAtSensorNoise();
    const PointCloud& model = *in.model;
    Result<registration::ModelPreparation> prepared = registration_.prepare(model);
    if (!prepared) return prepared.status();
    if (prepared->grid_too_large)
      warn(fmt::format(
          "the model's lookup grid would need more than {} cells of {} m; only the KD-tree is "
          "used (a larger lookup_grid_cell would allow it)",
          registration::NearestGrid::kMaxCells, params_.lookup_grid_cell));
    // Without a new scan the call only prepares the model (see the DFN's `source`).
    if (!in.source.isFresh()) return Status::ok();
    const PointCloud& source = *in.source;
    Result<Eigen::Isometry3d> guess =
        registration3d::checkInputs(source, model, in.sensor.get(), in.initial_guess.get());
    if (!guess) return guess.status();
    Result<std::optional<Eigen::Matrix3d>> position_covariance =
        registration3d::guessPositionCovariance(source, in.guess_uncertainty.get());
    if (!position_covariance) return position_covariance.status();
    registration3d::selectSource(source, params_.max_source_points, points_);
    Result<registration::Registration> result = registration_.registerScan(
        points_, *guess, source.stamp, lasers_.of(in.sensor.get()), *position_covariance);
    if (!result) return result.status();
    const registration::Registration& r = *result;
    if (r.run.starved)
      warn(fmt::format(
          "only {} source points of {} have a model point within {:.3g} m (iteration {}); "
          "expected at least min_correspondences = {}: no overlap with the model",
          r.run.last_pairs, points_.size(), r.run.distance, r.run.iterations + 1,
          params_.min_correspondences));
    if (r.run.converged && r.quality.degenerate)
      warn(
          "the scan constrains some direction of the pose poorly (degenerate geometry); its "
          "covariance is large there");
    registration3d::publish(out, source, model, r.pose, r.quality,
                            r.run.converged && !r.run.starved, r.run.iterations);
    out.ambiguous.set(r.ambiguous);
    out.visibility.set(r.visibility);
    return Status::ok();
  }

 private:
  registration::FastIcpOptions options() const {
    registration::FastIcpOptions o;
    registration::IcpOptions& icp = o.icp;
    icp.max_correspondence_distance = params_.max_correspondence_distance;
    icp.min_correspondence_distance = params_.min_correspondence_distance;
    icp.translation_epsilon = params_.translation_epsilon;
    icp.rotation_epsilon = params_.rotation_epsilon;
    icp.convergence_sigma = params_.convergence_sigma;
    icp.min_correspondences = params_.min_correspondences;
    icp.point_to_point_above = params_.point_to_point_above;
    icp.kernel = registration::robustKernelNamed(params_.robust_kernel);
    icp.kernel_scale = params_.kernel_scale;
    icp.min_kernel_scale = params_.min_kernel_scale;
    icp.association.back_face_rejection = params_.back_face_rejection;
    icp.association.viewpoint =
        Eigen::Vector3f(params_.viewpoint[0], params_.viewpoint[1], params_.viewpoint[2]);
    o.max_iterations = params_.max_iterations;
    o.exact_refinement_iterations = params_.exact_refinement_iterations;
    o.quality = {params_.inlier_distance, params_.covariance_inflation};
    o.grid = {params_.lookup_grid_cell, params_.lookup_grid_band};
    registration::MultiStartOptions& starts = o.multi_start;
    starts.hypotheses = params_.hypotheses;
    starts.angle = params_.hypothesis_angle;
    starts.centroid = params_.hypothesis_centroid;
    starts.max_turn = params_.hypothesis_max_turn;
    starts.iterations = params_.hypothesis_iterations;
    starts.min_visibility = params_.min_visibility;
    o.visibility_check = params_.visibility_check;
    registration::ConfirmationOptions& confirmation = o.confirmation;
    confirmation.scans = params_.confirmation_scans;
    confirmation.kept = params_.kept_hypotheses;
    confirmation.margin = params_.confirmation_margin;
    confirmation.timeout = params_.confirmation_timeout;
    confirmation.follow_shift_sigma = params_.follow_shift_sigma;
    confirmation.follow_turn_sigma = params_.follow_turn_sigma;
    confirmation.max_unexplained = params_.max_unexplained;
    return o;
  }

  /// With kernel_floor_at_sensor_noise, the robust kernel's adaptive scale never below the
  /// sensor's range noise (1 sigma, from `sensor`; see the parameter). Reconfigured only when the
  /// noise changes (a description comes with every scan).
  void floorKernelAtSensorNoise() {
    if (!params_.kernel_floor_at_sensor_noise) return;
    const LidarInfo* sensor = in.sensor.get();
    const double noise = sensor ? sensor->range_noise : 0.0;
    if (noise == kernel_floor_noise_) return;
    kernel_floor_noise_ = noise;
    registration::FastIcpOptions o = options();
    o.icp.min_kernel_scale = std::max(o.icp.min_kernel_scale, noise);
    registration_.configure(o);
  }

  registration::FastIcp registration_;
  std::vector<Eigen::Vector3f> points_;  // the scan points used; kept so as not to allocate
  registration::LaserElevations lasers_;
  double kernel_floor_noise_ = 0;  // the range noise the kernel's floor was last set from
};

CDFF_REGISTER_DFI(Registration3DFastIcp);

}  // namespace cdff::dfn
