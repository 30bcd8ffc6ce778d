// StateFromPose: the pose and its covariance pass unchanged, the twist is zero with the stated
// prior, a zero covariance needs the stated sigmas, and bad inputs are reported.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "StateFromPose.gen.hpp"
#include "cdff/types/geometry.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr double kDeg = M_PI / 180.0;

PoseWithCovariance detection() {
  PoseWithCovariance p;
  p.pose =
      Transform::fromIsometry(Eigen::Translation3d(0.3, -0.2, 7.5) *
                                  Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, 1, 0).normalized()),
                              "servicer", "target", 4'000'000);
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Random() * 0.01;
  p.covariance = a * a.transpose() + Matrix6d::Identity() * 1e-6;
  return p;
}

std::unique_ptr<StateFromPose> make(const std::string& yaml) {
  return testing::makeDfn<StateFromPose>("StateFromPose", "UnknownTwist", yaml);
}

TEST(StateFromPoseUnknownTwist, KeepsThePoseAndStatesTheUnknownTwist) {
  auto dfn = make("{linear_velocity_sigma: 0.2, angular_velocity_sigma: 3}");
  const PoseWithCovariance in = detection();
  dfn->in.pose.set(in);
  ASSERT_OK(dfn->process());
  ASSERT_TRUE(dfn->out.state.hasValue());
  const RigidBodyState& s = *dfn->out.state;
  EXPECT_EQ(s.pose.parent_frame, "servicer");
  EXPECT_EQ(s.pose.child_frame, "target");
  EXPECT_EQ(s.pose.stamp, in.pose.stamp);
  EXPECT_TRUE(s.pose.translation.isApprox(in.pose.translation));
  EXPECT_LT(angularDistance(s.pose.rotation, in.pose.rotation), 1e-12);
  EXPECT_TRUE(s.twist.linear.isZero(0));
  EXPECT_TRUE(s.twist.angular.isZero(0));
  EXPECT_TRUE((s.covariance.topLeftCorner<6, 6>().isApprox(in.covariance)));
  Matrix6d twist = Matrix6d::Zero();
  twist.diagonal() << Eigen::Vector3d::Constant(0.04),
      Eigen::Vector3d::Constant(std::pow(3 * kDeg, 2));
  EXPECT_TRUE((s.covariance.bottomRightCorner<6, 6>().isApprox(twist, 1e-12)));
  EXPECT_TRUE((s.covariance.topRightCorner<6, 6>().isZero(0)));
  EXPECT_TRUE((s.covariance.bottomLeftCorner<6, 6>().isZero(0)));
  EXPECT_OK(s.validate());
}

TEST(StateFromPoseUnknownTwist, AZeroCovarianceNeedsTheStatedSigmas) {
  PoseWithCovariance exact = detection();
  exact.covariance.setZero();
  auto refusing = make("{}");
  refusing->in.pose.set(exact);
  testing::expectRejected(*refusing, "has a zero covariance");

  auto stated = make("{position_sigma: 0.5, attitude_sigma: 10}");
  stated->in.pose.set(exact);
  ASSERT_OK(stated->process());
  const Matrix12d& c = stated->out.state->covariance;
  EXPECT_DOUBLE_EQ(c(0, 0), 0.25);
  EXPECT_DOUBLE_EQ(c(5, 5), std::pow(10 * kDeg, 2));
}

TEST(StateFromPoseUnknownTwist, BadInputsAreReported) {
  auto dfn = make("{}");
  PoseWithCovariance indefinite = detection();
  indefinite.covariance(4, 4) = -1e-3;
  indefinite.covariance(1, 4) = indefinite.covariance(4, 1) = 0;
  dfn->in.pose.set(indefinite);
  EXPECT_FALSE(dfn->process().isOk());

  PoseWithCovariance nan = detection();
  nan.pose.translation.x() = std::numeric_limits<double>::quiet_NaN();
  dfn->in.pose.set(nan);
  EXPECT_FALSE(dfn->process().isOk());

  for (const char* bad :
       {"{position_sigma: 0.5}", "{linear_velocity_sigma: 0}", "{angular_velocity_sigma: -1}"}) {
    auto d = dfn::Registry::instance().createAs<StateFromPose>("StateFromPose", "UnknownTwist");
    ASSERT_OK(d.status());
    EXPECT_FALSE(d.value()->configure(YAML::Load(bad)).isOk()) << bad;
  }
}

}  // namespace
}  // namespace cdff::dfn
