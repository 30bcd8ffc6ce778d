#include "cdff/egse/calibration_error.hpp"

#include <algorithm>
#include <cmath>

#include "cdff/egse/rng.hpp"
#include "cdff/types/geometry.hpp"

namespace cdff::egse {

namespace {

Status nonNegative(double value, const char* name, const char* unit) {
  if (!std::isfinite(value) || value < 0)
    return invalidParameter("calibration_error.{} = {} is invalid; expected a size >= 0 {}", name,
                            value, unit);
  return Status::ok();
}

// A uniformly random unit vector (a normalised Gaussian vector).
Eigen::Vector3d randomDirection(Rng& rng) {
  for (;;) {
    const Eigen::Vector3d v(rng.normal(), rng.normal(), rng.normal());
    if (v.norm() > 1e-9) return v.normalized();
  }
}

Eigen::Vector3d drawVector(Rng& rng, double size, CalibrationErrorDistribution distribution) {
  if (distribution == CalibrationErrorDistribution::kFixed) return size * randomDirection(rng);
  const double sigma = size / std::sqrt(3.0);
  return Eigen::Vector3d(rng.normal(0, sigma), rng.normal(0, sigma), rng.normal(0, sigma));
}

}  // namespace

bool CalibrationErrorSpec::active() const {
  return extrinsic_angle > 0 || extrinsic_position > 0 || intrinsics_fraction > 0;
}

bool CalibrationErrorSpec::appliesTo(const std::string& sensor) const {
  return sensors.empty() || std::find(sensors.begin(), sensors.end(), sensor) != sensors.end();
}

Status CalibrationErrorSpec::validate() const {
  CDFF_RETURN_IF_ERROR(nonNegative(extrinsic_angle, "extrinsic_angle", "rad"));
  CDFF_RETURN_IF_ERROR(nonNegative(extrinsic_position, "extrinsic_position", "m"));
  CDFF_RETURN_IF_ERROR(nonNegative(intrinsics_fraction, "intrinsics_fraction", ""));
  if (intrinsics_fraction >= 0.5)
    return invalidParameter(
        "calibration_error.intrinsics_fraction = {} is too large; expected < 0.5 (a calibration "
        "error, not another camera)",
        intrinsics_fraction);
  return Status::ok();
}

SensorCalibrationError drawCalibrationError(const CalibrationErrorSpec& spec,
                                            std::uint64_t run_seed, const std::string& sensor) {
  SensorCalibrationError error;
  if (!spec.active() || !spec.appliesTo(sensor)) return error;
  Rng rng = Rng::stream(spec.seed.value_or(run_seed), "calibration/" + sensor);
  error.rotation = drawVector(rng, spec.extrinsic_angle, spec.distribution);
  error.translation = drawVector(rng, spec.extrinsic_position, spec.distribution);
  for (int i = 0; i < 4; ++i)
    error.intrinsics[i] = spec.distribution == CalibrationErrorDistribution::kFixed
                              ? (rng.uniform() < 0.5 ? -1.0 : 1.0) * spec.intrinsics_fraction
                              : rng.normal(0, spec.intrinsics_fraction);
  return error;
}

Eigen::Isometry3d perturbedMounting(const Eigen::Isometry3d& servicer_T_frame,
                                    const SensorCalibrationError& error) {
  Eigen::Isometry3d out = servicer_T_frame;
  out.linear() = expSO3(error.rotation).toRotationMatrix() * servicer_T_frame.linear();
  out.translation() = servicer_T_frame.translation() + error.translation;
  return out;
}

CameraModel perturbedIntrinsics(const CameraModel& model, const SensorCalibrationError& error) {
  CameraModel out = model;
  out.fx *= 1 + error.intrinsics[0];
  out.fy *= 1 + error.intrinsics[1];
  out.cx *= 1 + error.intrinsics[2];
  out.cy *= 1 + error.intrinsics[3];
  return out;
}

}  // namespace cdff::egse
