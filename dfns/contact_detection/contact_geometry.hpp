#pragma once
// What the ContactDetection DFIs share: the checks of a sensor sample and the contact's output
// as a one-point cloud.
#include <cmath>
#include <string>

#include <Eigen/Core>

#include "cdff/types/point_cloud.hpp"
#include "cdff/types/sensors.hpp"

namespace cdff::dfn::contact {

/// Ok when the sample is finite and below the sensor's full scale on every axis; a saturated
/// reading's true value is unknown, so nothing may be inferred from it.
inline Status checkSample(const Wrench& w, double force_range, double torque_range) {
  Status finite = w.validate();
  if (!finite.isOk()) return finite.withContext(fmt::format("input 'wrench' at {} us", w.stamp));
  static const char* kAxes[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    if (std::abs(w.force[i]) >= force_range)
      return invalidInput(
          "input 'wrench' at {} us: force {} = {} N reaches the sensor's full scale +-{} N; "
          "expected an unsaturated sample (no contact is inferred from a saturated one)",
          w.stamp, kAxes[i], w.force[i], force_range);
    if (std::abs(w.torque[i]) >= torque_range)
      return invalidInput(
          "input 'wrench' at {} us: torque {} = {} N m reaches the sensor's full scale +-{} N m; "
          "expected an unsaturated sample (no contact is inferred from a saturated one)",
          w.stamp, kAxes[i], w.torque[i], torque_range);
  }
  return Status::ok();
}

/// The contact at `point` with `normal` and normal force `force` (N), as a one-point cloud.
inline PointCloud contactCloud(const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                               double force, const Wrench& w) {
  PointCloud cloud = PointCloud::fromXyz({point.cast<float>()}, w.frame_id, w.stamp);
  const Eigen::Vector3f n = normal.cast<float>();
  cloud.normals = Buffer<Point4f>::fromVector({Point4f(n.x(), n.y(), n.z())});
  cloud.intensity = Buffer<float>::fromVector({static_cast<float>(force)});
  return cloud;
}

}  // namespace cdff::dfn::contact
