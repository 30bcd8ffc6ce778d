// The arm in the scenario library and the recordings: the haptic_scanning scenario runs the arm at
// its rate with the target where the World puts it, writes its joints, wrench and true contacts
// (on the target's surface, in the scan region), and bad `arm:` sections are errors at the
// scenario's file:line (a URDF that does not parse, at the URDF's).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "cdff/egse/simulator.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

Scenario haptic(const std::vector<std::string>& overrides = {}) {
  auto path = resolveScenario("haptic_scanning");
  EXPECT_TRUE(path.isOk()) << path.status().toString();
  auto scenario = loadScenario(*path, overrides);
  EXPECT_TRUE(scenario.isOk()) << scenario.status().toString();
  return std::move(scenario).value();
}

TEST(SimulatorArm, TheHapticScenarioRecordsJointsWrenchAndTrueContacts) {
  const Scenario scenario = haptic();
  ASSERT_TRUE(scenario.arm.enabled);
  const CollisionPathSpec& paths = scenario.arm.spec.paths;
  auto sim = Simulator::create(scenario, 7, 8.0);
  ASSERT_OK(sim.status());
  MemorySink sink;
  ASSERT_OK((*sim)->run(sink));
  // Every 1 ms, joints and wrench at the same stamps; the arm's mounting; the target's pose in
  // the arm's base at the truth's rate.
  const auto joints = sink.on<JointState>("/chaser/arm/joints");
  const auto wrenches = sink.on<Wrench>("/chaser/arm/wrench");
  ASSERT_EQ(joints.size(), 8000u);
  ASSERT_EQ(wrenches.size(), joints.size());
  for (std::size_t i = 0; i < joints.size(); ++i) {
    ASSERT_EQ(joints[i].stamp, static_cast<Timestamp>(i + 1) * 1000) << i;
    ASSERT_EQ(wrenches[i].stamp, joints[i].stamp) << i;
    ASSERT_EQ(joints[i].names.size(), 7u);
    ASSERT_EQ(wrenches[i].frame_id, "ft_sensor");
  }
  const auto mount = sink.on<Transform>("/chaser/tf/base_link");
  ASSERT_EQ(mount.size(), 1u);
  EXPECT_TRUE(mount[0].isometry().isApprox(scenario.arm.servicer_T_base, 1e-12));
  const auto target_poses = sink.on<PoseWithCovariance>("/truth/arm/target_pose");
  EXPECT_EQ(target_poses.size(), 401u);  // 50 Hz over 8 s, both ends
  const auto servicer_poses = sink.on<PoseWithCovariance>("/truth/target_pose");
  ASSERT_EQ(servicer_poses.size(), target_poses.size());
  for (std::size_t i = 0; i < target_poses.size(); ++i)
    EXPECT_TRUE((scenario.arm.servicer_T_base * target_poses[i].pose.isometry())
                    .isApprox(servicer_poses[i].pose.isometry(), 1e-9));
  // True contacts: on the target's +x face (x = 0.6 m), in the scan region (the aim within
  // region_radius; the contact slides by less than the tip's radius), pushing.
  const auto contacts = sink.on<PointCloud>("/truth/arm/contact");
  const auto forces = sink.on<Wrench>("/truth/arm/contact_force");
  ASSERT_GT(contacts.size(), 100u) << "some presses in 8 s";
  ASSERT_EQ(forces.size(), contacts.size());
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const PointCloud& c = contacts[i];
    ASSERT_EQ(c.frame_id, "target");
    const Eigen::Vector3d p = c.points[0].vec().cast<double>();
    EXPECT_NEAR(p.x(), 0.6, 1e-6) << i;
    EXPECT_LT((p - paths.region_centre).norm(), paths.region_radius + 0.01) << i;
    EXPECT_NEAR(c.normals[0].vec().x(), 1.0, 1e-6) << i;
    EXPECT_GT(c.intensity[0], 0.0f);
    EXPECT_LT(c.intensity[0], 2 * paths.press_force);
    EXPECT_NEAR(forces[i].force.dot(Eigen::Vector3d::UnitX()), c.intensity[0], 1e-4) << i;
  }
}

TEST(SimulatorArm, BadArmSectionsAreErrorsAtTheirLine) {
  const std::filesystem::path base = scenarioDirectory();
  auto parse = [&](const std::string& yaml) { return parseScenario(yaml, "s.yaml", {}, base); };
  auto missing = parse("duration: 5\narm:\n  description: ../arms/no_such_arm.urdf\n");
  ASSERT_FALSE(missing.isOk());
  EXPECT_EQ(missing.status().location().line, 3) << missing.status().toString();
  EXPECT_NE(missing.status().message().find("no_such_arm.urdf' does not exist"), std::string::npos)
      << missing.status().toString();
  auto region =
      parse("arm:\n  description: ../arms/servicer_arm.urdf\n  paths: {region_radius: -0.1}\n");
  ASSERT_FALSE(region.isOk());
  EXPECT_EQ(region.status().location().line, 3) << region.status().toString();
  EXPECT_NE(region.status().message().find("arm.paths.region_radius = -0.1"), std::string::npos)
      << region.status().toString();
  auto no_description = parse("arm: {rate: 500}\n");
  ASSERT_FALSE(no_description.isOk());
  EXPECT_NE(no_description.status().message().find("no 'description'"), std::string::npos)
      << no_description.status().toString();
  auto unknown = parse("arm: {description: ../arms/servicer_arm.urdf, rates: 500}\n");
  ASSERT_FALSE(unknown.isOk());
  EXPECT_NE(unknown.status().message().find("did you mean 'rate'"), std::string::npos)
      << unknown.status().toString();
}

TEST(SimulatorArm, AUrdfThatDoesNotParseIsAnErrorAtItsLine) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / fmt::format("broken_arm_{}.urdf", ::getpid());
  {
    std::ofstream out(file);
    out << "<?xml version=\"1.0\"?>\n<robot name=\"arm\">\n  <link name=\"base_link\">\n</robot>\n";
  }
  Scenario scenario = haptic();
  scenario.arm.spec.description = file.string();
  auto sim = Simulator::create(scenario, 1, 1.0);
  std::filesystem::remove(file);
  ASSERT_FALSE(sim.isOk());
  EXPECT_NE(sim.status().toString().find(file.string() + ":"), std::string::npos)
      << sim.status().toString();
  std::printf("%s\n", sim.status().toString().c_str());
}

TEST(SimulatorArm, ScanRegionOffTheTargetIsRefused) {
  Scenario scenario = haptic({"arm.paths.region_centre=[5,5,5]", "arm.paths.region_radius=0.1"});
  auto sim = Simulator::create(scenario, 1, 1.0);
  ASSERT_FALSE(sim.isOk());
  EXPECT_NE(sim.status().message().find("no surface of"), std::string::npos)
      << sim.status().toString();
}

}  // namespace
}  // namespace cdff::egse
