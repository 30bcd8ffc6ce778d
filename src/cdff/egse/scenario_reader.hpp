#pragma once
// Internal to the scenario reader (scenario_reader*.cpp): the scenario while it is read, the
// readers its sections share, and one entry point per section. Every section is a declarative
// schema::Table (cdff/schema/table.hpp), so that errors have the project's one format:
//   s.yaml:3:32: sensors.camera_left.exposure_time = -0.002: out of range; expected a number in
//   (0, 10] s

#include <cmath>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "cdff/egse/scenario.hpp"
#include "cdff/schema/table.hpp"

namespace cdff::egse::scenario_reader {

using schema::Field;
using schema::Range;
using schema::Table;

constexpr double kDeg = M_PI / 180.0;

/// A scenario while it is read: the Scenario, and what one section leaves for a later one.
struct ScenarioDraft {
  Scenario scenario;
  std::filesystem::path base;  // the scenario file's directory: mesh paths are relative to it
  int shadow_map_size = 1024;  // renderer.shadow_map_size, every camera's default
  // The sun relative to the first line of sight (lighting.sun), unless given as a direction.
  double sun_azimuth = 90 * kDeg, sun_elevation = 10 * kDeg;
  bool sun_direction_given = false;
};

/// A reader of a part of the target: via(&Sensor::camera, schema::flag(&CameraSpec::noise)).
template <typename T, typename Part, typename Reader>
auto via(Part T::*part, Reader reader) {
  return
      [part, reader = std::move(reader)](const Field& f, T& out) { return reader(f, out.*part); };
}
/// A reader of the Scenario, in a table of the draft.
template <typename Reader>
auto inScenario(Reader reader) {
  return via(&ScenarioDraft::scenario, std::move(reader));
}

// Values of the scenario's own kinds.

/// Three numbers, times `scale`.
Status readVec3(const Field& f, Eigen::Vector3d& out, double scale = 1.0);
/// Three numbers, not all zero, normalised.
Status readDirection(const Field& f, Eigen::Vector3d& out);
/// Roll, pitch, yaw in degrees (REP-103 fixed axes).
Status readRpy(const Field& f, Eigen::Quaterniond& out);
/// A number in degrees within `range`, stored in radians.
Status readDegrees(const Field& f, double& out, const Range& range);

template <typename T>
auto vec3(Eigen::Vector3d T::*member, double scale = 1.0) {
  return [member, scale](const Field& f, T& out) { return readVec3(f, out.*member, scale); };
}
template <typename T>
auto direction(Eigen::Vector3d T::*member) {
  return [member](const Field& f, T& out) { return readDirection(f, out.*member); };
}
template <typename T>
auto rpy(Eigen::Quaterniond T::*member) {
  return [member](const Field& f, T& out) { return readRpy(f, out.*member); };
}
template <typename T>
auto degrees(double T::*member, Range range) {
  return [member, range](const Field& f, T& out) { return readDegrees(f, out.*member, range); };
}

/// R = Rz(yaw) Ry(pitch) Rx(roll), `rpy` in radians.
Eigen::Quaterniond fromRpy(const Eigen::Vector3d& rpy);
/// The pose of a sensor's body frame in the servicer frame.
Eigen::Isometry3d mountAt(const Eigen::Vector3d& p,
                          const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity());

// The sections, each in its own file.

/// orbit, renderer, lighting, background, truth (scenario_reader_world.cpp).
const Table<Orbit>& orbitTable();
const Table<ScenarioDraft>& rendererTable();
const Table<ScenarioDraft>& lightingTable();
const Table<Scenario>& backgroundTable();
const Table<Scenario>& truthTable();
/// The sun's direction from lighting.sun's angles and the first line of sight, when no
/// direction was given.
void placeSun(ScenarioDraft& draft);

/// target: model, procedural, mesh, attitude (scenario_reader_target.cpp).
const Table<ScenarioDraft>& targetTable();
/// servicer: trajectory, attitude, mockup (scenario_reader_servicer.cpp).
const Table<Scenario>& servicerTable();
/// sensors: the built-in ones changed by name, new ones with a type (scenario_reader_sensors.cpp).
Status readSensors(const Field& f, ScenarioDraft& draft);
/// arm: the manipulator, its sensors and collision paths (scenario_reader_arm.cpp).
Status readArm(const Field& f, ScenarioDraft& draft);
/// faults: a list, each on sensors that exist (scenario_reader_faults.cpp).
Status readFaults(const Field& f, ScenarioDraft& draft);

/// The whole file: `overrides` ("dotted.key=value") applied to `document` first; mesh paths
/// relative to `base` (scenario_reader.cpp).
Result<Scenario> readScenario(schema::Document document, const std::vector<std::string>& overrides,
                              const std::filesystem::path& base);

}  // namespace cdff::egse::scenario_reader
