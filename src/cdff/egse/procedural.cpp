#include "cdff/egse/procedural.hpp"

#include <cmath>

#include "cdff/egse/procedural_placement.hpp"

namespace cdff::egse {

namespace {

Status positive(double value, const char* name) {
  if (!std::isfinite(value) || value <= 0.0)
    return invalidParameter("target model: '{}' = {} is invalid; expected a positive length in m",
                            name, value);
  return Status::ok();
}

using placement::at;
using placement::zTo;

}  // namespace

Status TargetSpec::validate() const {
  if (kind == TargetKind::kHexagonal) return hexagonal.validate();
  CDFF_RETURN_IF_ERROR(positive(bus_size.x(), "bus_size[0]"));
  CDFF_RETURN_IF_ERROR(positive(bus_size.y(), "bus_size[1]"));
  CDFF_RETURN_IF_ERROR(positive(bus_size.z(), "bus_size[2]"));
  if (solar_wings) {
    if (panels_per_wing < 1 || panels_per_wing > 8)
      return invalidParameter(
          "target model: 'panels_per_wing' = {} is out of range; expected [1, 8]", panels_per_wing);
    CDFF_RETURN_IF_ERROR(positive(panel_size.x(), "panel_size[0]"));
    CDFF_RETURN_IF_ERROR(positive(panel_size.y(), "panel_size[1]"));
    CDFF_RETURN_IF_ERROR(positive(panel_thickness, "panel_thickness"));
    CDFF_RETURN_IF_ERROR(positive(yoke_length, "yoke_length"));
    if (!std::isfinite(panel_gap) || panel_gap < 0)
      return invalidParameter("target model: 'panel_gap' = {} is invalid; expected >= 0 m",
                              panel_gap);
  }
  if (adapter_ring) {
    CDFF_RETURN_IF_ERROR(positive(ring_diameter, "ring_diameter"));
    CDFF_RETURN_IF_ERROR(positive(ring_height, "ring_height"));
    CDFF_RETURN_IF_ERROR(positive(ring_wall, "ring_wall"));
    if (ring_wall * 2 >= ring_diameter)
      return invalidParameter(
          "target model: 'ring_wall' = {} m is too thick for 'ring_diameter' = {} m", ring_wall,
          ring_diameter);
    if (ring_diameter + 2 * ring_flange_width > std::min(bus_size.y(), bus_size.z()) + 1e-9)
      return invalidParameter(
          "target model: 'ring_diameter' = {} m (+ flange) does not fit the bus's -x face ({} x {} "
          "m); expected at most {} m",
          ring_diameter, bus_size.y(), bus_size.z(),
          std::min(bus_size.y(), bus_size.z()) - 2 * ring_flange_width);
  }
  if (antenna) {
    CDFF_RETURN_IF_ERROR(positive(dish_diameter, "dish_diameter"));
    CDFF_RETURN_IF_ERROR(positive(dish_depth, "dish_depth"));
    CDFF_RETURN_IF_ERROR(positive(mast_height, "mast_height"));
  }
  if (thrusters) {
    CDFF_RETURN_IF_ERROR(positive(thruster_length, "thruster_length"));
    CDFF_RETURN_IF_ERROR(positive(thruster_exit_diameter, "thruster_exit_diameter"));
  }
  if (segments < 8 || segments > 256)
    return invalidParameter("target model: 'segments' = {} is out of range; expected [8, 256]",
                            segments);
  return Status::ok();
}

namespace {

// The target's materials, added to the builder in this order.
struct TargetMaterials {
  std::uint16_t gold, silver, radiator, cells, panel_back, ring, structure, antenna, thruster;

  explicit TargetMaterials(ModelBuilder& b)
      : gold(b.material(MaterialId::kMliGold)),
        silver(b.material(MaterialId::kMliSilver)),
        radiator(b.material(MaterialId::kRadiator)),
        cells(b.material(MaterialId::kSolarCell)),
        panel_back(b.material(MaterialId::kPanelBack)),
        ring(b.material(MaterialId::kAdapterRing)),
        structure(b.material(MaterialId::kStructure)),
        antenna(b.material(MaterialId::kAntenna)),
        thruster(b.material(MaterialId::kThruster)) {}
};

// Two wings of panels on yokes from the +-y faces, cells on +z (sun side). h: the bus's half
// size.
void addSolarWings(ModelBuilder& b, const TargetSpec& spec, const Eigen::Vector3d& h,
                   const TargetMaterials& m) {
  const auto structure = m.structure, panel_back = m.panel_back, cells = m.cells;
  for (int side : {-1, 1}) {
    b.beginPart(side > 0 ? "wing_left" : "wing_right");
    // Yoke: a thin strut from the +-y face to the first panel.
    const double yoke_y = h.y() + spec.yoke_length / 2;
    b.addBox(at({0, side * yoke_y, 0}), {0.02, spec.yoke_length / 2, 0.02}, structure);
    const Eigen::Matrix3d tilt =
        Eigen::AngleAxisd(spec.wing_angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
    double y = h.y() + spec.yoke_length + spec.panel_gap;
    for (int p = 0; p < spec.panels_per_wing; ++p) {
      const Eigen::Vector3d centre(0, side * (y + spec.panel_size.x() / 2), 0);
      const Eigen::Vector3d half(spec.panel_size.y() / 2, spec.panel_size.x() / 2,
                                 spec.panel_thickness / 2);
      // Cells on +z (sun side), substrate elsewhere.
      b.addBox(at(centre, tilt), half,
               {panel_back, panel_back, panel_back, panel_back, panel_back, cells});
      y += spec.panel_size.x() + spec.panel_gap;
    }
  }
}

// The launcher adapter ring on the aft deck, and its brackets.
void addAdapterRing(ModelBuilder& b, const TargetSpec& spec, const Eigen::Vector3d& h,
                    const TargetMaterials& m) {
  const auto ring = m.ring, structure = m.structure;
  // The ring's axis along -x, starting on the aft deck.
  const Eigen::Matrix3d R = zTo(-Eigen::Vector3d::UnitX());
  const Eigen::Isometry3d base = at({-h.x(), 0, 0}, R);
  const double ro = spec.ring_diameter / 2, ri = ro - spec.ring_wall;
  const double hr = spec.ring_height, flange = spec.ring_flange_width;
  const double lip = std::min(0.02, hr / 3);
  b.beginPart("adapter_ring");
  b.addRevolution(base, {{ro, 0.0}, {ro, hr - lip}}, spec.segments, ring, true);
  b.addAnnulus(at(base * Eigen::Vector3d(0, 0, hr - lip), R), ro, ro + flange, spec.segments, ring,
               false);
  b.addRevolution(base, {{ro + flange, hr - lip}, {ro + flange, hr}}, spec.segments, ring, true);
  b.addAnnulus(at(base * Eigen::Vector3d(0, 0, hr), R), ri, ro + flange, spec.segments, ring, true);
  b.addRevolution(base, {{ri, 0.0}, {ri, hr}}, spec.segments, ring, false);
  if (spec.launcher_brackets) {
    b.beginPart("launcher_brackets");
    // Four brackets on the deck, outside the ring, at 45 degrees.
    for (int k = 0; k < 4; ++k) {
      const double a = M_PI / 4 + k * M_PI / 2;
      const double r = ro + flange + 0.05;
      const Eigen::Vector3d c(-h.x() - 0.03, r * std::cos(a), r * std::sin(a));
      const Eigen::Matrix3d Rb = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix();
      b.addBox(at(c, Rb), {0.03, 0.04, 0.02}, structure);
    }
  }
}

// Four thruster bells on the aft deck's corners.
void addThrusters(ModelBuilder& b, const TargetSpec& spec, const Eigen::Vector3d& h,
                  const TargetMaterials& m) {
  const auto thruster = m.thruster;
  b.beginPart("thrusters");
  const Eigen::Matrix3d R = zTo(-Eigen::Vector3d::UnitX());
  const double inset = 0.08;
  for (int sy : {-1, 1})
    for (int sz : {-1, 1}) {
      const Eigen::Vector3d c(-h.x(), sy * (h.y() - inset), sz * (h.z() - inset));
      const double re = spec.thruster_exit_diameter / 2, rt = re * 0.35, L = spec.thruster_length;
      // A bell: throat at the deck, widening to the exit.
      b.addRevolution(at(c, R), {{rt, 0.0}, {re * 0.7, 0.6 * L}, {re, L}}, 16, thruster, true);
      b.addRevolution(at(c, R), {{rt * 0.8, 0.0}, {re * 0.65, 0.6 * L}, {re * 0.95, L}}, 16,
                      thruster, false);
      b.addAnnulus(at(c + Eigen::Vector3d(-L, 0, 0), R), re * 0.95, re, 16, thruster, true);
    }
}

// A mast on the +z face carrying a parabolic dish.
void addAntenna(ModelBuilder& b, const TargetSpec& spec, const Eigen::Vector3d& h,
                const TargetMaterials& m) {
  const auto antenna = m.antenna, structure = m.structure;
  b.beginPart("antenna");
  // Mast from the +z face, then a parabolic dish opening towards +z.
  const double mast_r = 0.025;
  const Eigen::Vector3d base(0.15 * spec.bus_size.x(), 0, h.z());
  b.addRevolution(at(base), {{mast_r, 0.0}, {mast_r, spec.mast_height}}, 12, structure, true);
  const double R = spec.dish_diameter / 2, depth = spec.dish_depth;
  const Eigen::Isometry3d dish_pose = at(base + Eigen::Vector3d(0, 0, spec.mast_height));
  std::vector<Eigen::Vector2d> profile;
  const int rings = 6;
  for (int i = 0; i <= rings; ++i) {
    const double r = R * i / rings;
    profile.emplace_back(r, depth * (r / R) * (r / R));
  }
  // The concave reflector (normals up, towards the axis) and its convex back.
  b.addRevolution(dish_pose, profile, spec.segments, antenna, false);
  std::vector<Eigen::Vector2d> back;
  for (const auto& p : profile) back.emplace_back(p.x(), p.y() - 0.006);
  b.addRevolution(dish_pose, back, spec.segments, structure, true);
  // The rim joining them.
  b.addRevolution(dish_pose, {{R, depth - 0.006}, {R, depth}}, spec.segments, structure, true);
}

}  // namespace

Result<TargetModel> makeTargetSatellite(const TargetSpec& spec) {
  TargetSpec satellite = spec;
  satellite.kind = TargetKind::kSatellite;
  CDFF_RETURN_IF_ERROR(satellite.validate());
  ModelBuilder b("target_satellite");
  const TargetMaterials m(b);
  const Eigen::Vector3d h = spec.bus_size / 2;
  // Bus: -x aft deck in silver MLI (the ring stands on it), +x and +-z in gold MLI, +-y
  // radiators.
  b.beginPart("bus");
  b.addBox(Eigen::Isometry3d::Identity(), h,
           {m.silver, m.gold, m.radiator, m.radiator, m.gold, m.gold});
  if (spec.solar_wings) addSolarWings(b, spec, h, m);
  if (spec.adapter_ring) addAdapterRing(b, spec, h, m);
  if (spec.thrusters) addThrusters(b, spec, h, m);
  if (spec.antenna) addAntenna(b, spec, h, m);
  TargetModel model = b.build();
  CDFF_RETURN_IF_ERROR(model.validate());
  return model;
}

Result<TargetModel> makeProceduralTarget(const TargetSpec& spec) {
  if (spec.kind == TargetKind::kHexagonal) return makeHexagonalSatellite(spec.hexagonal);
  return makeTargetSatellite(spec);
}

Status ServicerSpec::validate() const {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(bus_size[i]) || bus_size[i] <= 0)
      return invalidParameter("servicer model: 'bus_size[{}]' = {} is invalid; expected > 0 m", i,
                              bus_size[i]);
  if (!std::isfinite(probe_length) || probe_length < 0)
    return invalidParameter("servicer model: 'probe_length' = {} is invalid; expected >= 0 m",
                            probe_length);
  if (probe_length > 0 && (!std::isfinite(probe_diameter) || probe_diameter <= 0))
    return invalidParameter("servicer model: 'probe_diameter' = {} is invalid; expected > 0 m",
                            probe_diameter);
  return Status::ok();
}

Result<TargetModel> makeServicerMockup(const ServicerSpec& spec) {
  CDFF_RETURN_IF_ERROR(spec.validate());
  ModelBuilder b("servicer_mockup");
  const auto body = b.material(MaterialId::kServicerBody);
  const auto structure = b.material(MaterialId::kStructure);
  const Eigen::Vector3d h = spec.bus_size / 2;
  b.addBox(Eigen::Isometry3d::Identity(), h, body);
  if (spec.probe_length > 0) {
    const Eigen::Matrix3d R = zTo(Eigen::Vector3d::UnitX());
    // On the front face's centre line, below the cameras, so that they see its tip.
    const Eigen::Isometry3d base = at({h.x(), 0, 0}, R);
    const double r = spec.probe_diameter / 2, L = spec.probe_length;
    b.addRevolution(base, {{r, 0.0}, {r, L - r}, {0.0, L}}, spec.segments, structure, true);
  }
  TargetModel model = b.build();
  model.mesh.frame_id = "servicer";
  CDFF_RETURN_IF_ERROR(model.validate());
  return model;
}

}  // namespace cdff::egse
