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
        "earth_background", "sensor_faults"})
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
      "s.yaml:4:5: unknown key 'sensors.camera_left.exposur_time' (did you mean 'exposure_time'?)");
  expectError(
      parseScenario("duration: 10\nsensors:\n  camera_left: {exposure_time: -0.002}\n", "s.yaml"),
      "s.yaml:3:32: sensors.camera_left.exposure_time = -0.002: expected a number in (0, 10] s");
  expectError(parseScenario("duration: ten\n", "s.yaml"),
              "s.yaml:1:11: duration = ten: expected a number");
  expectError(
      parseScenario("servicer:\n  trajectory: {type: spiral}\n", "s.yaml"),
      "servicer.trajectory.type = spiral: expected one of {hold, line, waypoints, fly_around, cw}");
  expectError(parseScenario("faults:\n  - {type: glare, sensor: lidar}\n", "s.yaml"),
              "s.yaml:2:27: faults.0.sensor = lidar: expected a sensor a glare fault applies to: "
              "one of {camera_left, camera_right} or '*'");
  expectError(
      parseScenario("target: {model: missing.obj}\n", "s.yaml", {}, "/nonexistent"),
      "target.model = missing.obj: the mesh file '/nonexistent/missing.obj' does not exist");
  expectError(parseScenario("sensors:\n  star_tracker: {rate: 1}\n", "s.yaml"),
              "sensors.star_tracker: a new sensor needs a 'type'");
  expectError(parseScenario("duration: [1, 2\n", "s.yaml"), "s.yaml:2:1: invalid YAML");
  expectError(parseScenario("target:\n  procedural: {ring_diameter: 2.5}\n", "s.yaml"),
              "target.procedural: target model: 'ring_diameter'");
  expectError(parseScenario("servicer:\n  trajectory: {type: waypoints, times: [0, 5, 5], "
                            "positions: [[0,0,0],[1,0,0],[2,0,0]]}\n",
                            "s.yaml"),
              "servicer.trajectory.times = [0, 5, 5]: expected strictly increasing times");
  // Sensor-level validation names the sensor too.
  expectError(parseScenario("sensors:\n  lidar: {min_range: 200}\n", "s.yaml"),
              "lidar: 'min_range' = 200 m is invalid");
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
              "--set sensors.lidar.range_noise=-1: sensors.lidar.range_noise = -1: expected a "
              "number in [0, 100] m");
  expectError(parseScenario("", "s.yaml", {"sensors.lidar.rang_noise=1"}),
              "--set sensors.lidar.rang_noise=1: unknown key 'sensors.lidar.rang_noise' (did you "
              "mean 'range_noise'?)");
  expectError(parseScenario("", "s.yaml", {"duration"}), "--set duration: expected KEY=VALUE");
  expectError(parseScenario("faults: []\n", "s.yaml", {"faults.2.start=1"}),
              "'faults.2' indexes a list of 0 items");
}

}  // namespace
}  // namespace cdff::egse
