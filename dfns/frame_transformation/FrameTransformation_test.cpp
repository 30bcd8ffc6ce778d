// FrameTransformation: a pose moved to the servicer frame and back is the pose again, points
// mapped through the result agree with mapping them through both transforms, the covariance turns
// with the frame (the spread of sampled poses moved one by one), other calibrations are ignored
// and bad inputs are reported.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "FrameTransformation.gen.hpp"
#include "cdff/types/geometry.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

Transform servicerTLidar() {
  return Transform::fromIsometry(Eigen::Translation3d(0.45, 0.0, -0.2) *
                                     Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()),
                                 "servicer", "lidar");
}

PoseWithCovariance lidarTTarget() {
  PoseWithCovariance p;
  p.pose = Transform::fromIsometry(
      Eigen::Translation3d(1.0, -2.0, 7.5) * Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitY()),
      "lidar", "target", 1234);
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Random() * 0.01;
  p.covariance = a * a.transpose() + Matrix6d::Identity() * 1e-6;
  return p;
}

std::unique_ptr<FrameTransformation> make(const std::string& yaml = "{}") {
  return testing::makeDfn<FrameTransformation>("FrameTransformation", "Rigid", yaml);
}

TEST(FrameTransformationRigid, ToTheParentFrameAndBackIsTheIdentity) {
  auto forward = make();
  auto back = make("{inverse: true}");
  // A camera's calibration comes first and must be ignored.
  forward->in.extrinsic.set(
      Transform::fromIsometry(Eigen::Isometry3d::Identity(), "servicer", "camera_left"));
  ASSERT_OK(forward->process());
  forward->in.extrinsic.set(servicerTLidar());
  ASSERT_OK(forward->process());
  EXPECT_FALSE(forward->out.pose.hasValue());
  const PoseWithCovariance z = lidarTTarget();
  forward->in.pose.set(z);
  ASSERT_OK(forward->process());
  const PoseWithCovariance& s = *forward->out.pose;
  EXPECT_EQ(s.pose.parent_frame, "servicer");
  EXPECT_EQ(s.pose.child_frame, "target");
  EXPECT_EQ(s.pose.stamp, 1234);
  const Eigen::Vector3d p(0.3, -0.7, 1.9);  // a point on the target
  EXPECT_LT((s.pose * p - servicerTLidar() * (z.pose * p)).norm(), 1e-12);

  back->in.extrinsic.set(servicerTLidar());
  back->in.transform.set(s.pose);
  back->in.pose.set(s);
  ASSERT_OK(back->process());
  EXPECT_EQ(back->out.transform->parent_frame, "lidar");
  EXPECT_LT((back->out.transform->isometry().matrix() - z.pose.isometry().matrix()).norm(), 1e-12);
  EXPECT_LT((back->out.pose->covariance - z.covariance).norm(), 1e-15);
}

TEST(FrameTransformationRigid, TheCovarianceTurnsWithTheFrame) {
  // Sample perturbed lidar poses from the covariance, move each, and compare the spread of the
  // moved poses (perturbations in the servicer frame) with the output covariance.
  auto forward = make();
  forward->in.extrinsic.set(servicerTLidar());
  const PoseWithCovariance z = lidarTTarget();
  forward->in.pose.set(z);
  ASSERT_OK(forward->process());
  const Transform s = forward->out.pose->pose;
  const Eigen::LLT<Matrix6d> llt(z.covariance);
  std::mt19937 rng(3);
  std::normal_distribution<double> n;
  constexpr int kSamples = 20000;
  Matrix6d spread = Matrix6d::Zero();
  for (int k = 0; k < kSamples; ++k) {
    Vector6d d;
    for (int i = 0; i < 6; ++i) d[i] = n(rng);
    d = llt.matrixL() * d;
    Transform perturbed = z.pose;
    perturbed.translation += d.head<3>();
    perturbed.rotation = expSO3(d.tail<3>()) * z.pose.rotation;
    const Transform moved = servicerTLidar().compose(perturbed).value();
    Vector6d e;
    e.head<3>() = moved.translation - s.translation;
    e.tail<3>() = logSO3(moved.rotation * s.rotation.conjugate());
    spread += e * e.transpose() / kSamples;
  }
  // Sampling error of a covariance over 20 000 samples: about 1 % of the entries' scale.
  EXPECT_LT((spread - forward->out.pose->covariance).norm(),
            0.03 * forward->out.pose->covariance.norm());
}

// A rigid-body state: the moved twist is the velocity of the moved pose (a finite difference of
// two poses a short time apart, each moved), and its covariance blocks turn as the pose's do.
TEST(FrameTransformationRigid, AStateKeepsItsMotion) {
  auto forward = make();
  forward->in.extrinsic.set(servicerTLidar());
  RigidBodyState z;
  z.pose = lidarTTarget().pose;
  z.twist.linear = Eigen::Vector3d(0.3, -0.1, -0.8);
  z.twist.angular = Eigen::Vector3d(0.02, 0.05, -0.03);
  Eigen::Matrix<double, 12, 12> a = Eigen::Matrix<double, 12, 12>::Random() * 0.01;
  z.covariance = a * a.transpose() + Matrix12d::Identity() * 1e-6;
  forward->in.state.set(z);
  ASSERT_OK(forward->process());
  ASSERT_TRUE(forward->out.state.hasValue());
  const RigidBodyState& s = *forward->out.state;
  EXPECT_EQ(s.pose.parent_frame, "servicer");
  EXPECT_EQ(s.pose.child_frame, "target");
  EXPECT_EQ(s.pose.stamp, 1234);
  EXPECT_LT(
      (s.pose.isometry().matrix() - (servicerTLidar().isometry() * z.pose.isometry()).matrix())
          .norm(),
      1e-12);

  constexpr double kDt = 1e-6;
  Transform later = z.pose;
  later.translation += kDt * z.twist.linear;
  later.rotation = expSO3(kDt * z.twist.angular) * z.pose.rotation;
  const Transform moved_later = servicerTLidar().compose(later).value();
  const Eigen::Vector3d v = (moved_later.translation - s.pose.translation) / kDt;
  const Eigen::Vector3d w = logSO3(moved_later.rotation * s.pose.rotation.conjugate()) / kDt;
  EXPECT_LT((v - s.twist.linear).norm(), 1e-6);
  EXPECT_LT((w - s.twist.angular).norm(), 1e-6);

  // The pose blocks agree with the pose path (checked by sampling above); every block turns.
  PoseWithCovariance pose{z.pose, z.covariance.topLeftCorner<6, 6>()};
  forward->in.pose.set(pose);
  ASSERT_OK(forward->process());
  EXPECT_LT((s.covariance.topLeftCorner<6, 6>() - forward->out.pose->covariance).norm(), 1e-15);
  const Eigen::Matrix3d r = servicerTLidar().rotation.toRotationMatrix();
  EXPECT_LT(
      (s.covariance.block<3, 3>(6, 9) - r * z.covariance.block<3, 3>(6, 9) * r.transpose()).norm(),
      1e-15);
  EXPECT_LT(
      (s.covariance.block<3, 3>(0, 9) - r * z.covariance.block<3, 3>(0, 9) * r.transpose()).norm(),
      1e-15);

  // And back with `inverse`.
  auto back = make("{inverse: true}");
  back->in.extrinsic.set(servicerTLidar());
  back->in.state.set(s);
  ASSERT_OK(back->process());
  EXPECT_EQ(back->out.state->pose.parent_frame, "lidar");
  EXPECT_LT((back->out.state->twist.linear - z.twist.linear).norm(), 1e-12);
  EXPECT_LT((back->out.state->twist.angular - z.twist.angular).norm(), 1e-12);
  EXPECT_LT((back->out.state->covariance - z.covariance).norm(), 1e-15);

  RigidBodyState wrong = z;
  wrong.pose.parent_frame = "camera_left_optical";
  forward->in.state.set(wrong);
  testing::expectRejected(*forward, "input 'state' is camera_left_optical_T_target");
}

TEST(FrameTransformationRigid, BadInputsAreReported) {
  auto forward = make();
  forward->in.extrinsic.set(
      Transform::fromIsometry(Eigen::Isometry3d::Identity(), "servicer", "tof"));
  forward->in.pose.set(lidarTTarget());
  testing::expectRejected(*forward, "no extrinsic with child frame 'lidar' yet");

  forward->in.extrinsic.set(servicerTLidar());
  PoseWithCovariance wrong = lidarTTarget();
  wrong.pose.parent_frame = "camera_left";
  forward->in.pose.set(wrong);
  testing::expectRejected(*forward, "expected a pose in frame 'lidar'");

  PoseWithCovariance nan = lidarTTarget();
  nan.pose.translation.x() = std::numeric_limits<double>::quiet_NaN();
  forward->in.extrinsic.set(servicerTLidar());
  forward->in.pose.set(nan);
  EXPECT_FALSE(forward->process().isOk());

  auto bad =
      dfn::Registry::instance().createAs<FrameTransformation>("FrameTransformation", "Rigid");
  ASSERT_OK(bad.status());
  EXPECT_FALSE(bad.value()->configure(YAML::Load("{frame: ''}")).isOk());
}

}  // namespace
}  // namespace cdff::dfn
