// The scenario file as a whole (scenario.hpp: loadScenario, parseScenario): `--set` overrides,
// the top-level keys, and what is derived once every section is read.

#include <fmt/format.h>

#include "cdff/egse/scenario_reader.hpp"
#include "cdff/schema/override.hpp"

namespace cdff::egse::scenario_reader {

Status readVec3(const Field& f, Eigen::Vector3d& out, double scale) {
  std::vector<double> v;
  CDFF_RETURN_IF_ERROR(f.numbers(v, 3, 3));
  out = Eigen::Vector3d(v[0], v[1], v[2]) * scale;
  return Status::ok();
}

Status readDirection(const Field& f, Eigen::Vector3d& out) {
  Eigen::Vector3d v;
  CDFF_RETURN_IF_ERROR(readVec3(f, v));
  if (v.norm() < 1e-12) return f.fail("a non-zero direction vector", "zero length");
  v.normalize();
  out = v;
  return Status::ok();
}

Status readRpy(const Field& f, Eigen::Quaterniond& out) {
  Eigen::Vector3d rpy;
  CDFF_RETURN_IF_ERROR(readVec3(f, rpy, kDeg));
  out = fromRpy(rpy);
  return Status::ok();
}

Status readDegrees(const Field& f, double& out, const Range& range) {
  double v = 0;
  CDFF_RETURN_IF_ERROR(f.read(v, range));
  out = v * kDeg;
  return Status::ok();
}

Eigen::Quaterniond fromRpy(const Eigen::Vector3d& rpy) {
  // REP-103 fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll).
  return Eigen::Quaterniond(Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()));
}

Eigen::Isometry3d mountAt(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = p;
  return T;
}

namespace {

// ----------------------------------------------------------------------------- the file

const Table<CalibrationErrorSpec>& calibrationErrorTable() {
  using C = CalibrationErrorSpec;
  static const Table<CalibrationErrorSpec> table =
      Table<CalibrationErrorSpec>(
          "the calibration error {seed, extrinsic_angle_deg, extrinsic_position, "
          "intrinsics_fraction, distribution, sensors}")
          .optional("seed",
                    [](const Field& f, C& c) -> Status {
                      std::uint64_t seed = 0;
                      CDFF_RETURN_IF_ERROR(f.read(seed));
                      c.seed = seed;
                      return Status::ok();
                    })
          .optional("extrinsic_angle_deg",
                    degrees(&C::extrinsic_angle, Range::closed(0, 10, "deg")))
          .optional("extrinsic_position",
                    schema::number(&C::extrinsic_position, Range::closed(0, 1, "m")))
          .optional("intrinsics_fraction",
                    schema::number(&C::intrinsics_fraction, Range::closed(0, 0.49)))
          .optional("distribution",
                    schema::named(&C::distribution,
                                  {{"gaussian", CalibrationErrorDistribution::kGaussian},
                                   {"fixed", CalibrationErrorDistribution::kFixed}}))
          .optional("sensors", [](const Field& f, C& c) {
            return f.words(c.sensors, "a list of sensor names");
          });
  return table;
}

// After the sensors: the names it lists must be sensors of the scenario.
Status readCalibrationError(const Field& f, Scenario& sc) {
  CDFF_RETURN_IF_ERROR(calibrationErrorTable().read(f, sc.calibration_error));
  for (std::size_t i = 0; i < sc.calibration_error.sensors.size(); ++i) {
    const std::string& name = sc.calibration_error.sensors[i];
    if (sc.sensor(name)) continue;
    std::vector<std::string> known;
    for (const SensorConfig& s : sc.sensors) known.push_back(s.name);
    return f["sensors"][i].fail(
        fmt::format("one of the scenario's sensors ({})", fmt::join(known, ", ")),
        fmt::format("no sensor '{}'", name));
  }
  return sc.calibration_error.validate().withContext(f.path()).at(f.location());
}

const Table<ScenarioDraft>& scenarioTable() {
  // Rows are read in this order: the renderer before the sensors (cameras take its shadow map
  // size), the sensors before the faults (which name them).
  static const Table<ScenarioDraft> table =
      Table<ScenarioDraft>("a scenario")
          .optional("name", inScenario(schema::text(&Scenario::name)))
          .optional("description", inScenario(schema::text(&Scenario::description)))
          .optional("duration",
                    inScenario(schema::number(&Scenario::duration, Range::leftOpen(0, 1e6, "s"))))
          .optional("seed", inScenario([](const Field& f, Scenario& s) { return f.read(s.seed); }))
          .optional("orbit", inScenario(schema::nested(&Scenario::orbit, orbitTable())))
          .optional("renderer",
                    [](const Field& f, ScenarioDraft& d) { return rendererTable().read(f, d); })
          .optional("target",
                    [](const Field& f, ScenarioDraft& d) { return targetTable().read(f, d); })
          .optional("servicer", inScenario([](const Field& f, Scenario& s) {
                      return servicerTable().read(f, s);
                    }))
          .optional("lighting",
                    [](const Field& f, ScenarioDraft& d) { return lightingTable().read(f, d); })
          .optional("background", inScenario([](const Field& f, Scenario& s) {
                      return backgroundTable().read(f, s);
                    }))
          .optional("sensors", readSensors)
          .optional("arm", readArm)
          .optional("calibration_error", inScenario(readCalibrationError))
          .optional("faults", readFaults)
          .optional("truth", inScenario([](const Field& f, Scenario& s) {
                      return truthTable().read(f, s);
                    }));
  return table;
}

/// What follows from the sections together.
void finish(ScenarioDraft& draft) {
  Scenario& sc = draft.scenario;
  if (sc.translation == TranslationKind::kFlyAround)
    sc.start =
        sc.centre +
        sc.radius *
            (std::cos(sc.phase) *
                 (sc.reference - sc.reference.dot(sc.axis) * sc.axis).normalized() +
             std::sin(sc.phase) *
                 sc.axis.cross((sc.reference - sc.reference.dot(sc.axis) * sc.axis).normalized()));
  if (!draft.sun_direction_given) placeSun(draft);
  if (sc.translation == TranslationKind::kLine && sc.end_time < 0) sc.end_time = sc.duration;
}

}  // namespace

Result<Scenario> readScenario(schema::Document document, const std::vector<std::string>& overrides,
                              const std::filesystem::path& base) {
  for (const std::string& text : overrides) {
    Result<schema::Override> o = schema::parseOverride(text, "sensors.lidar.range_noise=0.05");
    if (!o) return o.status();
    CDFF_RETURN_IF_ERROR(schema::applyOverride(document, *o));
  }
  YAML::Node& root = document.node();
  if (!root.IsDefined() || root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  ScenarioDraft draft;
  draft.base = base;
  draft.scenario.name = std::filesystem::path(document.source()).stem().string();
  draft.scenario.sensors = defaultSensors();
  CDFF_RETURN_IF_ERROR(scenarioTable().read(document.root(), draft));
  finish(draft);
  YAML::Emitter out;
  out << root;
  draft.scenario.yaml = out.c_str();
  return std::move(draft.scenario);
}

}  // namespace cdff::egse::scenario_reader
