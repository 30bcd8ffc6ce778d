#pragma once
// A serial manipulator read from its URDF description (urdfdom) with its kinematics (Orocos KDL):
// the chain of joints from a base link to a tip link, their limits, forward kinematics and a
// position-level inverse. Shared by the simulator's arm (cdff/egse/arm_simulator.hpp) and the
// ForwardKinematics DFN, so that both read one description the same way.
//
// Not thread-safe: the solvers keep their work space between calls; give each thread its own
// ArmModel (load() is cheap for a chain of a few joints).

#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/types/sensors.hpp"
#include "cdff/types/status.hpp"

namespace cdff::kinematics {

/// A joint of the chain that moves (revolute, continuous or prismatic).
struct ArmJoint {
  std::string name;
  double lower = 0;     // rad or m; -inf for a continuous joint
  double upper = 0;     // rad or m; +inf for a continuous joint
  double velocity = 0;  // rad/s or m/s, the description's limit (0: none given)
  bool prismatic = false;
  int line = 0;  // of its <joint> element in the description (0: unknown)
};

/// A posture a redundant arm's self-motion is drawn towards while the tip holds its pose: each
/// inverse() moves the joints `fraction` (0 to 1) of the way from the seed towards `posture`,
/// projected on the Jacobian's null space (the motions that leave the tip where it is). A servo
/// at rate f drawing the posture back with rate k (1/s) takes fraction = 1 - exp(-k / f).
struct PosturePull {
  std::span<const double> posture;  // one per joint, in joints() order
  double fraction = 0;
};

class ArmModel {
 public:
  /// An empty chain (no joints; the tip is the base): load() or fromString() give a real one.
  ArmModel();
  ArmModel(ArmModel&&) noexcept;
  ArmModel& operator=(ArmModel&&) noexcept;
  ~ArmModel();

  /// Reads the URDF file `path` and the chain from `base_link` to `tip_link`. A file that is
  /// missing, is not XML or is not a valid URDF is an error naming the file (and the line where
  /// the XML parser or a named element locates it); so is a link that is absent or not below
  /// the base.
  static Result<ArmModel> load(const std::string& path, const std::string& base_link,
                               const std::string& tip_link);
  /// The same from the description's text; `source` names it in errors.
  static Result<ArmModel> fromString(const std::string& xml, const std::string& source,
                                     const std::string& base_link, const std::string& tip_link);

  const std::string& source() const { return source_; }
  const std::string& baseLink() const { return base_link_; }
  const std::string& tipLink() const { return tip_link_; }
  const std::vector<ArmJoint>& joints() const { return joints_; }
  std::size_t jointCount() const { return joints_.size(); }
  /// The radius of the tip link's collision sphere, or 0 when it has none.
  double tipSphereRadius() const { return tip_sphere_radius_; }

  /// base_T_tip at joint positions `q` (one per joint, in joints() order; not checked).
  Eigen::Isometry3d forward(std::span<const double> q) const;
  /// base_T_link for a link of the chain between base and tip (the tip itself included).
  Result<Eigen::Isometry3d> forwardTo(std::span<const double> q, const std::string& link) const;

  /// Ok when `q` has one finite value per joint within its limits widened by `margin` (rad; m
  /// for a prismatic joint: `linear_margin`); otherwise the error names the joint, its value and
  /// its limits (in degrees for a revolute joint). `what` names the input in the message.
  Status checkJoints(std::span<const double> q, double margin, const std::string& what,
                     double linear_margin = 0) const;
  /// The positions of `state` in joints() order, matched by name (extra names are ignored); a
  /// joint of the chain missing from `state` is an error naming it.
  Result<std::vector<double>> positionsOf(const JointState& state, const std::string& what) const;

  /// Joint positions that put the tip at `base_T_tip`, searched from `seed` (KDL's
  /// Levenberg-Marquardt; a 7-joint arm keeps the seed's elbow unless `pull` draws it towards a
  /// posture first). An error when the tip ends farther than `tolerance` (m, and rad) from the
  /// pose or a joint outside its limits.
  Result<std::vector<double>> inverse(const Eigen::Isometry3d& base_T_tip,
                                      std::span<const double> seed, double tolerance = 1e-6,
                                      const PosturePull* pull = nullptr) const;
  /// The geometric Jacobian at `q` (6 rows: the tip's linear then angular velocity in the base
  /// frame, per joint velocity).
  Eigen::Matrix<double, 6, Eigen::Dynamic> jacobian(std::span<const double> q) const;

 private:
  /// Damped Gauss-Newton steps from `q` (updated) towards the pose; the remaining error.
  Eigen::Matrix<double, 6, 1> newtonSteps(std::vector<double>& q,
                                          const Eigen::Isometry3d& base_T_tip,
                                          double tolerance) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string source_, base_link_, tip_link_;
  std::vector<ArmJoint> joints_;
  double tip_sphere_radius_ = 0;
};

}  // namespace cdff::kinematics
