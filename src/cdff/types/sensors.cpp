#include "cdff/types/sensors.hpp"

#include <cmath>

#include "cdff/types/geometry.hpp"

namespace cdff {

Status ImuSample::validate() const {
  CDFF_RETURN_IF_ERROR(checkFinite(angular_velocity, "IMU angular velocity"));
  return checkFinite(linear_acceleration, "IMU linear acceleration");
}

Status Wrench::validate() const {
  CDFF_RETURN_IF_ERROR(checkFinite(force, "wrench force"));
  return checkFinite(torque, "wrench torque");
}

Status JointState::validate() const {
  const std::size_t n = names.size();
  auto check = [&](const std::vector<double>& values, const char* field, bool optional) -> Status {
    if (values.size() != n && !(optional && values.empty()))
      return invalidInput("joint state has {} names but {} {} values; expected {}", n,
                          values.size(), field, optional ? "the same count or none" : "the same count");
    for (std::size_t i = 0; i < values.size(); ++i)
      if (!std::isfinite(values[i]))
        return invalidInput("joint state {} of '{}' is {}; expected a finite value", field,
                            names[i], values[i]);
    return Status::ok();
  };
  CDFF_RETURN_IF_ERROR(check(position, "position", false));
  CDFF_RETURN_IF_ERROR(check(velocity, "velocity", true));
  return check(effort, "effort", true);
}

}  // namespace cdff
