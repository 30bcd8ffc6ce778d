// Scenario files: the library loads, and bad files get errors naming file, line, key and value.
#include <gtest/gtest.h>

#include "cdff/egse/scenario.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

void expectError(const Result<Scenario>& result, const std::string& fragment) {
  ASSERT_FALSE(result.isOk()) << "expected an error containing: " << fragment;
  EXPECT_NE(result.status().message().find(fragment), std::string::npos)
      << "message: " << result.status().message() << "\nexpected to contain: " << fragment;
}

/// An error in the one format of every YAML file the project reads, at `location`:
/// "<file>:<line>:<column>: <key path> = <value>: <problem>; expected <what>".
void expectError(const Result<Scenario>& result, const SourceLocation& location,
                 const std::string& fragment) {
  expectError(result, fragment);
  if (!result.isOk()) {
    EXPECT_EQ(result.status().location(), location) << result.status().message();
  }
}

TEST(ScenarioLibrary, HasTheIssuesScenariosAndEveryOneLoads) {
  const auto library = listScenarios();
  std::set<std::string> names;
  for (const ScenarioInfo& s : library) {
    names.insert(s.name);
    EXPECT_EQ(s.description.rfind("INVALID", 0), std::string::npos)
        << s.name << ": " << s.description;
    EXPECT_GT(s.duration, 0) << s.name;
  }
  for (const char* required :
       {"far_range_approach", "mid_range_approach", "close_range_approach", "fly_around_inspection",
        "tumbling_target", "leaving_field_of_view", "under_illuminated", "specular_glare",
        "earth_background", "sensor_faults", "haptic_scanning", "rendezvous"})
    EXPECT_TRUE(names.count(required)) << required;
  auto path = resolveScenario("mid_range_approach");
  ASSERT_OK(path.status());
  auto mid = loadScenario(*path);
  ASSERT_OK(mid.status());
  // The seed's validation distances and sensor suite.
  EXPECT_NEAR(mid->start.norm(), 17.0, 0.01);
  EXPECT_NEAR(mid->end.norm(), 2.0, 1e-9);
  const SensorConfig* left = mid->sensor("camera_left");
  ASSERT_NE(left, nullptr);
  EXPECT_EQ(left->camera.model.width, 1624);
  EXPECT_EQ(left->camera.model.height, 1234);
  EXPECT_NEAR(left->camera.model.fx, 6e-3 / 4.4e-6, 1e-9);
  EXPECT_EQ(mid->sensor("lidar")->lidar.elevations.size(), 16u);
  EXPECT_EQ(mid->sensor("imu")->rate, 120.0);
  EXPECT_EQ(left->frame(), "camera_left_optical");
  EXPECT_EQ(left->channelPrefix(), "/chaser/camera/left");
  // The tumbling target turns at 5 deg/s.
  auto tumbling = loadScenario(*resolveScenario("tumbling_target"));
  ASSERT_OK(tumbling.status());
  EXPECT_NEAR(tumbling->target_rate.norm() * 180 / M_PI, 5.0, 0.05);
  EXPECT_FALSE(resolveScenario("no_such_scenario").isOk());
  EXPECT_NE(resolveScenario("no_such_scenario").status().message().find("mid_range_approach"),
            std::string::npos);
}

TEST(ScenarioErrors, NameFileLineKeyAndValue) {
  expectError(
      parseScenario("duration: 10\nsensors:\n  camera_left:\n    exposur_time: 0.01\n", "s.yaml"),
      {"s.yaml", 4, 5},
      "s.yaml:4:5: sensors.camera_left.exposur_time: unknown key; expected one of {type, enabled, "
      "rate, phase, latency, mount, active_range, width, height");
  expectError(
      parseScenario("duration: 10\nsensors:\n  camera_left:\n    exposur_time: 0.01\n", "s.yaml"),
      "shadow_map_size} (did you mean 'exposure_time'?)");
  expectError(
      parseScenario("duration: 10\nsensors:\n  camera_left: {exposure_time: -0.002}\n", "s.yaml"),
      {"s.yaml", 3, 32},
      "s.yaml:3:32: sensors.camera_left.exposure_time = -0.002: out of range; expected a number in "
      "(0, 10] s");
  expectError(parseScenario("duration: ten\n", "s.yaml"), {"s.yaml", 1, 11},
              "s.yaml:1:11: duration = ten: not a number; expected a number in (0, 1000000] s");
  expectError(
      parseScenario("servicer:\n  trajectory: {type: spiral}\n", "s.yaml"), {"s.yaml", 2, 22},
      "s.yaml:2:22: servicer.trajectory.type = spiral: unknown value; expected one of {hold, line, "
      "waypoints, fly_around, cw}");
  expectError(parseScenario("faults:\n  - {type: glare, sensor: lidar}\n", "s.yaml"),
              {"s.yaml", 2, 27},
              "s.yaml:2:27: faults.0.sensor = lidar: glare faults do not apply to lidar sensors; "
              "expected a sensor a glare fault applies to: one of {camera_left, camera_right} or "
              "'*'");
  const Result<Scenario> missing_mesh =
      parseScenario("target: {model: missing.obj}\n", "s.yaml", {}, "/nonexistent");
  expectError(missing_mesh, {"s.yaml", 1, 17},
              "s.yaml:1:17: target.model = missing.obj: the mesh file '/nonexistent/missing.obj' "
              "does not exist; expected 'procedural' or a mesh file");
  EXPECT_EQ(missing_mesh.status().code(), StatusCode::kNotFound);
  expectError(parseScenario("sensors:\n  star_tracker: {rate: 1}\n", "s.yaml"), {"s.yaml", 2, 17},
              "s.yaml:2:17: sensors.star_tracker.type: missing; expected a new sensor's type: one "
              "of {camera, lidar, tof, imu, radar, ahrs}");
  expectError(parseScenario("duration: [1, 2\n", "s.yaml"), {"s.yaml", 2, 1},
              "s.yaml:2:1: YAML syntax error");
  expectError(parseScenario("target:\n  procedural: {ring_diameter: 2.5}\n", "s.yaml"),
              "target.procedural: target model: 'ring_diameter'");
  expectError(parseScenario("servicer:\n  trajectory: {type: waypoints, times: [0, 5, 5], "
                            "positions: [[0,0,0],[1,0,0],[2,0,0]]}\n",
                            "s.yaml"),
              "servicer.trajectory.times = [0, 5, 5]: time 2 is not after time 1; expected "
              "strictly increasing times");
  // Sensor-level validation names the sensor too.
  expectError(parseScenario("sensors:\n  lidar: {min_range: 200}\n", "s.yaml"), {"s.yaml", 2, 10},
              "s.yaml:2:10: sensors.lidar: lidar: 'min_range' = 200 m is invalid");
}

TEST(ScenarioErrors, HaveTheSharedFormat) {
  // A missing file.
  const Result<Scenario> no_file = loadScenario("/nonexistent/scenario.yaml");
  expectError(no_file,
              "/nonexistent/scenario.yaml: cannot open scenario file; expected a readable "
              "YAML file");
  EXPECT_EQ(no_file.status().code(), StatusCode::kNotFound);
  // An unknown key at the top, with the accepted keys and the nearest one.
  expectError(parseScenario("duration: 10\nlightning: {eclipses: false}\n", "s.yaml"),
              {"s.yaml", 2, 1},
              "s.yaml:2:1: lightning: unknown key; expected one of {name, description, duration, "
              "seed, orbit, renderer, target, servicer, lighting, background, sensors, arm, "
              "calibration_error, faults, truth} (did you mean 'lighting'?)");
  // A malformed key: a section that is not a map.
  expectError(parseScenario("orbit: 500000\n", "s.yaml"), {"s.yaml", 1, 8},
              "s.yaml:1:8: orbit = 500000: expected the orbit {enabled, altitude} (a map of key: "
              "value)");
  // A value of the wrong type, and an element of a list.
  expectError(parseScenario("sensors:\n  imu: {noise: maybe}\n", "s.yaml"), {"s.yaml", 2, 16},
              "s.yaml:2:16: sensors.imu.noise = maybe: not a bool; expected true or false");
  expectError(
      parseScenario("servicer:\n  trajectory: {type: hold, position: [0, x, 0]}\n", "s.yaml"),
      {"s.yaml", 2, 42},
      "s.yaml:2:42: servicer.trajectory.position.1 = x: not a number; expected a number");
  expectError(
      parseScenario("target:\n  attitude: {rpy_deg: [0, 0]}\n", "s.yaml"), {"s.yaml", 2, 23},
      "s.yaml:2:23: target.attitude.rpy_deg = [0, 0]: has 2 values; expected a list of 3 numbers");
  // Out of range, with the range and its unit.
  expectError(parseScenario("sensors:\n  lidar: {elevations_deg: [0, 95]}\n", "s.yaml"),
              {"s.yaml", 2, 31},
              "s.yaml:2:31: sensors.lidar.elevations_deg.1 = 95: out of range; expected a number "
              "in (-90, 90) deg");
  expectError(parseScenario("renderer: {shadow_map_size: 10}\n", "s.yaml"), {"s.yaml", 1, 29},
              "s.yaml:1:29: renderer.shadow_map_size = 10: out of range; expected an integer in "
              "[64, 8192]");
  // A choice, with the nearest one.
  expectError(parseScenario("lighting:\n  sun: {preset: sid_lit}\n", "s.yaml"), {"s.yaml", 2, 17},
              "s.yaml:2:17: lighting.sun.preset = sid_lit: unknown value; expected one of "
              "{front_lit, side_lit, "
              "back_lit, near_fov} (did you mean 'side_lit'?)");
  // A required key.
  expectError(parseScenario("faults:\n  - {sensor: lidar}\n", "s.yaml"), {"s.yaml", 2, 5},
              "s.yaml:2:5: faults.0.type: missing; expected the fault's type");
  expectError(parseScenario("servicer:\n  trajectory: {type: line, start: [0, -9, 0]}\n", "s.yaml"),
              {"s.yaml", 2, 15},
              "s.yaml:2:15: servicer.trajectory.end: missing; expected the end position (lvlh, m)");
  // A misspelt built-in sensor is taken for a new one without a type: the nearest name helps.
  expectError(parseScenario("sensors:\n  camera_lft: {rate: 1}\n", "s.yaml"), {"s.yaml", 2, 15},
              "sensors.camera_lft.type: missing; expected a new sensor's type: one of {camera, "
              "lidar, tof, imu, radar, ahrs}; or the name of a built-in sensor (did you mean "
              "'camera_left'?)");
  expectError(parseScenario("faults:\n  - {type: glare, sensor: camera_lft}\n", "s.yaml"),
              "faults.0.sensor = camera_lft: no such sensor; expected a sensor a glare fault "
              "applies to: one of {camera_left, camera_right} or '*' (did you mean "
              "'camera_left'?)");
  // A fly-around axis parallel to the default reference points at the axis.
  expectError(
      parseScenario("servicer:\n  trajectory: {type: fly_around, axis: [0, 1, 0]}\n", "s.yaml"),
      {"s.yaml", 2, 40},
      "servicer.trajectory.axis = [0, 1, 0]: parallel to the reference; expected a "
      "direction not parallel to 'reference'");
}

TEST(ScenarioOverrides, SetDottedKeysAndReportThem) {
  auto s = parseScenario(
      "duration: 10\nfaults:\n  - {type: camera_failure, sensor: camera_right, start: 1, end: 2}\n",
      "s.yaml",
      {"sensors.lidar.range_noise=0.05", "duration=3.5", "faults.0.start=1.5",
       "sensors.camera_left.distortion=[-0.1, 0.02, 0, 0, 0]", "orbit.enabled=false"});
  ASSERT_OK(s.status());
  EXPECT_EQ(s->sensor("lidar")->lidar.range_noise, 0.05);
  EXPECT_EQ(s->duration, 3.5);
  EXPECT_EQ(s->faults[0].start, 1.5);
  EXPECT_EQ(s->sensor("camera_left")->camera.model.distortion[0], -0.1);
  EXPECT_FALSE(s->orbit.enabled);
  EXPECT_NE(s->yaml.find("range_noise: 0.05"), std::string::npos)
      << "the effective YAML records overrides";
  expectError(parseScenario("", "s.yaml", {"sensors.lidar.range_noise=-1"}),
              {"--set sensors.lidar.range_noise=-1", 0, 0},
              "--set sensors.lidar.range_noise=-1: sensors.lidar.range_noise = -1: out of range; "
              "expected a number in [0, 100] m");
  expectError(parseScenario("", "s.yaml", {"sensors.lidar.rang_noise=1"}),
              {"--set sensors.lidar.rang_noise=1", 0, 0},
              "--set sensors.lidar.rang_noise=1: sensors.lidar.rang_noise: unknown key; expected "
              "one of {type, enabled, rate, phase, latency, mount, active_range, elevations_deg, "
              "firing_cycle, laser_interval, min_range, max_range, range_noise, "
              "dropout_probability, spurious_rate, motion_during_scan} (did you mean "
              "'range_noise'?)");
  expectError(parseScenario("", "s.yaml", {"duration"}), "--set duration: expected KEY=VALUE");
  expectError(parseScenario("faults: []\n", "s.yaml", {"faults.2.start=1"}),
              "'faults.2' indexes a list of 0 items");
}

}  // namespace
}  // namespace cdff::egse
