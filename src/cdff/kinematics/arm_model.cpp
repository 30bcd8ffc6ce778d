// The URDF reading (urdfdom, with tinyxml for the lines of XML errors and of named elements) and
// the KDL chain built from it; the only translation unit that includes KDL and urdfdom.
#include "cdff/kinematics/arm_model.hpp"

#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <mutex>
#include <sstream>

#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainiksolverpos_lma.hpp>
#include <kdl/chainjnttojacsolver.hpp>

#include <Eigen/Cholesky>

namespace cdff::kinematics {

struct ArmModel::Impl {
  KDL::Chain chain;
  std::vector<std::string> segment_links;  // the child link of each segment, in chain order
  std::unique_ptr<KDL::ChainFkSolverPos_recursive> fk;
  std::unique_ptr<KDL::ChainIkSolverPos_LMA> ik;
  std::unique_ptr<KDL::ChainJntToJacSolver> jac;
};

namespace {

constexpr double kDeg = 180.0 / M_PI;

/// Collects what urdfdom reports through console_bridge while it parses (it returns only a null
/// model), so that the error can say why. console_bridge's handler is process-wide: the mutex
/// keeps two parses from swapping it under each other.
class CapturedLog final : public console_bridge::OutputHandler {
 public:
  CapturedLog() { console_bridge::useOutputHandler(this); }
  ~CapturedLog() override { console_bridge::restorePreviousOutputHandler(); }
  CapturedLog(const CapturedLog&) = delete;
  CapturedLog& operator=(const CapturedLog&) = delete;
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && first_error.empty())
      first_error = text;
  }
  std::string first_error;
};
std::mutex& consoleMutex() {
  static std::mutex m;
  return m;
}

/// The line of the <link> or <joint> element named `name` in `doc`, or 0.
int elementLine(const TiXmlDocument& doc, const std::string& name) {
  const TiXmlElement* robot = doc.RootElement();
  if (robot == nullptr) return 0;
  for (const TiXmlElement* e = robot->FirstChildElement(); e; e = e->NextSiblingElement()) {
    const char* n = e->Attribute("name");
    if (n != nullptr && name == n && (e->ValueStr() == "joint" || e->ValueStr() == "link"))
      return e->Row();
  }
  return 0;
}

/// urdfdom names the element it rejects in brackets ("joint [elbow] ..."): its line, or 0.
int lineOfMessage(const TiXmlDocument& doc, const std::string& message) {
  std::size_t open = message.find('[');
  while (open != std::string::npos) {
    const std::size_t close = message.find(']', open);
    if (close == std::string::npos) break;
    if (int line = elementLine(doc, message.substr(open + 1, close - open - 1)); line > 0)
      return line;
    open = message.find('[', close);
  }
  return 0;
}

KDL::Frame toKdl(const urdf::Pose& p) {
  return KDL::Frame(
      KDL::Rotation::Quaternion(p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w),
      KDL::Vector(p.position.x, p.position.y, p.position.z));
}

Eigen::Isometry3d toEigen(const KDL::Frame& f) {
  double x, y, z, w;
  f.M.GetQuaternion(x, y, z, w);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix();
  out.translation() = Eigen::Vector3d(f.p.x(), f.p.y(), f.p.z());
  return out;
}

KDL::Frame toKdl(const Eigen::Isometry3d& t) {
  const Eigen::Quaterniond q(t.linear());
  return KDL::Frame(KDL::Rotation::Quaternion(q.x(), q.y(), q.z(), q.w()),
                    KDL::Vector(t.translation().x(), t.translation().y(), t.translation().z()));
}

/// The KDL joint of a URDF joint: about (or along) its axis through its origin, both expressed
/// in the parent link's frame, as the segment's pose is joint motion then the fixed origin.
Result<KDL::Joint> toKdlJoint(const urdf::Joint& j, const KDL::Frame& origin) {
  const KDL::Vector axis = origin.M * KDL::Vector(j.axis.x, j.axis.y, j.axis.z);
  switch (j.type) {
    case urdf::Joint::FIXED:
      return KDL::Joint(j.name, KDL::Joint::None);
    case urdf::Joint::REVOLUTE:
    case urdf::Joint::CONTINUOUS:
      return KDL::Joint(j.name, origin.p, axis, KDL::Joint::RotAxis);
    case urdf::Joint::PRISMATIC:
      return KDL::Joint(j.name, origin.p, axis, KDL::Joint::TransAxis);
    default:
      return invalidInput(
          "joint '{}' is of a type a serial chain cannot hold (floating or planar); expected "
          "revolute, continuous, prismatic or fixed",
          j.name);
  }
}

ArmJoint limitsOf(const urdf::Joint& j, int line) {
  ArmJoint a;
  a.name = j.name;
  a.line = line;
  a.prismatic = j.type == urdf::Joint::PRISMATIC;
  a.lower = -std::numeric_limits<double>::infinity();
  a.upper = std::numeric_limits<double>::infinity();
  if (j.limits && j.type != urdf::Joint::CONTINUOUS) {
    a.lower = j.limits->lower;
    a.upper = j.limits->upper;
  }
  if (j.limits) a.velocity = j.limits->velocity;
  return a;
}

/// A joint's value with its unit: degrees for an angle, metres for a prismatic joint.
std::string shown(const ArmJoint& j, double v) {
  return j.prismatic ? fmt::format("{:.6g} m", v) : fmt::format("{:.4f} deg", v * kDeg);
}

}  // namespace

ArmModel::ArmModel() : impl_(std::make_unique<Impl>()) {
  impl_->fk = std::make_unique<KDL::ChainFkSolverPos_recursive>(impl_->chain);
}
ArmModel::ArmModel(ArmModel&&) noexcept = default;
ArmModel& ArmModel::operator=(ArmModel&&) noexcept = default;
ArmModel::~ArmModel() = default;

Result<ArmModel> ArmModel::load(const std::string& path, const std::string& base_link,
                                const std::string& tip_link) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return notFound("arm description '{}' cannot be opened; expected a URDF file", path);
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) return ioError("arm description '{}': reading failed", path);
  return fromString(text.str(), path, base_link, tip_link);
}

Result<ArmModel> ArmModel::fromString(const std::string& xml, const std::string& source,
                                      const std::string& base_link, const std::string& tip_link) {
  TiXmlDocument doc;
  doc.Parse(xml.c_str());
  if (doc.Error())
    return Status(StatusCode::kCorruptData,
                  fmt::format("arm description is not well-formed XML: {}", doc.ErrorDesc()),
                  SourceLocation{source, doc.ErrorRow(), doc.ErrorCol()});
  urdf::ModelInterfaceSharedPtr model;
  std::string urdf_error;
  {
    std::lock_guard<std::mutex> lock(consoleMutex());
    CapturedLog log;
    model = urdf::parseURDF(xml);
    urdf_error = log.first_error;
  }
  if (!model)
    return Status(StatusCode::kCorruptData,
                  fmt::format("arm description is not a valid URDF: {}",
                              urdf_error.empty() ? "urdfdom gave no reason" : urdf_error),
                  SourceLocation{source, lineOfMessage(doc, urdf_error), 0});
  ArmModel arm;
  arm.source_ = source;
  arm.base_link_ = base_link;
  arm.tip_link_ = tip_link;
  for (const std::string& name : {base_link, tip_link})
    if (!model->getLink(name))
      return Status(StatusCode::kNotFound,
                    fmt::format("arm description has no link '{}' (robot '{}'); expected the "
                                "chain's base and tip links",
                                name, model->getName()),
                    SourceLocation{source, 0, 0});
  // The joints from the tip up to the base, then reversed.
  std::vector<urdf::JointConstSharedPtr> path;
  for (urdf::LinkConstSharedPtr link = model->getLink(tip_link); link->name != base_link;) {
    if (!link->parent_joint || !link->getParent())
      return Status(StatusCode::kInvalidInput,
                    fmt::format("arm description: link '{}' is not below link '{}'; expected a "
                                "chain from the base link to the tip link",
                                tip_link, base_link),
                    SourceLocation{source, elementLine(doc, tip_link), 0});
    path.push_back(link->parent_joint);
    link = link->getParent();
  }
  std::reverse(path.begin(), path.end());
  for (const urdf::JointConstSharedPtr& j : path) {
    const KDL::Frame origin = toKdl(j->parent_to_joint_origin_transform);
    Result<KDL::Joint> joint = toKdlJoint(*j, origin);
    if (!joint)
      return Status(joint.status().code(), "arm description: " + joint.status().reason(),
                    SourceLocation{source, elementLine(doc, j->name), 0});
    arm.impl_->chain.addSegment(KDL::Segment(j->child_link_name, *joint, origin));
    arm.impl_->segment_links.push_back(j->child_link_name);
    if (j->type != urdf::Joint::FIXED)
      arm.joints_.push_back(limitsOf(*j, elementLine(doc, j->name)));
  }
  const urdf::LinkConstSharedPtr tip = model->getLink(tip_link);
  if (tip->collision && tip->collision->geometry &&
      tip->collision->geometry->type == urdf::Geometry::SPHERE)
    arm.tip_sphere_radius_ =
        std::static_pointer_cast<const urdf::Sphere>(tip->collision->geometry)->radius;
  arm.impl_->fk = std::make_unique<KDL::ChainFkSolverPos_recursive>(arm.impl_->chain);
  return arm;
}

Eigen::Isometry3d ArmModel::forward(std::span<const double> q) const {
  KDL::JntArray joints(static_cast<unsigned>(q.size()));
  for (std::size_t i = 0; i < q.size(); ++i) joints(static_cast<unsigned>(i)) = q[i];
  KDL::Frame tip;
  impl_->fk->JntToCart(joints, tip);
  return toEigen(tip);
}

Result<Eigen::Isometry3d> ArmModel::forwardTo(std::span<const double> q,
                                              const std::string& link) const {
  if (link == base_link_) return Eigen::Isometry3d::Identity();
  const auto it = std::find(impl_->segment_links.begin(), impl_->segment_links.end(), link);
  if (it == impl_->segment_links.end())
    return notFound("link '{}' is not on the chain from '{}' to '{}' of '{}'", link, base_link_,
                    tip_link_, source_);
  KDL::JntArray joints(static_cast<unsigned>(q.size()));
  for (std::size_t i = 0; i < q.size(); ++i) joints(static_cast<unsigned>(i)) = q[i];
  KDL::Frame frame;
  impl_->fk->JntToCart(joints, frame, static_cast<int>(it - impl_->segment_links.begin()) + 1);
  return toEigen(frame);
}

Status ArmModel::checkJoints(std::span<const double> q, double angular_margin,
                             const std::string& what, double linear_margin) const {
  if (q.size() != joints_.size())
    return invalidInput("{} has {} joint positions; expected {} (the joints of '{}')", what,
                        q.size(), joints_.size(), source_);
  for (std::size_t i = 0; i < q.size(); ++i) {
    const ArmJoint& j = joints_[i];
    if (!std::isfinite(q[i]))
      return invalidInput("{}: joint '{}' is {}; expected a finite position", what, j.name, q[i]);
    const double margin = j.prismatic ? linear_margin : angular_margin;
    if (q[i] < j.lower - margin || q[i] > j.upper + margin)
      return invalidInput(
          "{}: joint '{}' is at {}, outside its limits [{}, {}] (widened by {}; {}:{}); expected "
          "a position the joint can reach",
          what, j.name, shown(j, q[i]), shown(j, j.lower), shown(j, j.upper), shown(j, margin),
          source_, j.line);
  }
  return Status::ok();
}

Result<std::vector<double>> ArmModel::positionsOf(const JointState& state,
                                                  const std::string& what) const {
  CDFF_RETURN_IF_ERROR(state.validate());
  std::vector<double> q(joints_.size());
  for (std::size_t i = 0; i < joints_.size(); ++i) {
    const auto it = std::find(state.names.begin(), state.names.end(), joints_[i].name);
    if (it == state.names.end())
      return invalidInput(
          "{} has no position of joint '{}' ({} names); expected every joint of "
          "the chain from '{}' to '{}'",
          what, joints_[i].name, state.names.size(), base_link_, tip_link_);
    q[i] = state.position[static_cast<std::size_t>(it - state.names.begin())];
  }
  return q;
}

Eigen::Matrix<double, 6, Eigen::Dynamic> ArmModel::jacobian(std::span<const double> q) const {
  if (!impl_->jac) impl_->jac = std::make_unique<KDL::ChainJntToJacSolver>(impl_->chain);
  KDL::JntArray joints(static_cast<unsigned>(q.size()));
  for (std::size_t i = 0; i < q.size(); ++i) joints(static_cast<unsigned>(i)) = q[i];
  KDL::Jacobian j(static_cast<unsigned>(q.size()));
  impl_->jac->JntToJac(joints, j);
  return j.data;
}

namespace {

using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

/// The damping of the least-squares steps (m, rad): no weight next to the arm's singular values
/// of tenths of a metre, it keeps a step finite at a singularity.
constexpr double kDamping = 1e-4;
/// Damped Gauss-Newton steps tried before Levenberg-Marquardt, and after it.
constexpr int kNewtonSteps = 5;
/// The pose error (m, rad) below which Gauss-Newton starts alone: a servo's next sample.
constexpr double kNewtonReach = 0.01;

/// The damped least-squares solution of J dq = e: J^T (J J^T + l^2 I)^-1 e.
Eigen::VectorXd dampedSolve(const Jacobian& j, const Vector6& e) {
  Eigen::Matrix<double, 6, 6> a = j * j.transpose();
  a.diagonal().array() += kDamping * kDamping;
  return j.transpose() * a.ldlt().solve(e);
}

/// The seed moved `pull.fraction` of the way towards `pull.posture` within the Jacobian's null
/// space: dq = (I - J+ J) f (posture - seed), with the damped inverse for J+ (so that near a
/// singularity the lost direction is not amplified). To first order the tip stays where it is;
/// the solver then removes the rest.
std::vector<double> pulledSeed(const Jacobian& jacobian, std::span<const double> seed,
                               const PosturePull& pull) {
  const auto n = static_cast<Eigen::Index>(seed.size());
  Eigen::VectorXd toward(n);
  for (Eigen::Index i = 0; i < n; ++i)
    toward[i] = pull.fraction *
                (pull.posture[static_cast<std::size_t>(i)] - seed[static_cast<std::size_t>(i)]);
  const Eigen::VectorXd step = toward - dampedSolve(jacobian, jacobian * toward);
  std::vector<double> out(seed.begin(), seed.end());
  for (Eigen::Index i = 0; i < n; ++i) out[static_cast<std::size_t>(i)] += step[i];
  return out;
}

/// The tip's pose error: the position's, then the attitude's as a rotation vector, both in the
/// base frame (the Jacobian's rows).
Vector6 poseError(const Eigen::Isometry3d& reached, const Eigen::Isometry3d& wanted) {
  const Eigen::AngleAxisd turn(wanted.linear() * reached.linear().transpose());
  Vector6 e;
  e << wanted.translation() - reached.translation(), turn.angle() * turn.axis();
  return e;
}

bool within(const Vector6& error, double tolerance) {
  return error.head<3>().norm() <= tolerance && error.tail<3>().norm() <= tolerance;
}

}  // namespace

Eigen::Matrix<double, 6, 1> ArmModel::newtonSteps(std::vector<double>& q,
                                                  const Eigen::Isometry3d& base_T_tip,
                                                  double tolerance) const {
  Vector6 error = poseError(forward(q), base_T_tip);
  for (int step = 0; step < kNewtonSteps && !within(error, tolerance); ++step) {
    const Eigen::VectorXd dq = dampedSolve(jacobian(q), error);
    for (std::size_t i = 0; i < q.size(); ++i) q[i] += dq[static_cast<Eigen::Index>(i)];
    error = poseError(forward(q), base_T_tip);
  }
  return error;
}

Result<std::vector<double>> ArmModel::inverse(const Eigen::Isometry3d& base_T_tip,
                                              std::span<const double> seed, double tolerance,
                                              const PosturePull* pull) const {
  if (!impl_->ik) {
    // Position and attitude weighted alike: an attitude error of 1 rad counts as 1 m. The
    // solver stops at a residual of 1e-9 (a nanometre: below it, its damped steps shrink without
    // gaining, up to its iteration limit) or a tiny step; Gauss-Newton steps finish below and
    // the result is judged by its actual residual.
    Eigen::Matrix<double, 6, 1> weights = Eigen::Matrix<double, 6, 1>::Ones();
    impl_->ik =
        std::make_unique<KDL::ChainIkSolverPos_LMA>(impl_->chain, weights, 1e-9, 200, 1e-15);
  }
  std::vector<double> pulled;
  if (pull != nullptr && pull->posture.size() != seed.size())
    return invalidInput(
        "inverse kinematics of '{}': the posture pulled towards has {} joints; "
        "expected {}, one per joint of the seed",
        source_, pull->posture.size(), seed.size());
  if (pull != nullptr && !(pull->fraction >= 0 && pull->fraction <= 1))
    return invalidInput("inverse kinematics of '{}': posture pull fraction {}; expected [0, 1]",
                        source_, pull->fraction);
  if (pull != nullptr && pull->fraction > 0) {
    pulled = pulledSeed(jacobian(seed), seed, *pull);
    seed = pulled;
  }
  // Close to the pose (a servo's next sample), damped Gauss-Newton steps converge in one or
  // two; from farther, or where they do not, KDL's Levenberg-Marquardt first, then the steps
  // again to below the tolerance (its damping slows it down close to the solution).
  std::vector<double> q(seed.begin(), seed.end());
  Vector6 error = poseError(forward(q), base_T_tip);
  if (error.norm() < kNewtonReach) error = newtonSteps(q, base_T_tip, tolerance);
  if (!within(error, tolerance)) {
    KDL::JntArray start(static_cast<unsigned>(seed.size())), solution(start.rows());
    for (std::size_t i = 0; i < seed.size(); ++i) start(static_cast<unsigned>(i)) = seed[i];
    impl_->ik->CartToJnt(start, toKdl(base_T_tip), solution);
    for (std::size_t i = 0; i < q.size(); ++i) q[i] = solution(static_cast<unsigned>(i));
    error = newtonSteps(q, base_T_tip, tolerance);
  }
  for (std::size_t i = 0; i < q.size(); ++i) {
    // A revolute joint's solution may be off by whole turns: the one within limits.
    if (!joints_[i].prismatic) {
      while (q[i] > joints_[i].upper && q[i] - 2 * M_PI >= joints_[i].lower) q[i] -= 2 * M_PI;
      while (q[i] < joints_[i].lower && q[i] + 2 * M_PI <= joints_[i].upper) q[i] += 2 * M_PI;
    }
  }
  const double position_error = error.head<3>().norm(), attitude_error = error.tail<3>().norm();
  if (!within(error, tolerance))
    return numericalFailure(
        "inverse kinematics of '{}' did not converge (residual {:.3g} m, {:.3g} rad; expected "
        "{:.3g}); the pose may be out of reach",
        source_, position_error, attitude_error, tolerance);
  CDFF_RETURN_IF_ERROR(checkJoints(q, 0.0, "inverse kinematics solution"));
  return q;
}

}  // namespace cdff::kinematics
