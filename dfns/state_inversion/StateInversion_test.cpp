// StateInversion: the inverse composed with the state is the identity, its twist is the time
// derivative of the inverse along the motion, its covariance is the spread of sampled states
// inverted one by one, an unobserved attitude is stated as such, and bad input is reported.
#include <gtest/gtest.h>

#include <random>

#include "StateInversion.gen.hpp"
#include "cdff/types/geometry.hpp"
#include "support/dfn_testing.hpp"

namespace cdff::dfn {
namespace {

// lvlh_T_servicer 40 m behind the target, turned, drifting and turning slowly.
RigidBodyState lvlhTServicer() {
  RigidBodyState s;
  s.pose =
      Transform::fromIsometry(Eigen::Translation3d(0.5, -40.0, 1.2) *
                                  Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 3).normalized()),
                              "lvlh", "servicer", 5'000'000);
  s.twist.linear = {0.02, 0.3, -0.01};
  s.twist.angular = {0.001, -0.002, 0.003};
  std::mt19937 rng(3);  // the same covariance in every call
  std::uniform_real_distribution<double> uniform(-0.02, 0.02);
  Matrix12d a;
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j) a(i, j) = uniform(rng);
  s.covariance = a * a.transpose() + Matrix12d::Identity() * 1e-5;
  return s;
}

std::unique_ptr<StateInversion> make(const std::string& yaml = "{}") {
  return testing::makeDfn<StateInversion>("StateInversion", "Rigid", yaml);
}

// The state moved by dt along its twist (left perturbations in the parent frame).
RigidBodyState moved(const RigidBodyState& s, double dt) {
  RigidBodyState m = s;
  m.pose.translation += s.twist.linear * dt;
  m.pose.rotation = (expSO3(s.twist.angular * dt) * s.pose.rotation).normalized();
  return m;
}

RigidBodyState inverted(StateInversion& dfn, const RigidBodyState& s) {
  dfn.in.state.set(s);
  EXPECT_TRUE(dfn.process().isOk());
  return *dfn.out.state;
}

TEST(StateInversionRigid, InvertsThePoseAndTheTwist) {
  auto dfn = make("{child_frame: target}");
  const RigidBodyState s = lvlhTServicer();
  const RigidBodyState inv = inverted(*dfn, s);
  EXPECT_EQ(inv.pose.parent_frame, "servicer");
  EXPECT_EQ(inv.pose.child_frame, "target");
  EXPECT_EQ(inv.pose.stamp, s.pose.stamp);
  const Eigen::Isometry3d identity = s.pose.isometry() * inv.pose.isometry();
  EXPECT_LT((identity.matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
  // The twist: the inverse's derivative along the motion (central differences).
  const double dt = 1e-3;
  auto other = make();
  const RigidBodyState ahead = inverted(*other, moved(s, dt)),
                       behind = inverted(*other, moved(s, -dt));
  const Eigen::Vector3d velocity = (ahead.pose.translation - behind.pose.translation) / (2 * dt);
  const Eigen::Vector3d rate =
      logSO3(ahead.pose.rotation * behind.pose.rotation.conjugate()) / (2 * dt);
  EXPECT_LT((velocity - inv.twist.linear).norm(), 1e-6 * velocity.norm() + 1e-9);
  EXPECT_LT((rate - inv.twist.angular).norm(), 1e-6);
}

// 20000 states drawn from the covariance, inverted one by one: their errors against the
// inverse's, in its error-state convention, spread as the carried covariance says (entries
// within 5 standard errors of a sample covariance; the perturbations are small enough for the
// first order to hold to well below that).
TEST(StateInversionRigid, CarriesTheCovarianceThroughTheInversion) {
  auto dfn = make();
  RigidBodyState s = lvlhTServicer();
  s.covariance *= 1e-4;  // a small spread: the first order holds
  const RigidBodyState inv = inverted(*dfn, s);
  Eigen::LLT<Matrix12d> llt(s.covariance);
  const Matrix12d l = llt.matrixL();
  std::mt19937 rng(11);
  std::normal_distribution<double> normal;
  constexpr int kSamples = 20000;
  Matrix12d sample = Matrix12d::Zero();
  for (int k = 0; k < kSamples; ++k) {
    Eigen::Matrix<double, 12, 1> x;
    for (int i = 0; i < 12; ++i) x(i) = normal(rng);
    const Eigen::Matrix<double, 12, 1> d = l * x;
    RigidBodyState drawn = s;
    drawn.pose.translation += d.segment<3>(0);
    drawn.pose.rotation = (expSO3(d.segment<3>(3)) * s.pose.rotation).normalized();
    drawn.twist.linear += d.segment<3>(6);
    drawn.twist.angular += d.segment<3>(9);
    const RigidBodyState di = inverted(*dfn, drawn);
    Eigen::Matrix<double, 12, 1> e;
    e.segment<3>(0) = di.pose.translation - inv.pose.translation;
    e.segment<3>(3) = logSO3(di.pose.rotation * inv.pose.rotation.conjugate());
    e.segment<3>(6) = di.twist.linear - inv.twist.linear;
    e.segment<3>(9) = di.twist.angular - inv.twist.angular;
    sample += e * e.transpose() / kSamples;
  }
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j) {
      const double c = inv.covariance(i, j);
      const double standard_error =
          std::sqrt((c * c + inv.covariance(i, i) * inv.covariance(j, j)) / kSamples);
      EXPECT_NEAR(sample(i, j), c, 5 * standard_error) << "entry " << i << ", " << j;
    }
}

TEST(StateInversionRigid, StatesAnUnobservedAttitude) {
  auto dfn = make(
      "{child_frame: target, unobserved_attitude_sigma: 180, "
      "unobserved_angular_velocity_sigma: 11.459155902616464}");
  const RigidBodyState inv = inverted(*dfn, lvlhTServicer());
  EXPECT_NEAR(inv.covariance(3, 3), M_PI * M_PI, 1e-12);
  EXPECT_NEAR(inv.covariance(10, 10), 0.04, 1e-12);  // (0.2 rad/s)^2
  EXPECT_TRUE((inv.covariance.block<3, 3>(0, 3).isZero(0)));
  EXPECT_TRUE((inv.covariance.block<3, 3>(6, 9).isZero(0)));
  // The position's block is the inversion's all the same.
  auto plain = make();
  const RigidBodyState reference = inverted(*plain, lvlhTServicer());
  EXPECT_LT(
      (inv.covariance.topLeftCorner<3, 3>() - reference.covariance.topLeftCorner<3, 3>()).norm(),
      1e-15);
  Eigen::LLT<Matrix12d> llt(inv.covariance);
  EXPECT_EQ(llt.info(), Eigen::Success);
}

TEST(StateInversionRigid, RefusesABadState) {
  auto dfn = make();
  RigidBodyState s = lvlhTServicer();
  s.pose.translation.x() = std::nan("");
  dfn->in.state.set(s);
  const Status status = dfn->process();
  ASSERT_FALSE(status.isOk());
  EXPECT_NE(status.message().find("input 'state'"), std::string::npos) << status.message();
  EXPECT_FALSE(dfn->out.state.hasValue());
  s = lvlhTServicer();
  s.covariance(0, 1) += 1.0;  // not symmetric
  dfn->in.state.set(s);
  EXPECT_FALSE(dfn->process().isOk());
  // A negative standard deviation is refused when configured.
  auto node = Registry::instance().createAs<StateInversion>("StateInversion", "Rigid");
  ASSERT_TRUE(node.isOk());
  const Status configured = node.value()->configure(YAML::Load("{unobserved_attitude_sigma: -1}"));
  ASSERT_FALSE(configured.isOk());
  EXPECT_NE(configured.message().find("unobserved_attitude_sigma"), std::string::npos)
      << configured.message();
}

}  // namespace
}  // namespace cdff::dfn
