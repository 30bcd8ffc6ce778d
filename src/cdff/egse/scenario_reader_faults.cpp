// The scenario's faults: a list, each of a type, on a sensor the type applies to (or '*'), over
// a time window.
#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/egse/scenario_reader.hpp"

namespace cdff::egse::scenario_reader {

namespace {

using F = FaultConfig;

const Table<FaultConfig>& faultTable() {
  const Range seconds = Range::closed(0, 1e9, "s");
  static const Table<FaultConfig> table =
      Table<FaultConfig>("a fault {type, sensor, start, end, ...}")
          .required("type",
                    schema::named(&F::type, {{"camera_failure", FaultType::kCameraFailure},
                                             {"glare", FaultType::kGlare},
                                             {"lidar_dropout", FaultType::kLidarDropout},
                                             {"lidar_spurious", FaultType::kLidarSpurious},
                                             {"imu_bias_jump", FaultType::kImuBiasJump},
                                             {"dropped_frames", FaultType::kDroppedFrames},
                                             {"late_frames", FaultType::kLateFrames},
                                             {"occlusion", FaultType::kOcclusion}}),
                    "the fault's type")
          .required("sensor", schema::text(&F::sensor), "a sensor name, or '*'")
          .optional("start", schema::number(&F::start, seconds))
          .optional("time", schema::number(&F::start, seconds))  // the same, for one-off faults
          .optional("end",
                    [seconds](const Field& f, FaultConfig& fault) -> Status {
                      CDFF_RETURN_IF_ERROR(f.read(fault.end, seconds));
                      if (fault.end <= fault.start)
                        return f.fail(fmt::format("a time after start ({} s)", fault.start),
                                      "not after start");
                      return Status::ok();
                    })
          .optional("probability", schema::number(&F::probability, Range::closed(0, 1)))
          .optional("rate", schema::number(&F::rate, Range::closed(0, 1e6, "returns per scan")))
          .optional("gain", schema::number(&F::gain, Range::closed(0, 1e6)))
          .optional("veil", schema::number(&F::veil, Range::closed(0, 1e6)))
          .optional("delay", schema::number(&F::delay, Range::leftOpen(0, 60, "s")))
          .optional("fraction", schema::number(&F::fraction, Range::closed(0, 1)))
          .optional("mode", schema::named(&F::mode, {{"occluder", OcclusionMode::kOccluder},
                                                     {"shadow", OcclusionMode::kShadow}}))
          .optional("gyro", vec3(&F::gyro))
          .optional("gyro_deg_s", vec3(&F::gyro, kDeg))
          .optional("accel", vec3(&F::accel));
  return table;
}

/// The sensor types a fault can hit.
std::vector<SensorType> targetsOf(FaultType type) {
  switch (type) {
    case FaultType::kCameraFailure:
    case FaultType::kGlare:
    case FaultType::kOcclusion:
      return {SensorType::kCamera};
    case FaultType::kLidarDropout:
      return {SensorType::kLidar, SensorType::kTof};
    case FaultType::kLidarSpurious:
      return {SensorType::kLidar};
    case FaultType::kImuBiasJump:
      return {SensorType::kImu};
    default:
      return {SensorType::kCamera, SensorType::kLidar, SensorType::kTof,
              SensorType::kImu,    SensorType::kRadar, SensorType::kAhrs};
  }
}

/// `fault.sensor` is '*' or a sensor of a type the fault applies to.
Status checkSensor(const Field& f, const FaultConfig& fault, const std::vector<SensorConfig>& all) {
  if (fault.sensor == "*") return Status::ok();
  const std::vector<SensorType> allowed = targetsOf(fault.type);
  const auto applies = [&](SensorType t) {
    return std::find(allowed.begin(), allowed.end(), t) != allowed.end();
  };
  std::vector<std::string> names;
  const SensorConfig* target = nullptr;
  for (const SensorConfig& s : all) {
    if (applies(s.type)) names.push_back(s.name);
    if (s.name == fault.sensor) target = &s;
  }
  if (target && applies(target->type)) return Status::ok();
  const std::string problem = target ? fmt::format("{} faults do not apply to {} sensors",
                                                   toString(fault.type), toString(target->type))
                                     : "no such sensor";
  return f.fail(
      fmt::format("a sensor a {} fault applies to: one of {{{}}} or '*'{}", toString(fault.type),
                  fmt::join(names, ", "), schema::didYouMean(fault.sensor, names)),
      problem);
}

}  // namespace

Status readFaults(const Field& f, ScenarioDraft& d) {
  if (!f.isList()) return f.fail("a list of faults");
  for (const Field& element : f.elements()) {
    FaultConfig fault;
    CDFF_RETURN_IF_ERROR(faultTable().read(element, fault));
    CDFF_RETURN_IF_ERROR(checkSensor(element["sensor"], fault, d.scenario.sensors));
    if (fault.type == FaultType::kLidarSpurious && !element.has("rate"))
      return element.missing("rate", "the returns per scan of a lidar_spurious fault");
    d.scenario.faults.push_back(fault);
  }
  return Status::ok();
}

}  // namespace cdff::egse::scenario_reader
