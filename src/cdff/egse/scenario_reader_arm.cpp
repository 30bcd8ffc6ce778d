// The scenario's manipulator (haptic scanning): its description, mounting, sensors, contact and
// collision paths. Off unless the scenario has `arm:`; its figures default to ArmSpec's.
#include <fmt/format.h>

#include "cdff/egse/scenario_reader.hpp"

namespace cdff::egse::scenario_reader {

namespace {

using A = ArmSpec;

/// The URDF file, relative to the scenario file (as a target mesh is).
Status readDescription(const Field& f, ScenarioDraft& d) {
  std::string file;
  CDFF_RETURN_IF_ERROR(f.read(file));
  const std::filesystem::path p(file);
  const std::filesystem::path path = p.is_absolute() || d.base.empty() ? p : d.base / p;
  if (!std::filesystem::exists(path))
    return f.fail("an arm description (URDF) relative to the scenario",
                  fmt::format("the file '{}' does not exist", path.string()),
                  StatusCode::kNotFound);
  d.scenario.arm.spec.description = path.string();
  return Status::ok();
}

Status readArmMount(const Field& f, ArmConfig& arm) {
  struct Pose {
    Eigen::Vector3d position;
    Eigen::Quaterniond rotation;
  };
  static const Table<Pose> table = Table<Pose>("the arm's mounting {position, rpy_deg}")
                                       .optional("position", vec3(&Pose::position))
                                       .optional("rpy_deg", rpy(&Pose::rotation));
  Pose pose{arm.servicer_T_base.translation(), Eigen::Quaterniond(arm.servicer_T_base.linear())};
  CDFF_RETURN_IF_ERROR(table.read(f, pose));
  arm.servicer_T_base = mountAt(pose.position, pose.rotation);
  return Status::ok();
}

const Table<ForceTorqueSpec>& forceTorqueTable() {
  using F = ForceTorqueSpec;
  const Range newtons = Range::closed(0, 1e4, "N"), newton_metres = Range::closed(0, 1e3, "N m");
  static const Table<F> table =
      Table<F>(
          "the force/torque sensor {noise, force_noise, torque_noise, force_bias_sigma, "
          "torque_bias_sigma, force_range, torque_range}")
          .optional("noise", schema::flag(&F::noise))
          .optional("force_noise", schema::number(&F::force_noise, newtons))
          .optional("torque_noise", schema::number(&F::torque_noise, newton_metres))
          .optional("force_bias_sigma", schema::number(&F::force_bias_sigma, newtons))
          .optional("torque_bias_sigma", schema::number(&F::torque_bias_sigma, newton_metres))
          .optional("force_range", schema::number(&F::force_range, Range::leftOpen(0, 1e5, "N")))
          .optional("torque_range",
                    schema::number(&F::torque_range, Range::leftOpen(0, 1e4, "N m")));
  return table;
}

const Table<EncoderSpec>& encoderTable() {
  static const Table<EncoderSpec> table =
      Table<EncoderSpec>("the joint encoders {noise, bits}")
          .optional("noise", schema::number(&EncoderSpec::noise, Range::closed(0, 0.1, "rad")))
          .optional("bits", schema::integer(&EncoderSpec::bits, 8, 32));
  return table;
}

const Table<ContactSpec>& contactTable() {
  using C = ContactSpec;
  static const Table<C> table =
      Table<C>("the tip's contact {stiffness, damping, friction}")
          .optional("stiffness", schema::number(&C::stiffness, Range::leftOpen(0, 1e9, "N/m")))
          .optional("damping", schema::number(&C::damping, Range::closed(0, 1e6, "N s/m")))
          .optional("friction", schema::number(&C::friction, Range::closed(0, 2)));
  return table;
}

const Table<CollisionPathSpec>& pathTable() {
  using P = CollisionPathSpec;
  static const Table<P> table =
      Table<P>(
          "the collision paths {standoff, press_force, hold, max_tilt_deg, reach, region_centre, "
          "region_radius}")
          .optional("standoff", schema::number(&P::standoff, Range::leftOpen(0, 1, "m")))
          .optional("press_force", schema::number(&P::press_force, Range::leftOpen(0, 1e3, "N")))
          .optional("hold", schema::number(&P::hold, Range::closed(0, 100, "s")))
          .optional("max_tilt_deg", degrees(&P::max_tilt, Range{0, 90, false, true, "deg"}))
          .optional("reach", schema::number(&P::reach, Range::leftOpen(0, 10, "m")))
          .optional("region_centre", vec3(&P::region_centre))
          .optional("region_radius", schema::number(&P::region_radius, Range::closed(0, 100, "m")));
  return table;
}

template <typename Reader>
auto inArm(Reader reader) {
  return [reader = std::move(reader)](const Field& f, ScenarioDraft& d) {
    return reader(f, d.scenario.arm);
  };
}
template <typename Reader>
auto inSpec(Reader reader) {
  return inArm(via(&ArmConfig::spec, std::move(reader)));
}

const Table<ScenarioDraft>& armTable() {
  static const Table<ScenarioDraft> table =
      Table<ScenarioDraft>(
          "the arm {enabled, description, mount, rate, force_torque, encoders, contact, paths}")
          .optional("enabled", inArm(schema::flag(&ArmConfig::enabled)))
          .optional("description", readDescription)
          .optional("mount", inArm(readArmMount))
          .optional("rate", inSpec(schema::number(&A::rate, Range::leftOpen(0, 100000, "Hz"))))
          .optional("force_torque", inSpec(schema::nested(&A::force_torque, forceTorqueTable())))
          .optional("encoders", inSpec(schema::nested(&A::encoders, encoderTable())))
          .optional("contact", inSpec(schema::nested(&A::contact, contactTable())))
          .optional("paths", inSpec(schema::nested(&A::paths, pathTable())));
  return table;
}

}  // namespace

Status readArm(const Field& f, ScenarioDraft& d) {
  ArmConfig& arm = d.scenario.arm;
  arm.enabled = true;  // the key is there: on unless `enabled: false`
  CDFF_RETURN_IF_ERROR(armTable().read(f, d));
  if (!arm.enabled) return Status::ok();
  if (arm.spec.description.empty())
    return f.fail("an arm with a 'description' (its URDF file)", "no 'description'");
  return arm.spec.validate().withContext(f.path()).at(f.location());
}

}  // namespace cdff::egse::scenario_reader
