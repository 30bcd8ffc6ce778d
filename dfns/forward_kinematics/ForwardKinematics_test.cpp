// ForwardKinematics/Kdl: the servicer arm's tool and sensor poses against poses worked out from
// its link lengths, joints matched by name, and bad joints and bad descriptions reported.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "ForwardKinematics.gen.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr double kDeg = M_PI / 180.0;
const std::string kArm = std::string(CDFF_SOURCE_DIR) + "/data/arms/servicer_arm.urdf";

std::unique_ptr<ForwardKinematics> make(const std::string& extra = "") {
  return testing::makeDfn<ForwardKinematics>("ForwardKinematics", "Kdl",
                                             "{description: " + kArm + extra + "}");
}

JointState joints(const std::vector<double>& q, Timestamp stamp = 5000) {
  JointState s;
  s.stamp = stamp;
  for (std::size_t i = 0; i < q.size(); ++i) s.names.push_back("joint_" + std::to_string(i + 1));
  s.position = q;
  return s;
}

TEST(ForwardKinematicsKdl, GivesTheToolPoseOfTheLinkLengths) {
  auto dfn = make();
  // The shoulder pitched by 90 deg lays the rest of the arm (0.4 + 0.4 + 0.1 + 0.05 + 0.12 m)
  // along the base's x at the shoulder's height (0.35 m); the wrist roll turns the tool about
  // its own axis only.
  dfn->in.joints.set(joints({0, 90 * kDeg, 0, 0, 0, 0, 30 * kDeg}));
  ASSERT_OK(dfn->process());
  const Transform& pose = *dfn->out.pose;
  EXPECT_EQ(pose.parent_frame, "base_link");
  EXPECT_EQ(pose.child_frame, "tool_tip");
  EXPECT_EQ(pose.stamp, 5000);
  EXPECT_LT((pose.translation - Eigen::Vector3d(1.07, 0, 0.35)).norm(), 1e-12);
  const Eigen::Quaterniond expected(Eigen::AngleAxisd(90 * kDeg, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d::UnitZ()));
  EXPECT_LT(angularDistance(pose.rotation, expected), 1e-12);

  // The elbow bent by 90 deg: the forearm and tool (0.2 + 0.2 + 0.1 + 0.05 + 0.12 m) turn about
  // -y, from up to -x, the upper arm (to 0.75 m) stays up.
  dfn->in.joints.set(joints({0, 0, 0, 90 * kDeg, 0, 0, 0}));
  ASSERT_OK(dfn->process());
  EXPECT_LT((dfn->out.pose->translation - Eigen::Vector3d(-0.67, 0, 0.75)).norm(), 1e-12);
}

TEST(ForwardKinematicsKdl, MatchesJointsByNameAndGivesAnyLinkOfTheChain) {
  auto dfn = make(", link: ft_sensor");
  JointState s = joints({0, 90 * kDeg, 0, 0, 0, 0, 0});
  // Shuffled, with a gripper's joint the chain does not have.
  std::swap(s.names[0], s.names[1]);
  std::swap(s.position[0], s.position[1]);
  s.names.push_back("gripper");
  s.position.push_back(0.02);
  dfn->in.joints.set(s);
  ASSERT_OK(dfn->process());
  EXPECT_EQ(dfn->out.pose->child_frame, "ft_sensor");
  EXPECT_LT((dfn->out.pose->translation - Eigen::Vector3d(0.95, 0, 0.35)).norm(), 1e-12);
}

TEST(ForwardKinematicsKdl, BadJointsAreFaultsWithoutAPose) {
  auto dfn = make(", limit_margin: 1");
  std::vector<double> q(7, 0.1);
  q[2] = std::numeric_limits<double>::quiet_NaN();
  dfn->in.joints.set(joints(q));
  testing::expectRejected(*dfn, "joint state position of 'joint_3' is nan");
  q[2] = 0.1;
  q[5] = 122 * kDeg;  // beyond +120 deg by more than the 1 deg margin
  dfn->in.joints.set(joints(q));
  testing::expectRejected(*dfn, "joint 'joint_6' is at 122.0000 deg, outside its limits");
  q[5] = 120.5 * kDeg;  // within the margin: an encoder's overshoot
  dfn->in.joints.set(joints(q));
  EXPECT_OK(dfn->process());
  JointState missing = joints({0, 0, 0, 0, 0, 0});
  dfn->in.joints.set(missing);
  testing::expectRejected(*dfn, "no position of joint 'joint_7'");
}

TEST(ForwardKinematicsKdl, BadDescriptionsAreReportedWithTheFileAndLine) {
  auto configure = [](const std::string& yaml) {
    auto d = dfn::Registry::instance().createAs<ForwardKinematics>("ForwardKinematics", "Kdl");
    EXPECT_TRUE(d.isOk());
    return d.value()->configure(YAML::Load(yaml));
  };
  // The default (no description) configures, but gives no pose.
  auto empty = testing::makeDfn<ForwardKinematics>("ForwardKinematics", "Kdl", "{}");
  empty->in.joints.set(joints(std::vector<double>(7, 0.0)));
  testing::expectRejected(*empty, "parameter 'description' is empty",
                          StatusCode::kInvalidParameter);
  const Status missing = configure("{description: /nonexistent/arm.urdf}");
  EXPECT_EQ(missing.code(), StatusCode::kNotFound);
  EXPECT_NE(missing.message().find("/nonexistent/arm.urdf"), std::string::npos);
  const Status no_link = configure("{description: " + kArm + ", link: gripper}");
  EXPECT_NE(no_link.message().find("no link 'gripper'"), std::string::npos) << no_link.message();

  const std::string broken = ::testing::TempDir() + "/broken_arm.urdf";
  std::ofstream(broken) << "<robot name=\"arm\">\n  <link name=\"a\">\n  <link name=\"b\"/>\n";
  const Status bad = configure("{description: " + broken + "}");
  EXPECT_EQ(bad.code(), StatusCode::kCorruptData);
  EXPECT_EQ(bad.location().file, broken);
  EXPECT_GT(bad.location().line, 0);
  EXPECT_NE(bad.message().find(broken + ":"), std::string::npos) << bad.message();
  std::remove(broken.c_str());
  EXPECT_FALSE(configure("{description: " + kArm + ", limit_margin: -1}").isOk());
}

}  // namespace
}  // namespace cdff::dfn
