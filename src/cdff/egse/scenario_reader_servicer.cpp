// The scenario's servicer: its trajectory (one table per type: hold, line, waypoints,
// fly_around, cw), its attitude and its mock-up.
#include <fmt/format.h>

#include "cdff/egse/scenario_reader.hpp"

namespace cdff::egse::scenario_reader {

namespace {

using S = Scenario;

/// The row of a trajectory's `type`: read first, by readTrajectory, to choose the table.
Status trajectoryTypeRead(const Field&, Scenario&) {
  return Status::ok();
}

const Table<Scenario>& holdTable() {
  static const Table<Scenario> table = Table<Scenario>("a hold {type, position}")
                                           .optional("type", trajectoryTypeRead)
                                           .optional("position", vec3(&S::start));
  return table;
}

const Table<Scenario>& lineTable() {
  static const Table<Scenario> table =
      Table<Scenario>("a line {type, start, end, start_time, end_time, profile}")
          .optional("type", trajectoryTypeRead)
          .required("start", vec3(&S::start), "the start position (lvlh, m)")
          .required("end", vec3(&S::end), "the end position (lvlh, m)")
          .optional("start_time", schema::number(&S::start_time, Range::closed(0, 1e6, "s")))
          .optional("end_time",
                    [](const Field& f, Scenario& sc) -> Status {
                      CDFF_RETURN_IF_ERROR(f.read(sc.end_time, Range::leftOpen(0, 1e6, "s")));
                      if (sc.end_time <= sc.start_time)
                        return f.fail(fmt::format("a time after start_time ({} s)", sc.start_time),
                                      "not after start_time");
                      return Status::ok();
                    })
          .optional("profile", schema::named(&S::smooth, {{"smooth", true}, {"linear", false}}));
  return table;
}

Status waypointTimes(const Field& f, Scenario& sc) {
  CDFF_RETURN_IF_ERROR(f.numbers(sc.waypoint_times, 2, 100000));
  for (std::size_t i = 1; i < sc.waypoint_times.size(); ++i)
    if (!(sc.waypoint_times[i] > sc.waypoint_times[i - 1]))
      return f.fail("strictly increasing times",
                    fmt::format("time {} is not after time {}", i, i - 1));
  return Status::ok();
}

Status waypointPositions(const Field& f, Scenario& sc) {
  if (!f.isList() || f.size() != sc.waypoint_times.size())
    return f.fail(fmt::format("a list of {} positions, one per time", sc.waypoint_times.size()));
  std::vector<Eigen::Vector3d> waypoints;
  for (const Field& element : f.elements()) {
    Eigen::Vector3d p;
    CDFF_RETURN_IF_ERROR(readVec3(element, p));
    waypoints.push_back(p);
  }
  sc.waypoints = std::move(waypoints);
  sc.start = sc.waypoints.front();
  return Status::ok();
}

const Table<Scenario>& waypointsTable() {
  // The times first: the positions are one per time.
  static const Table<Scenario> table =
      Table<Scenario>("waypoints {type, times, positions, profile}")
          .optional("type", trajectoryTypeRead)
          .required("times", waypointTimes, "the waypoints' times (s)")
          .required("positions", waypointPositions, "the waypoints' positions (lvlh, m)")
          .optional("profile",
                    schema::named(&Scenario::waypoint_legs, {{"spline", false}, {"legs", true}}));
  return table;
}

const Table<Scenario>& flyAroundTable() {
  static const Table<Scenario> table =
      Table<Scenario>(
          "a fly-around {type, centre, axis, reference, radius, radial_rate, rate_deg_s, "
          "phase_deg}")
          .optional("type", trajectoryTypeRead)
          .optional("centre", vec3(&S::centre))
          .optional("axis", direction(&S::axis))
          .optional("reference", direction(&S::reference))
          .optional("radius", schema::number(&S::radius, Range::leftOpen(0, 1e6, "m")))
          .optional("radial_rate", schema::number(&S::radial_rate, Range::closed(-100, 100, "m/s")))
          .optional("rate_deg_s", degrees(&S::angular_rate, Range::closed(-90, 90, "deg/s")))
          .optional("phase_deg", degrees(&S::phase, Range::closed(-360, 360, "deg")));
  return table;
}

const Table<Scenario>& cwTable() {
  static const Table<Scenario> table = Table<Scenario>("a CW trajectory {type, position, velocity}")
                                           .optional("type", trajectoryTypeRead)
                                           .optional("position", vec3(&S::start))
                                           .optional("velocity", vec3(&S::velocity));
  return table;
}

struct TrajectoryType {
  const char* name;
  TranslationKind kind;
  const Table<Scenario>& (*table)();
};
const TrajectoryType kTrajectories[] = {{"hold", TranslationKind::kHold, holdTable},
                                        {"line", TranslationKind::kLine, lineTable},
                                        {"waypoints", TranslationKind::kWaypoints, waypointsTable},
                                        {"fly_around", TranslationKind::kFlyAround, flyAroundTable},
                                        {"cw", TranslationKind::kCw, cwTable}};

Status readTrajectory(const Field& f, Scenario& sc) {
  std::vector<std::string> names;
  for (const TrajectoryType& t : kTrajectories) names.emplace_back(t.name);
  std::string type = "hold";
  if (f.has("type")) CDFF_RETURN_IF_ERROR(f["type"].choice(type, names));
  for (const TrajectoryType& t : kTrajectories) {
    if (type != t.name) continue;
    CDFF_RETURN_IF_ERROR(t.table().read(f, sc));
    sc.translation = t.kind;
  }
  if (sc.translation != TranslationKind::kFlyAround || std::abs(sc.axis.dot(sc.reference)) <= 0.999)
    return Status::ok();
  // The one given is at fault (the reference's default is -y).
  if (f.has("reference"))
    return f["reference"].fail("a direction not parallel to 'axis'", "parallel to the axis");
  return f["axis"].fail("a direction not parallel to 'reference' (by default [0, -1, 0])",
                        "parallel to the reference");
}

const Table<Scenario>& servicerAttitudeTable() {
  static const Table<Scenario> table =
      Table<Scenario>(
          "the servicer's attitude {mode, up, yaw_offset_deg, pitch_offset_deg, jitter_deg, "
          "rpy_deg}")
          .optional("mode",
                    schema::named(&S::servicer_attitude,
                                  {{"target_pointing", ServicerAttitudeKind::kTargetPointing},
                                   {"lvlh", ServicerAttitudeKind::kLvlh},
                                   {"inertial", ServicerAttitudeKind::kInertial}}))
          .optional("up", direction(&S::up))
          .optional("yaw_offset_deg", degrees(&S::yaw_offset, Range::closed(-180, 180, "deg")))
          .optional("jitter_deg", degrees(&S::servicer_jitter, Range::closed(0, 10, "deg")))
          .optional("pitch_offset_deg", degrees(&S::pitch_offset, Range::closed(-90, 90, "deg")))
          .optional("rpy_deg", rpy(&S::servicer_orientation));
  return table;
}

const Table<Scenario>& mockupTable() {
  using M = ServicerSpec;
  static const Table<Scenario> table =
      Table<Scenario>("the servicer's mock-up {enabled, bus_size, probe_length, probe_diameter}")
          .optional("enabled", schema::flag(&S::servicer_mockup))
          .optional("bus_size", via(&S::servicer_spec, vec3(&M::bus_size)))
          .optional(
              "probe_length",
              via(&S::servicer_spec, schema::number(&M::probe_length, Range::closed(0, 10, "m"))))
          .optional("probe_diameter",
                    via(&S::servicer_spec,
                        schema::number(&M::probe_diameter, Range::leftOpen(0, 1, "m"))));
  return table;
}

/// A mock-up is drawn when the key is there, unless `enabled: false`.
Status readMockup(const Field& f, Scenario& sc) {
  sc.servicer_mockup = true;
  CDFF_RETURN_IF_ERROR(mockupTable().read(f, sc));
  return sc.servicer_spec.validate().withContext(f.path()).at(f.location());
}

}  // namespace

const Table<Scenario>& servicerTable() {
  static const Table<Scenario> table =
      Table<Scenario>("the servicer {trajectory, attitude, mockup}")
          .optional("trajectory", readTrajectory)
          .optional("attitude", [](const Field& f,
                                   Scenario& sc) { return servicerAttitudeTable().read(f, sc); })
          .optional("mockup", readMockup);
  return table;
}

}  // namespace cdff::egse::scenario_reader
