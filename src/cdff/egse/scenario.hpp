#pragma once
// Scenarios: everything a simulation run needs, read from YAML (docs/simulator.md has the
// schema). The trajectory library lives in data/scenarios/*.yaml; `cdff sim --list` lists it.
//
// Loading is strict: an unknown key, a value of the wrong type or out of range is an error in the
// one format of every YAML file the project reads (cdff/schema), naming the file, line and column
// (Status::location()), the key's full path and the value, and saying what was expected:
//   mid_range_approach.yaml:31:22: sensors.camera_left.exposure_time = -0.002: out of range;
//   expected a number in (0, 10] s
// `overrides` ("key=value" with dotted keys, list items by index: faults.0.start=5) are applied
// before validation; errors in them name the override ("--set key=value") instead of a line.
// The reader is in scenario_reader*.cpp, a declarative table per section.

#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/egse/arm_simulator.hpp"
#include "cdff/egse/calibration_error.hpp"
#include "cdff/egse/camera_sensor.hpp"
#include "cdff/egse/imu.hpp"
#include "cdff/egse/model_io.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/range_sensors.hpp"
#include "cdff/egse/render.hpp"
#include "cdff/egse/world.hpp"

namespace cdff::egse {

enum class SensorType { kCamera, kLidar, kTof, kImu, kRadar, kAhrs };
const char* toString(SensorType type);

struct SensorConfig {
  std::string name;  // the key in `sensors:` (camera_left, lidar, ...)
  SensorType type = SensorType::kCamera;
  bool enabled = true;
  double rate = 10.0;    // Hz
  double phase = 0.0;    // s, time of the first measurement
  double latency = 0.0;  // s from the measurement to its availability (log time)
  /// The band of true range (m, servicer to target centre) in which the sensor is on: the
  /// mission's timeline switches each sensor on within its phase of the approach (a far-range
  /// camera from 2 km, the stereo cameras from 20 m). Outside it: no measurement.
  double min_active_range = 0.0;
  double max_active_range = std::numeric_limits<double>::infinity();
  /// Mounting: the sensor's body frame in the servicer frame (x along the boresight). Cameras
  /// and the ToF publish in their optical frame (z along the boresight), `<name>_optical`.
  Eigen::Isometry3d servicer_T_mount = Eigen::Isometry3d::Identity();
  CameraSpec camera;
  LidarSpec lidar;
  TofSpec tof;
  ImuSpec imu;
  RadarSpec radar;
  AhrsSpec ahrs;

  /// The frame the measurements are expressed in.
  std::string frame() const;
  /// servicer_T_<frame()>.
  Eigen::Isometry3d servicerTframe() const;
  /// The channel prefix: /chaser/camera/left for camera_left, /chaser/lidar for lidar, ...
  std::string channelPrefix() const;
};

enum class FaultType {
  kCameraFailure,  // the camera goes dark
  kGlare,          // sun glare / saturation
  kLidarDropout,   // LIDAR (or ToF) points dropped
  kLidarSpurious,  // LIDAR spurious returns
  kImuBiasJump,
  kDroppedFrames,
  kLateFrames,
  kOcclusion,  // part of the target hidden (25/50/75 % in the seed)
};
const char* toString(FaultType type);

struct FaultConfig {
  FaultType type = FaultType::kCameraFailure;
  std::string sensor;        // a sensor name, or "*" for every sensor the fault applies to
  double start = 0.0;        // s
  double end = 1e300;        // s
  double probability = 1.0;  // dropped/late frames, LIDAR dropouts
  double rate = 0.0;         // spurious returns per scan
  double gain = 20.0;        // glare: multiplies the stray light
  double veil = 0.0;         // glare: a uniform veil (radiance units)
  double delay = 0.1;        // late frames, s
  double fraction = 0.5;     // occlusion
  OcclusionMode mode = OcclusionMode::kOccluder;
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // bias jump, rad/s
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // bias jump, m/s^2

  bool activeAt(double t) const { return t >= start && t < end; }
  bool appliesTo(const std::string& name) const { return sensor == "*" || sensor == name; }
};

/// The servicer's manipulator (haptic scanning, docs/haptic-scanning.md): off unless a scenario
/// has `arm:`. Its base frame is `spec.base_link`, mounted on the servicer.
struct ArmConfig {
  bool enabled = false;
  ArmSpec spec;
  /// servicer_T_base: the front face of the default 0.8 m bus (x = 0.4 m), the base 0.35 m below
  /// the servicer's centre so that the shoulder is level with the line of sight to the target.
  Eigen::Isometry3d servicer_T_base = Eigen::Isometry3d(Eigen::Translation3d(0.4, 0, -0.35));
};

enum class TranslationKind { kHold, kLine, kWaypoints, kFlyAround, kCw };
enum class ServicerAttitudeKind { kTargetPointing, kLvlh, kInertial };
enum class TargetAttitudeKind { kLvlh, kInertial, kTumbling };

struct Scenario {
  std::string name;
  std::string description;
  std::filesystem::path file;  // empty for scenarios built in code
  double duration = 60.0;      // s
  std::uint64_t seed = 1;
  Orbit orbit;

  // Target
  bool procedural_target = true;
  TargetSpec target_spec;
  std::filesystem::path target_mesh;  // when not procedural
  MeshLoadOptions mesh_options;
  Eigen::Quaterniond mesh_rotation = Eigen::Quaterniond::Identity();  // applied after loading
  TargetAttitudeKind target_attitude = TargetAttitudeKind::kLvlh;
  Eigen::Quaterniond target_initial = Eigen::Quaterniond::Identity();  // lvlh_R_target at t = 0
  Eigen::Vector3d target_rate = Eigen::Vector3d::Zero();  // rad/s, body axes (tumbling)
  std::optional<Eigen::Vector3d> target_inertia;          // kg m^2 (tumbling)

  // Servicer
  TranslationKind translation = TranslationKind::kHold;
  Eigen::Vector3d start = Eigen::Vector3d(0, -10, 0), end = Eigen::Vector3d(0, -10, 0);  // lvlh
  double start_time = 0.0, end_time = -1.0;  // line; end_time < 0: the duration
  bool smooth = true;
  std::vector<double> waypoint_times;
  std::vector<Eigen::Vector3d> waypoints;
  /// waypoints' `profile: legs`: a minimum-jerk leg between consecutive waypoints, at rest at
  /// each (a rendezvous's hold points); `spline` (false): one natural cubic spline through all.
  bool waypoint_legs = false;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero(), axis = Eigen::Vector3d::UnitZ(),
                  reference = -Eigen::Vector3d::UnitY();
  double radius = 10.0, radial_rate = 0.0, angular_rate = 0.0, phase = 0.0;  // fly-around
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();                        // cw
  ServicerAttitudeKind servicer_attitude = ServicerAttitudeKind::kTargetPointing;
  Eigen::Vector3d up = Eigen::Vector3d::UnitX();  // target pointing: body z towards this (lvlh)
  double yaw_offset = 0.0, pitch_offset = 0.0;    // rad
  double servicer_jitter = 0.0;                   // rad RMS per axis (pointing jitter)
  Eigen::Quaterniond servicer_orientation = Eigen::Quaterniond::Identity();  // lvlh / inertial
  bool servicer_mockup = false;
  ServicerSpec servicer_spec;

  // Lighting and background
  Sun sun;
  bool eclipses = true;  // the Earth's shadow (with an orbit)
  bool stars = true;
  double star_gain = 1.0;
  bool earth = true;  // drawn when the orbit is enabled

  std::vector<SensorConfig> sensors;
  ArmConfig arm;
  /// The calibrations published differ from those simulated by this drawn error (none by
  /// default); the truth channels keep the true ones.
  CalibrationErrorSpec calibration_error;
  std::vector<FaultConfig> faults;
  double truth_rate = 50.0;  // Hz
  bool truth_camera_depth = false;
  RendererBackend renderer = RendererBackend::kCpu;

  std::string yaml;  // the effective YAML (overrides applied), for the recording

  const SensorConfig* sensor(const std::string& name) const;
};

/// The sensor suite of the DLR OOS-Sim as the seed specifies it (§5.2.1), mounted on the
/// servicer's front face: stereo Prosilica GC1600H with 6 mm lenses (0.2 m baseline), a VLP-16,
/// a ToF camera, an Xsens MTi and a radar (off unless a scenario enables it).
std::vector<SensorConfig> defaultSensors();
/// The seed's Prosilica GC1600H (1624 x 1234, 4.4 um pixels) behind a 6 mm lens, with the barrel
/// distortion of such a lens: the default stereo cameras.
CameraModel prosilicaGc1600h();

/// Reads a scenario file, applying `overrides` ("dotted.key=value").
Result<Scenario> loadScenario(const std::filesystem::path& file,
                              const std::vector<std::string>& overrides = {});
/// Parses YAML text (`source` names it in errors).
Result<Scenario> parseScenario(const std::string& yaml, const std::string& source,
                               const std::vector<std::string>& overrides = {},
                               const std::filesystem::path& base_directory = {});

/// The trajectory library: data/scenarios in the source tree, or $CDFF_SCENARIO_DIR.
std::filesystem::path scenarioDirectory();
struct ScenarioInfo {
  std::string name;
  std::filesystem::path file;
  std::string description;
  double duration = 0;
};
/// Every scenario of the library, sorted by name (files that fail to load are listed with
/// their error as description).
std::vector<ScenarioInfo> listScenarios(
    const std::filesystem::path& directory = scenarioDirectory());
/// A library name ("mid_range_approach") or a path to a YAML file.
Result<std::filesystem::path> resolveScenario(const std::string& name_or_path);

}  // namespace cdff::egse
