// The scenario's world: orbit, renderer, lighting (the sun), background and truth.
#include <map>

#include "cdff/egse/scenario_reader.hpp"

namespace cdff::egse::scenario_reader {

const Table<Orbit>& orbitTable() {
  static const Table<Orbit> table =
      Table<Orbit>("the orbit {enabled, altitude}")
          .optional("enabled", schema::flag(&Orbit::enabled))
          .optional("altitude", schema::number(&Orbit::altitude, Range::closed(100e3, 1e8, "m")));
  return table;
}

const Table<ScenarioDraft>& rendererTable() {
  static const Table<ScenarioDraft> table =
      Table<ScenarioDraft>("the renderer {backend, shadow_map_size}")
          .optional("backend", inScenario(schema::named(&Scenario::renderer,
                                                        {{"cpu", RendererBackend::kCpu},
                                                         {"opengl", RendererBackend::kOpenGl},
                                                         {"auto", RendererBackend::kAuto}})))
          .optional("shadow_map_size", [](const Field& f, ScenarioDraft& d) -> Status {
            CDFF_RETURN_IF_ERROR(f.read(d.shadow_map_size, 64, 8192));
            // The default of every camera, the built-in ones included.
            for (SensorConfig& s : d.scenario.sensors)
              if (s.type == SensorType::kCamera) s.camera.shadow_map_size = d.shadow_map_size;
            return Status::ok();
          });
  return table;
}

// ------------------------------------------------------------------------------ lighting

namespace {

/// Azimuth and elevation (deg) of the presets, relative to the first line of sight.
const std::map<std::string, std::pair<double, double>>& sunPresets() {
  static const std::map<std::string, std::pair<double, double>> presets = {{"front_lit", {25, 15}},
                                                                           {"side_lit", {90, 10}},
                                                                           {"back_lit", {130, 20}},
                                                                           {"near_fov", {145, 0}}};
  return presets;
}

const Table<ScenarioDraft>& sunTable() {
  static const Table<ScenarioDraft> table =
      Table<ScenarioDraft>("the sun {preset, azimuth_deg, elevation_deg} or {direction, frame}")
          .optional("preset",
                    [](const Field& f, ScenarioDraft& d) -> Status {
                      std::string preset;
                      CDFF_RETURN_IF_ERROR(
                          f.choice(preset, {"front_lit", "side_lit", "back_lit", "near_fov"}));
                      d.sun_azimuth = sunPresets().at(preset).first * kDeg;
                      d.sun_elevation = sunPresets().at(preset).second * kDeg;
                      return Status::ok();
                    })
          .optional("azimuth_deg",
                    degrees(&ScenarioDraft::sun_azimuth, Range::closed(-360, 360, "deg")))
          .optional("elevation_deg",
                    degrees(&ScenarioDraft::sun_elevation, Range::closed(-90, 90, "deg")))
          .optional("direction",
                    [](const Field& f, ScenarioDraft& d) -> Status {
                      CDFF_RETURN_IF_ERROR(readDirection(f, d.scenario.sun.direction));
                      d.sun_direction_given = true;
                      return Status::ok();
                    })
          .optional("frame", inScenario(via(
                                 &Scenario::sun,
                                 schema::named(&Sun::inertial, {{"lvlh", false}, {"eci", true}}))));
  return table;
}

Status readSun(const Field& f, ScenarioDraft& d) {
  CDFF_RETURN_IF_ERROR(sunTable().check(f));
  if (f.has("direction") && (f.has("preset") || f.has("azimuth_deg") || f.has("elevation_deg")))
    return f["direction"].fail("either 'direction' or 'preset'/'azimuth_deg'/'elevation_deg'",
                               "given with a preset or angles");
  return sunTable().read(f, d);
}

}  // namespace

const Table<ScenarioDraft>& lightingTable() {
  static const Table<ScenarioDraft> table =
      Table<ScenarioDraft>("the lighting {sun, irradiance, eclipses}")
          .optional("sun", readSun)
          .optional("irradiance",
                    inScenario(via(&Scenario::sun,
                                   schema::number(&Sun::irradiance,
                                                  Range::closed(0, 100, "solar constants")))))
          .optional("eclipses", inScenario(schema::flag(&Scenario::eclipses)));
  return table;
}

void placeSun(ScenarioDraft& draft) {
  Scenario& sc = draft.scenario;
  const double azimuth = draft.sun_azimuth, elevation = draft.sun_elevation;
  // Azimuth from "behind the servicer" (0, front-lit) towards its right; elevation towards up.
  const Eigen::Vector3d f =
      (-sc.start).norm() > 1e-9 ? (-sc.start).normalized() : Eigen::Vector3d::UnitY();
  Eigen::Vector3d u = sc.up - sc.up.dot(f) * f;
  if (u.norm() < 1e-6) u = Eigen::Vector3d::UnitZ() - f.z() * f;
  u.normalize();
  const Eigen::Vector3d r = f.cross(u);
  sc.sun.direction = (std::cos(elevation) * (std::cos(azimuth) * -f + std::sin(azimuth) * r) +
                      std::sin(elevation) * u)
                         .normalized();
}

// ------------------------------------------------------------------------ background, truth

const Table<Scenario>& backgroundTable() {
  static const Table<Scenario> table =
      Table<Scenario>("the background {stars, star_gain, earth}")
          .optional("stars", schema::flag(&Scenario::stars))
          .optional("star_gain", schema::number(&Scenario::star_gain, Range::closed(0, 1e9)))
          .optional("earth", schema::flag(&Scenario::earth));
  return table;
}

const Table<Scenario>& truthTable() {
  static const Table<Scenario> table =
      Table<Scenario>("the ground truth {rate, camera_depth}")
          .optional("rate", schema::number(&Scenario::truth_rate, Range::leftOpen(0, 10000, "Hz")))
          .optional("camera_depth", schema::flag(&Scenario::truth_camera_depth));
  return table;
}

}  // namespace cdff::egse::scenario_reader
