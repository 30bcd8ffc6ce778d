#pragma once
// The procedural target satellite and servicer mock-up.
//
// The target is the seed's "typical satellite, with solar panel, adapter ring and launcher
// bracket interface" (§2.2.5.3): a box bus wrapped in gold MLI with white radiators, two solar
// wings on yokes, a launch adapter ring with its clamp-band flange and launcher brackets on the
// aft face, an antenna dish on a mast, and four thruster nozzles around the ring.
//
// Target body frame `target` (REP-103: x forward, y left, z up), origin at the bus centre:
//   -x face: the aft deck with the launch adapter ring (its axis is the x axis), the launcher
//            bracket interface and the thrusters; the natural capture interface for a servicer,
//   +-y:     the solar wings (along y) on yokes, radiators on the +-y faces,
//   +z face: the antenna dish, looking along +z.
// Its parts (TargetModel::parts): bus, wing_left (+y), wing_right (-y), adapter_ring,
// launcher_brackets, thrusters, antenna.
//
// The second target (TargetKind::kHexagonal) differs from the first in every respect a tracker
// could rely on: a hexagonal bus 1.6 m across its corners and 1.4 m long along x, a single solar
// wing on +y (no mirror symmetry), a boom with a magnetometer on the upper -y side, an apogee
// engine's nozzle on the -x face (where the first has its adapter ring), and a star tracker off
// the centre of the +x face. Parts: bus, solar_wing, boom, nozzle, star_tracker.

#include <cstdint>

#include <Eigen/Core>

#include "cdff/egse/model.hpp"

namespace cdff::egse {

/// The second procedural target, a hexagonal satellite (see above).
struct HexagonalTargetSpec {
  double bus_diameter = 1.6;             // m, across the hexagon's corners (in the y-z plane)
  double bus_length = 1.4;               // m, along x
  int panels = 3;                        // on the single wing (+y)
  Eigen::Vector2d panel_size{1.1, 0.9};  // m, along the wing (y) and across it (x)
  double panel_thickness = 0.03;         // m
  double yoke_length = 0.4;              // m from the bus's +y face to the first panel
  double wing_angle = 0.0;               // rad about the wing axis (0: cells facing +z)
  double boom_length = 1.5;              // m, the magnetometer boom (0: none)
  double nozzle_length = 0.3;            // m, the apogee engine's bell on -x (0: none)
  double nozzle_exit_diameter = 0.4;     // m
  int segments = 32;                     // tessellation of round parts

  /// Ok when every size is positive and finite and the nozzle fits the -x face.
  Status validate() const;
};

enum class TargetKind { kSatellite, kHexagonal };

struct TargetSpec {
  /// Which generator: the box satellite (the fields below) or the hexagonal one (`hexagonal`).
  TargetKind kind = TargetKind::kSatellite;
  HexagonalTargetSpec hexagonal;
  Eigen::Vector3d bus_size{1.2, 1.0, 1.0};  // m, along x, y, z
  // Solar wings
  bool solar_wings = true;
  int panels_per_wing = 2;
  Eigen::Vector2d panel_size{1.0, 0.8};  // m, along the wing (y) and across it (x)
  double panel_thickness = 0.03;         // m
  double panel_gap = 0.03;               // m between panels and between the yoke and panel 1
  double yoke_length = 0.35;             // m from the bus face to the first panel
  double wing_angle = 0.0;               // rad about the wing axis (0: cells facing +z)
  // Launch adapter ring on the -x face
  bool adapter_ring = true;
  double ring_diameter = 0.60;       // m, outer diameter of the ring's wall
  double ring_height = 0.12;         // m, along -x
  double ring_wall = 0.02;           // m
  double ring_flange_width = 0.035;  // m, the clamp-band flange at the ring's end
  bool launcher_brackets = true;
  // Antenna dish on the +z face
  bool antenna = true;
  double dish_diameter = 0.6;  // m
  double dish_depth = 0.09;    // m
  double mast_height = 0.25;   // m
  // Thrusters on the -x face
  bool thrusters = true;
  double thruster_length = 0.08;         // m
  double thruster_exit_diameter = 0.05;  // m
  int segments = 32;                     // tessellation of round parts

  /// Ok when every size is positive and finite and the parts fit the bus.
  Status validate() const;
};

/// The procedural target satellite in its body frame `target` (`spec.kind` is not read).
Result<TargetModel> makeTargetSatellite(const TargetSpec& spec = {});
/// The hexagonal satellite in its body frame `target`.
Result<TargetModel> makeHexagonalSatellite(const HexagonalTargetSpec& spec = {});
/// The target `spec.kind` selects.
Result<TargetModel> makeProceduralTarget(const TargetSpec& spec);

struct ServicerSpec {
  Eigen::Vector3d bus_size{0.8, 0.8, 0.8};  // m
  double probe_length = 0.5;                // m, a capture probe along +x (0: none)
  double probe_diameter = 0.04;             // m
  int segments = 24;

  Status validate() const;
};

/// A small servicer mock-up in its body frame `servicer` (front face at x = bus_size.x / 2, where
/// the sensors are mounted), with a capture probe along +x for close-range scenes.
Result<TargetModel> makeServicerMockup(const ServicerSpec& spec = {});

}  // namespace cdff::egse
