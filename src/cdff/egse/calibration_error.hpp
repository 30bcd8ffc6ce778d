#pragma once
// Calibration errors: the simulator renders and casts rays with the sensors' true mountings and
// intrinsics, but publishes calibrations that are off by a drawn error, as a real bench's
// calibration would be (scenario key `calibration_error`, docs/simulator.md).
//
// Each sensor's error is drawn from its own stream (the error's seed, "calibration/" + the
// sensor's name), so enabling a sensor never changes another one's error. The stated sizes are
// the errors' RMS over draws:
//   - gaussian (default): the rotation vector's three components are N(0, (angle / sqrt 3)^2),
//     likewise the translation's, so that the RMS of the error's magnitude is the stated size;
//     each of fx, fy, cx, cy is scaled by 1 + e, e ~ N(0, fraction^2);
//   - fixed: a rotation of exactly the stated angle about a uniformly random axis, a translation
//     of exactly the stated length in a uniformly random direction, e = +-fraction (random
//     sign) for each intrinsic.
// The published mounting is servicer_T_frame' = [exp(dtheta), dt] * servicer_T_frame: the error
// is a rotation about the sensor's origin and a shift, both in servicer axes.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/types/image.hpp"
#include "cdff/types/status.hpp"

namespace cdff::egse {

enum class CalibrationErrorDistribution { kGaussian, kFixed };

struct CalibrationErrorSpec {
  std::optional<std::uint64_t> seed;  // default: the run's seed
  double extrinsic_angle = 0.0;       // rad
  double extrinsic_position = 0.0;    // m
  double intrinsics_fraction = 0.0;   // relative error of fx, fy, cx, cy
  CalibrationErrorDistribution distribution = CalibrationErrorDistribution::kGaussian;
  std::vector<std::string> sensors;  // the sensors it applies to; empty: every sensor

  /// True when any size is non-zero.
  bool active() const;
  bool appliesTo(const std::string& sensor) const;
  /// Ok when every size is finite and >= 0 (and the intrinsics fraction below 0.5).
  Status validate() const;
};

/// One sensor's drawn error.
struct SensorCalibrationError {
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();     // rotation vector, rad, servicer axes
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  // m, servicer axes
  Eigen::Vector4d intrinsics = Eigen::Vector4d::Zero();   // relative errors of fx, fy, cx, cy
};

/// The error of `sensor` in a run seeded `run_seed` (the spec's own seed when it has one); zero
/// for a sensor the spec does not apply to.
SensorCalibrationError drawCalibrationError(const CalibrationErrorSpec& spec,
                                            std::uint64_t run_seed, const std::string& sensor);

/// The mounting a sensor with this error publishes (see above).
Eigen::Isometry3d perturbedMounting(const Eigen::Isometry3d& servicer_T_frame,
                                    const SensorCalibrationError& error);
/// The intrinsics it publishes: fx, fy, cx, cy scaled by 1 + the error; the size and the
/// distortion are kept.
CameraModel perturbedIntrinsics(const CameraModel& model, const SensorCalibrationError& error);

}  // namespace cdff::egse
