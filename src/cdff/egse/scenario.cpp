// Scenarios: the sensor suite, the trajectory library, and the entry points of the reader
// (scenario_reader*.cpp).
#include "cdff/egse/scenario.hpp"

#include <algorithm>
#include <cstdlib>

#include <fmt/ranges.h>

#include "cdff/egse/scenario_reader.hpp"

namespace cdff::egse {

const char* toString(SensorType type) {
  switch (type) {
    case SensorType::kCamera:
      return "camera";
    case SensorType::kLidar:
      return "lidar";
    case SensorType::kTof:
      return "tof";
    case SensorType::kImu:
      return "imu";
    case SensorType::kRadar:
      return "radar";
    case SensorType::kAhrs:
      return "ahrs";
  }
  return "?";
}

const char* toString(FaultType type) {
  switch (type) {
    case FaultType::kCameraFailure:
      return "camera_failure";
    case FaultType::kGlare:
      return "glare";
    case FaultType::kLidarDropout:
      return "lidar_dropout";
    case FaultType::kLidarSpurious:
      return "lidar_spurious";
    case FaultType::kImuBiasJump:
      return "imu_bias_jump";
    case FaultType::kDroppedFrames:
      return "dropped_frames";
    case FaultType::kLateFrames:
      return "late_frames";
    case FaultType::kOcclusion:
      return "occlusion";
  }
  return "?";
}

namespace {

using scenario_reader::mountAt;

// The optical frame (z forward, x right, y down) of a sensor whose body frame looks along x.
Eigen::Matrix3d mountRotationOptical() {
  Eigen::Matrix3d R;
  R.col(0) = -Eigen::Vector3d::UnitY();  // optical x (right) = body -y
  R.col(1) = -Eigen::Vector3d::UnitZ();  // optical y (down) = body -z
  R.col(2) = Eigen::Vector3d::UnitX();   // optical z (forward) = body x
  return R;
}

}  // namespace

CameraModel prosilicaGc1600h() {
  CameraModel m;
  m.width = 1624;
  m.height = 1234;
  m.fx = m.fy = 6e-3 / 4.4e-6;  // 6 mm lens, 4.4 um pixels (Sony ICX274)
  m.cx = 811.5;
  m.cy = 616.5;
  m.distortion_model = DistortionModel::kRadialTangential;
  m.distortion = {-0.12, 0.05, 0.0005, -0.0003, 0.0};
  return m;
}

// ------------------------------------------------------------------------------ sensors

std::string SensorConfig::frame() const {
  return type == SensorType::kCamera || type == SensorType::kTof ? name + "_optical" : name;
}

Eigen::Isometry3d SensorConfig::servicerTframe() const {
  if (type != SensorType::kCamera && type != SensorType::kTof) return servicer_T_mount;
  Eigen::Isometry3d optical = Eigen::Isometry3d::Identity();
  optical.linear() = mountRotationOptical();
  return servicer_T_mount * optical;
}

std::string SensorConfig::channelPrefix() const {
  if (type == SensorType::kCamera) {
    const std::string stem = name.rfind("camera_", 0) == 0 ? name.substr(7) : name;
    return "/chaser/camera/" + stem;
  }
  return "/chaser/" + name;
}

const SensorConfig* Scenario::sensor(const std::string& n) const {
  for (const SensorConfig& s : sensors)
    if (s.name == n) return &s;
  return nullptr;
}

std::vector<SensorConfig> defaultSensors() {
  std::vector<SensorConfig> sensors;
  for (int side : {1, -1}) {
    SensorConfig c;
    c.name = side > 0 ? "camera_left" : "camera_right";
    c.type = SensorType::kCamera;
    c.rate = 10.0;
    c.servicer_T_mount = mountAt({0.45, 0.1 * side, 0.15});
    c.camera.model = prosilicaGc1600h();
    sensors.push_back(c);
  }
  SensorConfig lidar;
  lidar.name = "lidar";
  lidar.type = SensorType::kLidar;
  lidar.rate = 10.0;
  lidar.servicer_T_mount = mountAt({0.45, 0.0, -0.2});
  lidar.lidar = LidarSpec::vlp16();
  sensors.push_back(lidar);
  SensorConfig tof;
  tof.name = "tof";
  tof.type = SensorType::kTof;
  tof.rate = 10.0;
  tof.servicer_T_mount = mountAt({0.45, 0.0, 0.3});
  tof.tof = TofSpec::defaults();
  sensors.push_back(tof);
  SensorConfig imu;
  imu.name = "imu";
  imu.type = SensorType::kImu;
  imu.rate = 120.0;
  imu.servicer_T_mount = mountAt({0.05, 0.02, -0.1});
  sensors.push_back(imu);
  SensorConfig radar;
  radar.name = "radar";
  radar.type = SensorType::kRadar;
  radar.enabled = false;
  radar.rate = 1.0;
  radar.servicer_T_mount = mountAt({0.45, 0.0, 0.0});
  sensors.push_back(radar);
  // Off by default: a scenario's recording (and its digest) changes only when the scenario
  // enables it; the LIDAR tracking DFPC uses it when present.
  SensorConfig ahrs;
  ahrs.name = "ahrs";
  ahrs.type = SensorType::kAhrs;
  ahrs.enabled = false;
  ahrs.rate = 10.0;
  sensors.push_back(ahrs);
  return sensors;
}

// ------------------------------------------------------------------------- reading files

Result<Scenario> parseScenario(const std::string& text, const std::string& source,
                               const std::vector<std::string>& overrides,
                               const std::filesystem::path& base) {
  Result<schema::Document> document = schema::Document::parse(text, source);
  if (!document) return document.status();
  return scenario_reader::readScenario(std::move(document).value(), overrides, base);
}

Result<Scenario> loadScenario(const std::filesystem::path& file,
                              const std::vector<std::string>& overrides) {
  Result<schema::Document> document = schema::Document::loadFile(file.string(), "scenario file");
  if (!document) return document.status();
  auto scenario =
      scenario_reader::readScenario(std::move(document).value(), overrides, file.parent_path());
  if (scenario) scenario->file = file;
  return scenario;
}

std::filesystem::path scenarioDirectory() {
  if (const char* dir = std::getenv("CDFF_SCENARIO_DIR")) return dir;
#ifdef CDFF_SOURCE_SCENARIO_DIR
  return CDFF_SOURCE_SCENARIO_DIR;
#else
  return "data/scenarios";
#endif
}

std::vector<ScenarioInfo> listScenarios(const std::filesystem::path& directory) {
  std::vector<ScenarioInfo> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(directory, ec)) {
    if (entry.path().extension() != ".yaml") continue;
    ScenarioInfo info;
    info.file = entry.path();
    info.name = entry.path().stem().string();
    auto scenario = loadScenario(entry.path());
    if (scenario) {
      info.description = scenario->description;
      info.duration = scenario->duration;
    } else {
      info.description = "INVALID: " + scenario.status().message();
    }
    out.push_back(info);
  }
  std::sort(out.begin(), out.end(),
            [](const ScenarioInfo& a, const ScenarioInfo& b) { return a.name < b.name; });
  return out;
}

Result<std::filesystem::path> resolveScenario(const std::string& name_or_path) {
  const std::filesystem::path p(name_or_path);
  if (p.extension() == ".yaml" || p.extension() == ".yml" ||
      name_or_path.find('/') != std::string::npos) {
    if (!std::filesystem::exists(p))
      return notFound("scenario file '{}' does not exist", name_or_path);
    return p;
  }
  const std::filesystem::path library = scenarioDirectory() / (name_or_path + ".yaml");
  if (std::filesystem::exists(library)) return library;
  std::vector<std::string> names;
  for (const ScenarioInfo& s : listScenarios()) names.push_back(s.name);
  return notFound("unknown scenario '{}'; expected a YAML file or one of {{{}}} (in {})",
                  name_or_path, fmt::join(names, ", "), scenarioDirectory().string());
}

}  // namespace cdff::egse
