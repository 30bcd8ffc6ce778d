#pragma once
// The ports of the Registration3D DFIs, shared by both: the input checks, the scan points a DFI
// registers, and the outputs, written the same way for every DFI at its final pose. The
// algorithms are in src/cdff/registration/.

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include <fmt/ranges.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "Registration3D.gen.hpp"
#include "cdff/registration/quality.hpp"
#include "cdff/registration/scan_inputs.hpp"

namespace cdff::dfn::registration3d {

/// Checks the scan, the sensor's description and the guess; returns the starting pose
/// source_T_model.
inline Result<Eigen::Isometry3d> checkInputs(const PointCloud& source, const PointCloud& model,
                                             const LidarInfo* sensor,
                                             const Transform* initial_guess) {
  CDFF_RETURN_IF_ERROR(source.validate("input 'source'"));
  CDFF_RETURN_IF_ERROR(cdff::registration::checkScanSensor(source, sensor));
  if (initial_guess == nullptr) return Eigen::Isometry3d::Identity();
  CDFF_RETURN_IF_ERROR(
      cdff::registration::checkSourceTModel(*initial_guess, source, model, "initial_guess"));
  return initial_guess->isometry();
}

/// The position block of `uncertainty`'s pose covariance (none without it); an error when it
/// is not finite or not expressed in the source's frame.
inline Result<std::optional<Eigen::Matrix3d>> guessPositionCovariance(
    const PointCloud& source, const RigidBodyState* uncertainty) {
  if (uncertainty == nullptr) return std::optional<Eigen::Matrix3d>();
  const Eigen::Matrix3d position = uncertainty->covariance.topLeftCorner<3, 3>();
  if (!position.allFinite())
    return invalidInput(
        "input 'guess_uncertainty' has a non-finite position covariance (diagonal {}); expected "
        "a finite covariance",
        fmt::join(position.diagonal(), ", "));
  const std::string& frame = uncertainty->pose.parent_frame;
  if (!frame.empty() && !source.frame_id.empty() && frame != source.frame_id)
    return invalidInput(
        "input 'guess_uncertainty' is expressed in frame '{}'; expected the source's frame '{}'",
        frame, source.frame_id);
  return std::optional<Eigen::Matrix3d>(position);
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

/// Writes every output of a Registration3D DFI but `ambiguous` and `visibility`.
inline void publish(Registration3D::Outputs& out, const PointCloud& source, const PointCloud& model,
                    const Eigen::Isometry3d& pose, const cdff::registration::Quality& quality,
                    bool converged, int iterations) {
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

}  // namespace cdff::dfn::registration3d
