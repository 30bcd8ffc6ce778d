// ArmModel: the servicer arm's URDF read into a 7-joint chain, forward kinematics against poses
// worked out by hand, the inverse against the forward, and every kind of bad description and bad
// joint value reported with what, where and which value.
#include "cdff/kinematics/arm_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace cdff::kinematics {
namespace {

constexpr double kDeg = M_PI / 180.0;
const std::string kArm = std::string(CDFF_SOURCE_DIR) + "/data/arms/servicer_arm.urdf";

ArmModel servicerArm(const std::string& tip = "tool_tip") {
  Result<ArmModel> arm = ArmModel::load(kArm, "base_link", tip);
  EXPECT_TRUE(arm.isOk()) << arm.status().toString();
  return std::move(arm).value();
}

TEST(ArmModel, ReadsTheSevenJointChainWithItsLimitsAndTip) {
  const ArmModel arm = servicerArm();
  ASSERT_EQ(arm.jointCount(), 7u);
  for (std::size_t i = 0; i < 7; ++i) {
    EXPECT_EQ(arm.joints()[i].name, "joint_" + std::to_string(i + 1));
    EXPECT_GT(arm.joints()[i].line, 0);
    EXPECT_DOUBLE_EQ(arm.joints()[i].velocity, 1.5);
  }
  EXPECT_NEAR(arm.joints()[1].upper, 120 * kDeg, 1e-6);
  EXPECT_NEAR(arm.joints()[6].lower, -175 * kDeg, 1e-6);
  EXPECT_DOUBLE_EQ(arm.tipSphereRadius(), 0.01);
}

TEST(ArmModel, ForwardKinematicsMatchesTheLinkLengths) {
  const ArmModel arm = servicerArm();
  std::vector<double> q(7, 0.0);
  // Stretched out: every link along the base's z (0.15 + 4 x 0.2 + 0.1 + 0.05 + 0.12 m).
  Eigen::Isometry3d tip = arm.forward(q);
  EXPECT_TRUE(tip.translation().isApprox(Eigen::Vector3d(0, 0, 1.42), 1e-12));
  EXPECT_TRUE(tip.linear().isIdentity(1e-12));
  // The shoulder pitched by +90 deg about y turns the rest of the arm (1.07 m) onto +x.
  q[1] = 90 * kDeg;
  tip = arm.forward(q);
  EXPECT_LT((tip.translation() - Eigen::Vector3d(1.07, 0, 0.35)).norm(), 1e-12);
  EXPECT_TRUE(tip.linear().isApprox(
      Eigen::AngleAxisd(90 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix(), 1e-12));
  // The wrist sensor sits 0.12 m behind the tip along the tool's axis.
  Result<Eigen::Isometry3d> sensor = arm.forwardTo(q, "ft_sensor");
  ASSERT_TRUE(sensor.isOk());
  EXPECT_LT((sensor->translation() - Eigen::Vector3d(0.95, 0, 0.35)).norm(), 1e-12);
  EXPECT_FALSE(arm.forwardTo(q, "nowhere").isOk());
}

TEST(ArmModel, InverseKinematicsReachesForwardPoses) {
  const ArmModel arm = servicerArm();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<double> q(7), seed(7);
    for (std::size_t i = 0; i < 7; ++i) {
      q[i] = 0.8 * arm.joints()[i].upper * unit(rng);
      seed[i] = q[i] + 0.1 * unit(rng);  // a nearby configuration, as a path follower has
    }
    const Eigen::Isometry3d target = arm.forward(q);
    Result<std::vector<double>> solved = arm.inverse(target, seed);
    ASSERT_TRUE(solved.isOk()) << solved.status().toString();
    const Eigen::Isometry3d reached = arm.forward(*solved);
    EXPECT_LT((reached.translation() - target.translation()).norm(), 1e-8);
    // A microradian: 1.4 um at the arm's reach, three orders below the haptic goal of 1 mm.
    EXPECT_LT(
        Eigen::Quaterniond(reached.linear()).angularDistance(Eigen::Quaterniond(target.linear())),
        1e-6);
  }
  // Beyond the reach (1.42 m from the base) there is no solution.
  EXPECT_FALSE(arm.inverse(Eigen::Isometry3d(Eigen::Translation3d(2.0, 0, 0.35)),
                           std::vector<double>(7, 0.1))
                   .isOk());
}

TEST(ArmModel, APosturePullMovesTheElbowAndNotTheTip) {
  const ArmModel arm = servicerArm();
  const std::vector<double> from = {0.3, 0.4, -0.2, -1.5, 0.3, -0.8, 0.2};
  const Eigen::Isometry3d tip = arm.forward(from);
  // Another posture with the same tip pose: the solver started from the upper arm rolled by
  // 0.6 rad stays near it, on the 7-joint arm's one-dimensional self-motion.
  std::vector<double> rolled = from;
  rolled[2] += 0.6;
  Result<std::vector<double>> other = arm.inverse(tip, rolled);
  ASSERT_TRUE(other.isOk()) << other.status().toString();
  auto gap = [&](const std::vector<double>& q) {
    double sum = 0;
    for (std::size_t i = 0; i < q.size(); ++i) sum += (q[i] - (*other)[i]) * (q[i] - (*other)[i]);
    return std::sqrt(sum);
  };
  ASSERT_GT(gap(from), 0.3);
  // Without a pull the solver keeps the seed that already reaches the pose.
  Result<std::vector<double>> kept = arm.inverse(tip, from);
  ASSERT_TRUE(kept.isOk());
  EXPECT_LT(gap(*kept), gap(from) + 1e-9);
  EXPECT_GT(gap(*kept), gap(from) - 1e-9);
  // Pulled by 5 % a call, the posture comes to the other one as (0.95)^n, the tip held.
  const PosturePull pull{*other, 0.05};
  std::vector<double> q = from;
  double last = gap(q);
  for (int call = 0; call < 200; ++call) {
    Result<std::vector<double>> next = arm.inverse(tip, q, 1e-9, &pull);
    ASSERT_TRUE(next.isOk()) << next.status().toString();
    q = std::move(next).value();
    EXPECT_LT((arm.forward(q).translation() - tip.translation()).norm(), 1e-9);
    EXPECT_LT(gap(q), last);
    last = gap(q);
  }
  // 0.95^200 = 3.5e-5 of the first gap, were the self-motion straight: a curve, within 1e-3.
  EXPECT_LT(gap(q), 1e-3 * gap(from));

  const std::vector<double> short_posture(6, 0.0);
  const PosturePull wrong_size{short_posture, 0.1};
  Result<std::vector<double>> bad = arm.inverse(tip, from, 1e-6, &wrong_size);
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find("has 6 joints; expected 7"), std::string::npos)
      << bad.status().message();
  const PosturePull too_far{*other, 1.5};
  bad = arm.inverse(tip, from, 1e-6, &too_far);
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find("fraction 1.5; expected [0, 1]"), std::string::npos)
      << bad.status().message();
}

TEST(ArmModel, BadJointValuesNameTheJointTheValueAndTheLimits) {
  const ArmModel arm = servicerArm();
  std::vector<double> q(7, 0.0);
  EXPECT_TRUE(arm.checkJoints(q, 0.0, "joints").isOk());
  q[3] = std::numeric_limits<double>::quiet_NaN();
  Status s = arm.checkJoints(q, 0.0, "joints");
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("joint 'joint_4' is nan"), std::string::npos) << s.message();
  q[3] = 125 * kDeg;
  s = arm.checkJoints(q, 1 * kDeg, "joints");
  EXPECT_NE(s.message().find("joint 'joint_4' is at 125.0000 deg, outside its limits "
                             "[-120.0000 deg, 120.0000 deg]"),
            std::string::npos)
      << s.message();
  EXPECT_NE(s.message().find("servicer_arm.urdf:"), std::string::npos) << s.message();
  EXPECT_TRUE(arm.checkJoints(q, 6 * kDeg, "joints").isOk());  // within a wider margin
  EXPECT_FALSE(arm.checkJoints(std::vector<double>(6, 0.0), 0.0, "joints").isOk());

  JointState state;
  state.names = {"joint_1", "joint_2"};
  state.position = {0.0, 0.0};
  Result<std::vector<double>> matched = arm.positionsOf(state, "input 'joints'");
  ASSERT_FALSE(matched.isOk());
  EXPECT_NE(matched.status().message().find("no position of joint 'joint_3'"), std::string::npos);
}

const char* kTwoJoints = R"(<?xml version="1.0"?>
<robot name="small">
  <link name="a"/>
  <link name="b"/>
  <link name="c"/>
  <joint name="j1" type="revolute">
    <parent link="a"/><child link="b"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="b"/><child link="c"/>
    <axis xyz="0 1 0"/>
  </joint>
</robot>
)";

TEST(ArmModel, BadDescriptionsAreReportedWithTheFileAndLine) {
  // Not XML: the XML parser's line.
  Result<ArmModel> broken = ArmModel::fromString(
      "<robot name=\"x\">\n  <link name=\"a\">\n</robot>", "broken.urdf", "a", "a");
  ASSERT_FALSE(broken.isOk());
  EXPECT_EQ(broken.status().code(), StatusCode::kCorruptData);
  EXPECT_EQ(broken.status().location().file, "broken.urdf");
  EXPECT_GT(broken.status().location().line, 0) << broken.status().message();

  // A revolute joint without limits is not a URDF: urdfdom's reason at the joint's line.
  Result<ArmModel> no_limits = ArmModel::fromString(kTwoJoints, "small.urdf", "a", "c");
  ASSERT_FALSE(no_limits.isOk());
  EXPECT_EQ(no_limits.status().code(), StatusCode::kCorruptData);
  EXPECT_NE(no_limits.status().message().find("small.urdf:10:"), std::string::npos)
      << no_limits.status().message();
  EXPECT_NE(no_limits.status().message().find("j2"), std::string::npos)
      << no_limits.status().message();

  // Links that are not there, or not a chain from the base to the tip.
  EXPECT_EQ(ArmModel::load(kArm, "base_link", "gripper").status().code(), StatusCode::kNotFound);
  Result<ArmModel> upside_down = ArmModel::load(kArm, "tool_tip", "base_link");
  ASSERT_FALSE(upside_down.isOk());
  EXPECT_NE(upside_down.status().message().find("is not below link 'tool_tip'"), std::string::npos)
      << upside_down.status().message();
  Result<ArmModel> missing = ArmModel::load("/nonexistent/arm.urdf", "a", "b");
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find("/nonexistent/arm.urdf"), std::string::npos);
}

}  // namespace
}  // namespace cdff::kinematics
