// The second procedural target: a hexagonal satellite with one wing, a boom and an apogee
// engine (procedural.hpp).
#include <cmath>

#include "cdff/egse/procedural.hpp"
#include "cdff/egse/procedural_placement.hpp"

namespace cdff::egse {

namespace {

Status positiveLength(double value, const char* name) {
  if (!std::isfinite(value) || value <= 0.0)
    return invalidParameter(
        "hexagonal target: '{}' = {} is invalid; expected a positive length in m", name, value);
  return Status::ok();
}

Status nonNegativeLength(double value, const char* name) {
  if (!std::isfinite(value) || value < 0.0)
    return invalidParameter("hexagonal target: '{}' = {} is invalid; expected a length >= 0 m",
                            name, value);
  return Status::ok();
}

using placement::at;
using placement::zTo;

// The hexagon's corner k in the y-z plane at `x`: corners at 30 + 60 k degrees from +y towards
// +z, so that two flats face +y and -y.
Eigen::Vector3d corner(double x, double radius, int k) {
  const double a = (30.0 + 60.0 * k) * M_PI / 180.0;
  return {x, radius * std::cos(a), radius * std::sin(a)};
}

// The flat j's outward direction (in the y-z plane, 60 j degrees from +y towards +z).
Eigen::Vector3d flatNormal(int j) {
  const double a = 60.0 * j * M_PI / 180.0;
  return {0.0, std::cos(a), std::sin(a)};
}

// A planar polygon whose outward side is `outward` (the points' order reversed if needed).
void addFacing(ModelBuilder& b, std::vector<Eigen::Vector3d> points, const Eigen::Vector3d& outward,
               std::uint16_t material) {
  const Eigen::Vector3d n = (points[1] - points[0]).cross(points[2] - points[0]);
  if (n.dot(outward) < 0) std::reverse(points.begin(), points.end());
  b.addPolygon(points, material);
}

void addBus(ModelBuilder& b, const HexagonalTargetSpec& spec) {
  b.beginPart("bus");
  const auto gold = b.material(MaterialId::kMliGold);
  const auto silver = b.material(MaterialId::kMliSilver);
  const auto radiator = b.material(MaterialId::kRadiator);
  const double R = spec.bus_diameter / 2, hx = spec.bus_length / 2;
  // Side flats: radiators on +-y (flats 0 and 3), gold MLI elsewhere.
  for (int j = 0; j < 6; ++j) {
    const int k0 = (j + 5) % 6, k1 = j;  // the corners either side of flat j
    addFacing(b, {corner(-hx, R, k0), corner(-hx, R, k1), corner(hx, R, k1), corner(hx, R, k0)},
              flatNormal(j), j % 3 == 0 ? radiator : gold);
  }
  // End faces: silver MLI.
  std::vector<Eigen::Vector3d> front, back;
  for (int k = 0; k < 6; ++k) {
    front.push_back(corner(hx, R, k));
    back.push_back(corner(-hx, R, k));
  }
  addFacing(b, front, Eigen::Vector3d::UnitX(), silver);
  addFacing(b, back, -Eigen::Vector3d::UnitX(), silver);
}

void addWing(ModelBuilder& b, const HexagonalTargetSpec& spec) {
  b.beginPart("solar_wing");
  const auto structure = b.material(MaterialId::kStructure);
  const auto panel_back = b.material(MaterialId::kPanelBack);
  const auto cells = b.material(MaterialId::kSolarCell);
  const double apothem = spec.bus_diameter / 2 * std::cos(M_PI / 6);
  const double gap = 0.03;
  b.addBox(at({0, apothem + spec.yoke_length / 2, 0}), {0.02, spec.yoke_length / 2, 0.02},
           structure);
  const Eigen::Matrix3d tilt =
      Eigen::AngleAxisd(spec.wing_angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
  double y = apothem + spec.yoke_length + gap;
  for (int p = 0; p < spec.panels; ++p) {
    const Eigen::Vector3d half(spec.panel_size.y() / 2, spec.panel_size.x() / 2,
                               spec.panel_thickness / 2);
    b.addBox(at({0, y + spec.panel_size.x() / 2, 0}, tilt), half,
             {panel_back, panel_back, panel_back, panel_back, panel_back, cells});
    y += spec.panel_size.x() + gap;
  }
}

// A boom from the upper -y flat (flat 2), perpendicular to it, carrying a magnetometer box.
void addBoom(ModelBuilder& b, const HexagonalTargetSpec& spec) {
  b.beginPart("boom");
  const auto structure = b.material(MaterialId::kStructure);
  const auto silver = b.material(MaterialId::kMliSilver);
  const double apothem = spec.bus_diameter / 2 * std::cos(M_PI / 6);
  const Eigen::Vector3d direction = flatNormal(2);
  const Eigen::Vector3d base = Eigen::Vector3d(0.25 * spec.bus_length, 0, 0) + apothem * direction;
  const double r = 0.025;
  b.addRevolution(at(base, zTo(direction)), {{r, 0.0}, {r, spec.boom_length}}, 12, structure, true);
  const double box = 0.06;
  b.addBox(at(base + (spec.boom_length + box) * direction, zTo(direction)), {box, box, box},
           silver);
}

// The apogee engine's bell on the -x face's centre, and its throat's housing.
void addNozzle(ModelBuilder& b, const HexagonalTargetSpec& spec) {
  b.beginPart("nozzle");
  const auto thruster = b.material(MaterialId::kThruster);
  const auto structure = b.material(MaterialId::kStructure);
  const Eigen::Matrix3d R = zTo(-Eigen::Vector3d::UnitX());
  const Eigen::Vector3d c(-spec.bus_length / 2, 0, 0);
  const double re = spec.nozzle_exit_diameter / 2, rt = re * 0.3, L = spec.nozzle_length;
  const double housing = 0.06;
  b.addRevolution(at(c, R), {{rt * 1.6, 0.0}, {rt * 1.6, housing}}, spec.segments, structure, true);
  b.addAnnulus(at(c + Eigen::Vector3d(-housing, 0, 0), R), rt, rt * 1.6, spec.segments, structure,
               true);
  const Eigen::Vector3d throat = c + Eigen::Vector3d(-housing, 0, 0);
  b.addRevolution(at(throat, R), {{rt, 0.0}, {re * 0.75, 0.5 * L}, {re, L}}, spec.segments,
                  thruster, true);
  b.addRevolution(at(throat, R), {{rt * 0.9, 0.0}, {re * 0.72, 0.5 * L}, {re * 0.96, L}},
                  spec.segments, thruster, false);
  b.addAnnulus(at(throat + Eigen::Vector3d(-L, 0, 0), R), re * 0.96, re, spec.segments, thruster,
               true);
}

// A star tracker off the centre of the +x face: a box with its baffle.
void addStarTracker(ModelBuilder& b, const HexagonalTargetSpec& spec) {
  b.beginPart("star_tracker");
  const auto structure = b.material(MaterialId::kStructure);
  const auto antenna = b.material(MaterialId::kAntenna);
  const double R = spec.bus_diameter / 2;
  const Eigen::Vector3d base(spec.bus_length / 2, 0.35 * R, -0.4 * R);
  b.addBox(at(base + Eigen::Vector3d(0.06, 0, 0)), {0.06, 0.07, 0.07}, structure);
  const Eigen::Matrix3d R_out = zTo(Eigen::Vector3d::UnitX());
  b.addRevolution(at(base + Eigen::Vector3d(0.12, 0, 0), R_out), {{0.04, 0.0}, {0.06, 0.1}}, 16,
                  antenna, true);
  b.addRevolution(at(base + Eigen::Vector3d(0.12, 0, 0), R_out), {{0.036, 0.0}, {0.056, 0.1}}, 16,
                  antenna, false);
  b.addAnnulus(at(base + Eigen::Vector3d(0.22, 0, 0), R_out), 0.056, 0.06, 16, antenna, true);
}

}  // namespace

Status HexagonalTargetSpec::validate() const {
  CDFF_RETURN_IF_ERROR(positiveLength(bus_diameter, "bus_diameter"));
  CDFF_RETURN_IF_ERROR(positiveLength(bus_length, "bus_length"));
  if (panels < 0 || panels > 8)
    return invalidParameter("hexagonal target: 'panels' = {} is out of range; expected [0, 8]",
                            panels);
  if (panels > 0) {
    CDFF_RETURN_IF_ERROR(positiveLength(panel_size.x(), "panel_size[0]"));
    CDFF_RETURN_IF_ERROR(positiveLength(panel_size.y(), "panel_size[1]"));
    CDFF_RETURN_IF_ERROR(positiveLength(panel_thickness, "panel_thickness"));
    CDFF_RETURN_IF_ERROR(positiveLength(yoke_length, "yoke_length"));
  }
  if (!std::isfinite(wing_angle))
    return invalidParameter("hexagonal target: 'wing_angle' = {} is not finite", wing_angle);
  CDFF_RETURN_IF_ERROR(nonNegativeLength(boom_length, "boom_length"));
  CDFF_RETURN_IF_ERROR(nonNegativeLength(nozzle_length, "nozzle_length"));
  if (nozzle_length > 0) {
    CDFF_RETURN_IF_ERROR(positiveLength(nozzle_exit_diameter, "nozzle_exit_diameter"));
    // The bell must stand on the -x face: within the hexagon's inscribed circle.
    const double apothem = bus_diameter / 2 * std::cos(M_PI / 6);
    if (nozzle_exit_diameter / 2 > apothem)
      return invalidParameter(
          "hexagonal target: 'nozzle_exit_diameter' = {} m does not fit the -x face ({} m across "
          "its flats); expected at most {} m",
          nozzle_exit_diameter, 2 * apothem, 2 * apothem);
  }
  if (segments < 8 || segments > 256)
    return invalidParameter("hexagonal target: 'segments' = {} is out of range; expected [8, 256]",
                            segments);
  return Status::ok();
}

Result<TargetModel> makeHexagonalSatellite(const HexagonalTargetSpec& spec) {
  CDFF_RETURN_IF_ERROR(spec.validate());
  ModelBuilder b("hexagonal_satellite");
  addBus(b, spec);
  if (spec.panels > 0) addWing(b, spec);
  if (spec.boom_length > 0) addBoom(b, spec);
  if (spec.nozzle_length > 0) addNozzle(b, spec);
  addStarTracker(b, spec);
  TargetModel model = b.build();
  CDFF_RETURN_IF_ERROR(model.validate());
  return model;
}

}  // namespace cdff::egse
