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
