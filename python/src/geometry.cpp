// Transforms, poses with covariance, rigid-body states, pose arrays and proprioceptive samples.
// Rotations cross as unit quaternions in (x, y, z, w) order (Eigen's coeffs(), ROS's and
// SciPy's order), named `quaternion_xyzw` so that the order is never guessed; `matrix` gives the
// 4x4 homogeneous form. Covariances are NumPy matrices ordered [dt, dtheta] (docs/conventions.md).

#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "cdff/types/geometry.hpp"
#include "cdff/types/sensors.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

Eigen::Vector4d xyzw(const Eigen::Quaterniond& q) {
  return q.coeffs();
}
Eigen::Quaterniond fromXyzw(const Eigen::Vector4d& v) {
  return {v[3], v[0], v[1], v[2]};
}

Transform makeTransform(const Eigen::Vector3d& translation, const Eigen::Vector4d& quaternion_xyzw,
                        std::string parent_frame, std::string child_frame, Timestamp stamp) {
  Transform t;
  t.stamp = stamp;
  t.parent_frame = std::move(parent_frame);
  t.child_frame = std::move(child_frame);
  t.translation = translation;
  t.rotation = fromXyzw(quaternion_xyzw);
  return t;
}

Transform fromMatrix(const Eigen::Matrix4d& m, std::string parent, std::string child,
                     Timestamp stamp) {
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  if (!m.allFinite() || !(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-6) ||
      r.determinant() < 0 || !m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)))
    raise(
        invalidInput("Transform.from_matrix: the matrix is not a rigid transform (its rotation "
                     "block must be orthonormal with determinant +1 and its last row "
                     "[0, 0, 0, 1]); got\n{}",
                     fmt::format("{}", fmt::join(m.data(), m.data() + 16, ", "))));
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() = r;
  iso.translation() = m.topRightCorner<3, 1>();
  return Transform::fromIsometry(iso, std::move(parent), std::move(child), stamp);
}

void bindTransform(py::module_& m) {
  py::class_<Transform, std::shared_ptr<Transform>>(
      m, "Transform",
      "a_T_b: maps points in frame b (child_frame) into frame a (parent_frame): "
      "p_a = translation + R(quaternion_xyzw) p_b. Translation in m, quaternion in (x, y, z, w).")
      .def(py::init<>())
      .def(py::init(&makeTransform), py::arg("translation"), py::arg("quaternion_xyzw"),
           py::arg("parent_frame") = "", py::arg("child_frame") = "", py::arg("stamp") = 0)
      .def_static("from_matrix", &fromMatrix, py::arg("matrix"), py::arg("parent_frame") = "",
                  py::arg("child_frame") = "", py::arg("stamp") = 0,
                  "From a 4x4 homogeneous matrix whose rotation block is orthonormal.")
      .def_readwrite("stamp", &Transform::stamp)
      .def_readwrite("parent_frame", &Transform::parent_frame)
      .def_readwrite("child_frame", &Transform::child_frame)
      .def_readwrite("translation", &Transform::translation)
      .def_property(
          "quaternion_xyzw", [](const Transform& t) { return xyzw(t.rotation); },
          [](Transform& t, const Eigen::Vector4d& q) { t.rotation = fromXyzw(q); })
      .def_property_readonly("matrix",
                             [](const Transform& t) { return t.isometry().matrix().eval(); })
      .def_property_readonly("rotation_matrix",
                             [](const Transform& t) { return t.rotation.toRotationMatrix(); })
      .def("inverse", &Transform::inverse)
      .def(
          "compose", [](const Transform& a, const Transform& b) { return take(a.compose(b)); },
          py::arg("b_T_c"), "a_T_c = a_T_b * b_T_c; the inner frame names must agree when set.")
      .def("__mul__", [](const Transform& a, const Transform& b) { return take(a.compose(b)); })
      .def(
          "apply",
          [](const Transform& t, const Eigen::Matrix<double, Eigen::Dynamic, 3>& p_b) {
            Eigen::Matrix<double, Eigen::Dynamic, 3> p_a =
                (p_b * t.rotation.toRotationMatrix().transpose()).rowwise() +
                t.translation.transpose();
            return p_a;
          },
          py::arg("points"), "Maps (N, 3) points of frame b into frame a.")
      .def("validate", [](const Transform& t) { check(t.validate()); })
      .def("__repr__", [](const Transform& t) {
        return fmt::format(
            "<cdff.Transform {}_T_{} t=[{:.6g}, {:.6g}, {:.6g}] q_xyzw=[{:.6g}, "
            "{:.6g}, {:.6g}, {:.6g}] stamp={}>",
            t.parent_frame, t.child_frame, t.translation.x(), t.translation.y(), t.translation.z(),
            t.rotation.x(), t.rotation.y(), t.rotation.z(), t.rotation.w(), t.stamp);
      });
  addClassConverter<Transform>("cdff.Transform");
}

void bindPoses(py::module_& m) {
  py::class_<PoseWithCovariance, std::shared_ptr<PoseWithCovariance>>(
      m, "PoseWithCovariance",
      "A pose (Transform) with its 6x6 covariance [dt, dtheta] (m², rad²).")
      .def(py::init<>())
      .def(py::init([](Transform pose, const Matrix6d& covariance) {
             return PoseWithCovariance{std::move(pose), covariance};
           }),
           py::arg("pose"), py::arg("covariance") = Matrix6d::Zero().eval())
      .def_readwrite("pose", &PoseWithCovariance::pose)
      .def_readwrite("covariance", &PoseWithCovariance::covariance)
      .def("validate", [](const PoseWithCovariance& p) { check(p.validate()); });
  addClassConverter<PoseWithCovariance>("cdff.PoseWithCovariance");

  py::class_<Twist>(m, "Twist", "Linear (m/s) and angular (rad/s) velocity, in the parent frame.")
      .def(py::init<>())
      .def_readwrite("linear", &Twist::linear)
      .def_readwrite("angular", &Twist::angular);
  py::class_<RigidBodyState, std::shared_ptr<RigidBodyState>>(
      m, "RigidBodyState", "Pose and twist with their 12x12 covariance [dt, dtheta, dv, domega].")
      .def(py::init<>())
      .def_readwrite("pose", &RigidBodyState::pose)
      .def_readwrite("twist", &RigidBodyState::twist)
      .def_readwrite("covariance", &RigidBodyState::covariance)
      .def("pose_with_covariance", &RigidBodyState::poseWithCovariance)
      .def("validate", [](const RigidBodyState& s) { check(s.validate()); });
  addClassConverter<RigidBodyState>("cdff.RigidBodyState");

  py::class_<PoseArray, std::shared_ptr<PoseArray>>(m, "PoseArray",
                                                    "Poses in one frame, as 4x4 matrices.")
      .def(py::init<>())
      .def_readwrite("stamp", &PoseArray::stamp)
      .def_readwrite("frame_id", &PoseArray::frame_id)
      .def_property(
          "poses",
          [](const PoseArray& a) {
            std::vector<Eigen::Matrix4d> out;
            for (const Eigen::Isometry3d& p : a.poses) out.push_back(p.matrix());
            return out;
          },
          [](PoseArray& a, const std::vector<Eigen::Matrix4d>& poses) {
            a.poses.clear();
            for (const Eigen::Matrix4d& p : poses)
              a.poses.emplace_back(fromMatrix(p, "", "", 0).isometry());
          },
          "The poses as 4x4 homogeneous matrices (a list; copied).");
  addClassConverter<PoseArray>("cdff.PoseArray");
}

void bindSensors(py::module_& m) {
  py::class_<ImuSample, std::shared_ptr<ImuSample>>(
      m, "ImuSample", "Angular rate (rad/s) and specific force (m/s²).")
      .def(py::init<>())
      .def_readwrite("stamp", &ImuSample::stamp)
      .def_readwrite("frame_id", &ImuSample::frame_id)
      .def_readwrite("angular_velocity", &ImuSample::angular_velocity)
      .def_readwrite("linear_acceleration", &ImuSample::linear_acceleration)
      .def_readwrite("angular_velocity_covariance", &ImuSample::angular_velocity_covariance)
      .def_readwrite("linear_acceleration_covariance", &ImuSample::linear_acceleration_covariance)
      .def("validate", [](const ImuSample& s) { check(s.validate()); });
  addClassConverter<ImuSample>("cdff.ImuSample");
  py::class_<Wrench, std::shared_ptr<Wrench>>(m, "Wrench",
                                              "Force (N) and torque (N m) at frame_id's origin.")
      .def(py::init<>())
      .def_readwrite("stamp", &Wrench::stamp)
      .def_readwrite("frame_id", &Wrench::frame_id)
      .def_readwrite("force", &Wrench::force)
      .def_readwrite("torque", &Wrench::torque)
      .def("validate", [](const Wrench& w) { check(w.validate()); });
  addClassConverter<Wrench>("cdff.Wrench");
  py::class_<JointState, std::shared_ptr<JointState>>(m, "JointState",
                                                      "Joint positions, velocities and efforts.")
      .def(py::init<>())
      .def_readwrite("stamp", &JointState::stamp)
      .def_readwrite("names", &JointState::names)
      .def_readwrite("position", &JointState::position)
      .def_readwrite("velocity", &JointState::velocity)
      .def_readwrite("effort", &JointState::effort)
      .def("validate", [](const JointState& j) { check(j.validate()); });
  addClassConverter<JointState>("cdff.JointState");
}

}  // namespace

void bindGeometry(py::module_& m) {
  bindTransform(m);
  bindPoses(m);
  bindSensors(m);
  m.def(
      "angular_distance",
      [](const Eigen::Vector4d& a, const Eigen::Vector4d& b) {
        return angularDistance(fromXyzw(a).normalized(), fromXyzw(b).normalized());
      },
      py::arg("a_xyzw"), py::arg("b_xyzw"), "Angle between two rotations (rad, in [0, pi]).");
}

}  // namespace cdff::python
