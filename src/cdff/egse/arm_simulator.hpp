#pragma once
// The servicer's manipulator touching the target (haptic scanning, docs/haptic-scanning.md): a
// serial arm read from URDF (cdff/kinematics), position-controlled along random collision paths
// towards the target, its joint encoders, a 6-axis force/torque sensor at the wrist and a
// spherical tool tip in contact with the target's mesh.
//
// Motion: the arm is kinematic (its servo loop is ideal: the joints take the inverse kinematics
// of the commanded tip pose at every sample, and the arm's self-motion is drawn back towards the
// home posture at `posture_rate`, so that the redundant joint does not drift to a limit). A
// collision path aims at a random point of the target's surface within reach and facing the arm:
// the tip's centre starts `standoff` outside the point, along an approach axis tilted from the
// surface normal by up to `max_tilt`, moves along it (fast, then slowly over the last `slow_zone`)
// until the contact force reaches `press_force`, holds `hold` seconds and retracts to the start.
// Between paths the arm moves in joint space (a transit to the start's posture solved from home,
// so that the arm does not wander from path to path and no straight line crosses a singularity;
// paths whose transit or approach would graze the target are drawn again); when no path can be
// reached from the arm's posture, it goes home: first back along the tool's axis (a straight line
// that moves away from the target), then in joint space along a motion whose tip keeps
// `homing_clearance` from the target, both checked before they are taken. Paths are defined in the
// target frame, so the arm follows a moving target. Only the tip touches the target: the links and
// the probe's shaft are not tested for contact.
//
// Contact: the tip sphere (radius r) against the mesh: penetration d = r - |c - p|, with p the
// surface point nearest to the centre c (RayCaster::closestPoint); normal force
// k d + b d' (never pulling), and Coulomb friction mu N against the tip's sliding velocity
// (regularised below 0.1 mm/s, where it would chatter), both from the relative motion in the
// target frame. The force acts at p.
//
// Sensors: encoders with white noise, then quantised to 2^bits counts per turn; the wrench on
// the tool at the sensor's origin in its frame (no gravity in orbit; the tool's inertial load,
// a few hundredths of a newton in these motions, is not modelled), with a turn-on bias drawn
// per run, white noise per sample and clipping at the full-scale range. Every draw comes from
// streams of the run's seed (rng.hpp), so a seed gives the same run everywhere.
//
// Default figures: an ATI Gamma-class sensor (SI-65-5: +-65 N, +-5 N m; noise of a few
// hundredths of a newton and about a millinewton-metre; turn-on offsets of a fraction of a
// newton), 20-bit absolute encoders with 20 urad of noise, a contact stiffness of 1e5 N/m (the
// probe's and panel's local compliance: 0.1 mm at 10 N) and a friction coefficient of 0.3
// (metal on aluminium or MLI, dry). Assumptions, not a datasheet: docs/haptic-scanning.md.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/egse/model.hpp"
#include "cdff/egse/raycaster.hpp"
#include "cdff/egse/rng.hpp"
#include "cdff/kinematics/arm_model.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/sensors.hpp"

namespace cdff::egse {

struct ForceTorqueSpec {
  double force_noise = 0.02;        // N, 1 sigma per axis per sample
  double torque_noise = 0.001;      // N m
  double force_bias_sigma = 0.5;    // N, turn-on bias per axis (1 sigma)
  double torque_bias_sigma = 0.02;  // N m
  double force_range = 65;          // N, full scale per axis
  double torque_range = 5;          // N m
  bool noise = true;                // false: exact truth (no bias, no noise)
};

struct EncoderSpec {
  double noise = 2e-5;  // rad, 1 sigma per sample
  int bits = 20;        // counts per turn 2^bits
};

struct ContactSpec {
  double stiffness = 1e5;  // N/m
  double damping = 20;     // N s/m
  double friction = 0.3;   // Coulomb coefficient
};

struct CollisionPathSpec {
  double standoff = 0.02;         // m, from the touching position to the path's start
  double slow_zone = 0.003;       // m, approached at slow_speed
  double fast_speed = 0.1;        // m/s
  double slow_speed = 0.01;       // m/s
  double press_force = 10;        // N, the normal force that ends the approach
  double hold = 0.1;              // s
  double max_overtravel = 0.005;  // m past the expected surface before the path gives up
  double max_tilt = 0.35;         // rad between the approach axis and the surface normal
  double transit_speed = 0.5;     // m/s of the tip on a retreat
  double transit_rate = 1.0;      // rad/s, the fastest joint's top speed between paths
  // m from reach_centre: farther is not aimed at (the arm stretched out, 1.07 m, is singular).
  double reach = 0.95;
  Eigen::Vector3d reach_centre{0, 0, 0.35};  // m, base frame (the servicer arm's shoulder)
  int max_draws = 2000;                      // draws of a path before the simulator gives up
  double homing_clearance = 0.03;            // m between the tip and the target on the way home
  // A scan of one area: paths aim only within region_radius of region_centre (target frame);
  // 0: anywhere on the target's surface.
  Eigen::Vector3d region_centre = Eigen::Vector3d::Zero();
  double region_radius = 0;  // m
};

struct ArmSpec {
  std::string description;  // URDF file
  std::string base_link = "base_link";
  std::string sensor_link = "ft_sensor";
  std::string tip_link = "tool_tip";
  double tip_radius = 0;     // m; 0: the tip link's collision sphere in the description
  std::vector<double> home;  // rad, the starting posture (empty: elbow bent, tool ahead)
  double rate = 1000;        // Hz, of the servo loop and of both sensors
  double posture_rate = 1;   // 1/s, the self-motion's return towards `home` (0: none)
  ForceTorqueSpec force_torque;
  EncoderSpec encoders;
  ContactSpec contact;
  CollisionPathSpec paths;

  Status validate() const;
};

/// One collision path, in the target frame.
struct CollisionPath {
  Eigen::Vector3d aim = Eigen::Vector3d::Zero();      // the surface point aimed at
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // its face's outward normal
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();    // approach axis, unit, out of the surface
  Eigen::Vector3d start = Eigen::Vector3d::Zero();    // the tip centre at the start
  Eigen::Vector3d touch = Eigen::Vector3d::Zero();    // the tip centre touching the aim
  Eigen::Quaterniond attitude = Eigen::Quaterniond::Identity();  // target_R_tip
  std::vector<double> start_joints;  // rad, the posture planned at the start
};

/// kRetreat and kHoming: the way home (back along the tool's axis, then in joint space).
enum class ArmPhase { kTransit, kApproach, kHold, kRetract, kRetreat, kHoming };

/// What the arm really did at a sample.
struct ArmTruth {
  std::vector<double> joints;                                    // rad
  Eigen::Isometry3d base_T_tip = Eigen::Isometry3d::Identity();  // the tip sphere's centre
  Eigen::Isometry3d base_T_sensor = Eigen::Isometry3d::Identity();
  bool in_contact = false;
  Eigen::Vector3d contact_point = Eigen::Vector3d::Zero();   // target frame, on the surface
  Eigen::Vector3d contact_normal = Eigen::Vector3d::Zero();  // target frame, out of the surface
  Eigen::Vector3d contact_force = Eigen::Vector3d::Zero();   // on the tool, target frame, N
  double normal_force = 0;                                   // N
  double penetration = 0;                                    // m
  int path = -1;                                             // the collision path's index
  ArmPhase phase = ArmPhase::kTransit;
  bool saturated = false;              // the wrench was clipped on some axis
  Vector6d wrench = Vector6d::Zero();  // the exact wrench at the sensor: force, torque
};

struct ArmSample {
  JointState joints;  // measured
  Wrench wrench;      // measured, frame: the sensor link
  ArmTruth truth;
};

class ArmSimulator {
 public:
  /// The arm of `spec` in front of `target`; paths and noise are drawn from `seed`.
  static Result<std::unique_ptr<ArmSimulator>> create(const ArmSpec& spec,
                                                      const TargetModel& target,
                                                      std::uint64_t seed);
  /// Advances one period of the servo loop with the target at `base_T_target` (the pose of the
  /// target in the arm's base frame at the new time) and samples the sensors. An error when no
  /// collision path can be drawn (the target out of reach).
  Result<ArmSample> step(const Eigen::Isometry3d& base_T_target);

  /// Ends the current path where it is and takes the arm home at the next step (back along the
  /// tool's axis, then in joint space, as when no path can be reached); the next path is drawn
  /// once home. Nothing happens before the first path or while the arm is already going home.
  void park() { park_ = true; }

  Timestamp time() const;
  const ArmSpec& spec() const { return spec_; }
  const kinematics::ArmModel& arm() const { return arm_; }
  /// The posture the arm starts from and returns to (rad).
  const std::vector<double>& home() const { return home_; }
  double tipRadius() const { return tip_radius_; }
  /// The tip sphere's centre in the sensor frame (fixed: the links between them are rigid).
  Eigen::Vector3d tipInSensor() const { return sensor_T_tip_.translation(); }
  /// The sensor's turn-on bias: force (N), torque (N m).
  const Vector6d& bias() const { return bias_; }
  /// Paths started so far, and those abandoned when the inverse kinematics failed on the way.
  int pathsStarted() const { return path_index_ + 1; }
  int pathsAbandoned() const { return abandoned_; }
  const CollisionPath& currentPath() const { return path_; }

 private:
  ArmSimulator() = default;
  Status weighTriangles();
  Status drawPath(const Eigen::Isometry3d& base_T_target);
  bool drawAim(Rng& rng, Eigen::Vector3d& aim, Eigen::Vector3d& normal) const;
  Result<CollisionPath> candidatePath(const Eigen::Isometry3d& base_T_target, Rng& rng) const;
  bool clear(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double clearance) const;
  bool movesAway(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double clearance) const;
  /// The joints at the end of a straight motion of the tip from `from` (target_T_tip, the
  /// current one) to `to` at the same attitude, the inverse kinematics chained over poses along
  /// it as the servo will; an error when a pose is out of reach or the joints jump between two.
  Result<std::vector<double>> reachAlong(const Eigen::Isometry3d& base_T_target,
                                         const Eigen::Isometry3d& from,
                                         const Eigen::Vector3d& to) const;
  /// The way home (kRetreat then kHoming) from the current posture; an error when none of the
  /// retreats leads to a joint-space motion clear of the target.
  Status planHoming(const Eigen::Isometry3d& base_T_target);
  /// True when the tip stays `clearance` off the target (beyond its radius) all along the
  /// joint-space motion from `from` to `to`.
  bool jointMoveClear(const Eigen::Isometry3d& base_T_target, const std::vector<double>& from,
                      const std::vector<double>& to, double clearance) const;
  double jointMoveDuration(const std::vector<double>& from, const std::vector<double>& to) const;
  void startJointMove(ArmPhase phase, const std::vector<double>& to);
  /// The joints of a joint-space motion (kTransit, kHoming: a cosine profile); moves the phase
  /// on at its end. An error when the transit's end is no longer reachable.
  Result<std::vector<double>> jointMove(const Eigen::Isometry3d& base_T_target);
  /// The commanded tip pose in the target frame for the current phase; moves the phase on.
  Eigen::Isometry3d command();
  void contact(const Eigen::Vector3d& centre, ArmTruth& truth);
  Wrench measureWrench(ArmTruth& truth);
  JointState measureJoints(const std::vector<double>& q);

  ArmSpec spec_;
  kinematics::ArmModel arm_;
  std::unique_ptr<RayCaster> caster_;
  TargetModel target_;
  std::vector<double> cumulative_area_;  // of the target's triangles, in order
  std::uint64_t seed_ = 0;
  double tip_radius_ = 0;
  Eigen::Isometry3d sensor_T_tip_ = Eigen::Isometry3d::Identity();
  Vector6d bias_ = Vector6d::Zero();
  std::vector<double> q_, home_, move_from_, move_to_;
  std::int64_t index_ = 0;
  Rng noise_;
  // The motion: the current path, its phase and the time spent in it.
  CollisionPath path_;
  int path_index_ = -1;
  int abandoned_ = 0;
  ArmPhase phase_ = ArmPhase::kTransit;
  double phase_time_ = 0;
  double travel_ = 0;                                               // m along the approach
  Eigen::Isometry3d transit_from_ = Eigen::Isometry3d::Identity();  // target_T_tip
  Eigen::Isometry3d retreat_to_ = Eigen::Isometry3d::Identity();    // target_T_tip
  double transit_duration_ = 0;
  std::optional<Eigen::Vector3d> last_centre_;  // target frame, for the sliding velocity
  double last_normal_force_ = 0;                // N, what the path's force control reads
  bool needs_path_ = false;                     // the current path is over or abandoned
  bool park_ = false;                           // park() was called
};

}  // namespace cdff::egse
