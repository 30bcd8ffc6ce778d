// The scenario's target: its model (procedural, or a mesh file), the procedural model's
// dimensions, the mesh's import options, and its attitude motion.
#include <fmt/format.h>

#include "cdff/egse/scenario_reader.hpp"

namespace cdff::egse::scenario_reader {

namespace {

/// "procedural", or a mesh file relative to the scenario file.
Status readModel(const Field& f, ScenarioDraft& d) {
  std::string model;
  CDFF_RETURN_IF_ERROR(f.read(model));
  if (model == "procedural") return Status::ok();
  Scenario& sc = d.scenario;
  sc.procedural_target = false;
  const std::filesystem::path p(model);
  sc.target_mesh = p.is_absolute() || d.base.empty() ? p : d.base / p;
  if (!std::filesystem::exists(sc.target_mesh))
    return f.fail("'procedural' or a mesh file (OBJ, PLY, STL, glTF, GLB) relative to the scenario",
                  fmt::format("the mesh file '{}' does not exist", sc.target_mesh.string()),
                  StatusCode::kNotFound);
  return Status::ok();
}

/// A length in (low, high] metres.
Range metres(double low, double high) {
  return Range::leftOpen(low, high, "m");
}

/// Two numbers into an Eigen::Vector2d member (a panel's width and height).
template <class S>
auto size2(Eigen::Vector2d S::*member) {
  return [member](const Field& f, S& s) -> Status {
    std::vector<double> v;
    CDFF_RETURN_IF_ERROR(f.numbers(v, 2, 2));
    s.*member = {v[0], v[1]};
    return Status::ok();
  };
}

const Table<HexagonalTargetSpec>& hexagonalTable() {
  using T = HexagonalTargetSpec;
  static const Table<HexagonalTargetSpec> table =
      Table<HexagonalTargetSpec>("the hexagonal target's dimensions")
          .optional("bus_diameter", schema::number(&T::bus_diameter, metres(0, 20)))
          .optional("bus_length", schema::number(&T::bus_length, metres(0, 20)))
          .optional("panels", schema::integer(&T::panels, 0, 8))
          .optional("panel_size", size2(&T::panel_size))
          .optional("panel_thickness", schema::number(&T::panel_thickness, metres(0, 1)))
          .optional("yoke_length", schema::number(&T::yoke_length, metres(0, 10)))
          .optional("wing_angle_deg", degrees(&T::wing_angle, Range::closed(-180, 180, "deg")))
          .optional("boom_length", schema::number(&T::boom_length, Range::closed(0, 20, "m")))
          .optional("nozzle_length", schema::number(&T::nozzle_length, Range::closed(0, 5, "m")))
          .optional("nozzle_exit_diameter", schema::number(&T::nozzle_exit_diameter, metres(0, 10)))
          .optional("segments", schema::integer(&T::segments, 8, 256));
  return table;
}

const Table<TargetSpec>& proceduralTable() {
  using T = TargetSpec;
  static const Table<TargetSpec> table =
      Table<TargetSpec>("the procedural target's kind and dimensions")
          .optional("kind", schema::named(&T::kind, {{"satellite", TargetKind::kSatellite},
                                                     {"hexagonal", TargetKind::kHexagonal}}))
          .optional("hexagonal", schema::nested(&T::hexagonal, hexagonalTable()))
          .optional("bus_size", vec3(&T::bus_size))
          .optional("solar_wings", schema::flag(&T::solar_wings))
          .optional("panels_per_wing", schema::integer(&T::panels_per_wing, 1, 8))
          .optional("panel_size", size2(&T::panel_size))
          .optional("panel_thickness", schema::number(&T::panel_thickness, metres(0, 1)))
          .optional("panel_gap", schema::number(&T::panel_gap, Range::closed(0, 1, "m")))
          .optional("yoke_length", schema::number(&T::yoke_length, metres(0, 10)))
          .optional("wing_angle_deg", degrees(&T::wing_angle, Range::closed(-180, 180, "deg")))
          .optional("adapter_ring", schema::flag(&T::adapter_ring))
          .optional("ring_diameter", schema::number(&T::ring_diameter, metres(0, 10)))
          .optional("ring_height", schema::number(&T::ring_height, metres(0, 5)))
          .optional("ring_wall", schema::number(&T::ring_wall, metres(0, 1)))
          .optional("ring_flange_width",
                    schema::number(&T::ring_flange_width, Range::closed(0, 1, "m")))
          .optional("launcher_brackets", schema::flag(&T::launcher_brackets))
          .optional("antenna", schema::flag(&T::antenna))
          .optional("dish_diameter", schema::number(&T::dish_diameter, metres(0, 10)))
          .optional("dish_depth", schema::number(&T::dish_depth, metres(0, 5)))
          .optional("mast_height", schema::number(&T::mast_height, metres(0, 10)))
          .optional("thrusters", schema::flag(&T::thrusters))
          .optional("thruster_length", schema::number(&T::thruster_length, metres(0, 2)))
          .optional("thruster_exit_diameter",
                    schema::number(&T::thruster_exit_diameter, metres(0, 2)))
          .optional("segments", schema::integer(&T::segments, 8, 256));
  return table;
}

Status readProcedural(const Field& f, Scenario& sc) {
  CDFF_RETURN_IF_ERROR(proceduralTable().read(f, sc.target_spec));
  // Each kind has its own keys: the satellite's at this level, the hexagonal one's under
  // `hexagonal`; a key of the other kind would be silently ignored.
  if (f.isMap())
    for (const Field::Entry& entry : f.entries()) {
      const bool hexagonal = sc.target_spec.kind == TargetKind::kHexagonal;
      if (entry.key == "kind" || (entry.key == "hexagonal") == hexagonal) continue;
      return entry.value.fail(
          hexagonal ? "the hexagonal target's keys under target.procedural.hexagonal"
                    : "the hexagonal target's keys only with target.procedural.kind: hexagonal",
          fmt::format("'{}' does not apply to kind {}", entry.key,
                      hexagonal ? "hexagonal" : "satellite"));
    }
  return sc.target_spec.validate().withContext(f.path()).at(f.location());
}

const Table<Scenario>& meshTable() {
  static const Table<Scenario> table =
      Table<Scenario>("the mesh's options {scale, recentre, rpy_deg, smoothing_angle_deg}")
          .optional("scale", via(&Scenario::mesh_options,
                                 schema::number(&MeshLoadOptions::scale, Range::leftOpen(0, 1e6))))
          .optional("recentre",
                    via(&Scenario::mesh_options, schema::flag(&MeshLoadOptions::recentre)))
          .optional("rpy_deg", rpy(&Scenario::mesh_rotation))
          .optional("smoothing_angle_deg",
                    via(&Scenario::mesh_options,
                        degrees(&MeshLoadOptions::smoothing_angle, Range::closed(0, 180, "deg"))));
  return table;
}

const Table<Scenario>& targetAttitudeTable() {
  static const Table<Scenario> table =
      Table<Scenario>("the target's attitude {mode, rpy_deg, rate_deg_s, inertia}")
          .optional("mode", schema::named(&Scenario::target_attitude,
                                          {{"lvlh", TargetAttitudeKind::kLvlh},
                                           {"inertial", TargetAttitudeKind::kInertial},
                                           {"tumbling", TargetAttitudeKind::kTumbling}}))
          .optional("rpy_deg", rpy(&Scenario::target_initial))
          .optional("rate_deg_s",
                    [](const Field& f, Scenario& sc) -> Status {
                      CDFF_RETURN_IF_ERROR(readVec3(f, sc.target_rate, kDeg));
                      if (sc.target_rate.norm() > 0 &&
                          sc.target_attitude != TargetAttitudeKind::kTumbling)
                        return f.fail("no rate unless target.attitude.mode is tumbling",
                                      "a rate of a target that does not tumble");
                      return Status::ok();
                    })
          .optional("inertia", [](const Field& f, Scenario& sc) -> Status {
            Eigen::Vector3d inertia;
            CDFF_RETURN_IF_ERROR(readVec3(f, inertia));
            if (inertia.minCoeff() <= 0)
              return f.fail("three positive principal moments of inertia in kg m^2",
                            "not all positive");
            sc.target_inertia = inertia;
            return Status::ok();
          });
  return table;
}

}  // namespace

const Table<ScenarioDraft>& targetTable() {
  static const Table<ScenarioDraft> table =
      Table<ScenarioDraft>("the target {model, procedural, mesh, attitude}")
          .optional("model", readModel)
          .optional("procedural", inScenario(readProcedural))
          .optional("mesh", inScenario([](const Field& f, Scenario& sc) {
                      return meshTable().read(f, sc);
                    }))
          .optional("attitude", inScenario([](const Field& f, Scenario& sc) {
                      return targetAttitudeTable().read(f, sc);
                    }));
  return table;
}

}  // namespace cdff::egse::scenario_reader
