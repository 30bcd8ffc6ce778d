// BearingPrediction: a state known to a few metres, propagated 10 s and projected into a 35 mm
// camera, must land where the true relative motion takes the target (the closed form, checked
// against integration in BearingFilter's test) within a small fraction of its own predicted
// uncertainty, with the attitude interpolated between AHRS samples; the last match's region is
// moved there and scaled by the range change. Bad input: a state in another frame, an image
// older than the state, a NaN IMU sample or one before the IMU's mounting; no attitude near the
// image's time gives no prediction and a warning. With the IMU, the prediction follows the
// measured thrust less the state's bias estimate.
#include <gtest/gtest.h>

#include <cmath>

#include "BearingPrediction.gen.hpp"
#include "cdff/tracking/relative_motion.hpp"
#include "support/dfn_testing.hpp"
#include "support/far_target.hpp"

namespace cdff::dfn {
namespace {

using testing::farCamera;

Transform cameraMount() {
  return testing::farCameraMount();
}

Eigen::Matrix3d servicerAttitude(double yaw) {
  // x along-track (towards a target ahead on V-bar), z radial, turned by `yaw` about z.
  Eigen::Matrix3d r;
  r << 0, 0, 1, 1, 0, 0, 0, 1, 0;
  return r * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

class BearingPredictionTest : public ::testing::Test {
 protected:
  std::unique_ptr<BearingPrediction> dfn_ =
      testing::makeDfn<BearingPrediction>("BearingPrediction", "ClohessyWiltshire");
  tracking::RelativeState state_;

  void SetUp() override {
    state_.stamp = 0;
    state_.x.head<6>() << 5, 1500, -3, 0.01, -1.0, 0.002;
    state_.covariance.diagonal().head<6>() << 4, 100, 4, 1e-4, 1e-2, 1e-4;
    dfn_->in.state.set(tracking::toRigidBodyState(state_));
    dfn_->in.camera_mount.set(cameraMount());
  }

  void attitudeAt(Timestamp stamp, double yaw) {
    PoseWithCovariance a;
    a.pose = Transform::identity("lvlh", "servicer", stamp);
    a.pose.rotation = Eigen::Quaterniond(servicerAttitude(yaw));
    a.covariance.block<3, 3>(3, 3) = 1e-10 * Eigen::Matrix3d::Identity();
    dfn_->in.attitude.set(a);
    ASSERT_TRUE(dfn_->process().isOk());
  }

  Image imageAt(Timestamp stamp) {
    Image image;
    image.stamp = stamp;
    image.frame_id = "camera_far_optical";
    image.camera = farCamera();
    return image;
  }
};

TEST_F(BearingPredictionTest, LandsWhereTheRelativeMotionTakesTheTarget) {
  attitudeAt(9'500'000, 1e-3);
  attitudeAt(10'500'000, 3e-3);  // the image at 10 s sees yaw 2e-3 (slerp half-way)
  ImageRegion reference = ImageRegion::box(490, 480, 40, 30);
  reference.homography(0, 0) = reference.homography(1, 1) = 1.5;
  dfn_->in.reference.set(reference);
  dfn_->in.image.set(imageAt(10'000'000));
  ASSERT_TRUE(dfn_->process().isOk()) << dfn_->diagnostics().last_error;
  const ImageRegion& p = *dfn_->out.prediction;
  const tracking::Vector6d truth =
      tracking::cwTransition(tracking::meanMotion(500e3), 10.0) * state_.x.head<6>();
  const tracking::BearingGeometry g{farCamera(), cameraMount().rotation.toRotationMatrix(),
                                    servicerAttitude(2e-3), cameraMount().translation};
  const Eigen::Vector2d expected = *g.pixelOf(truth.head<3>());
  EXPECT_LT((p.centre() - expected).norm(), 0.05);
  EXPECT_EQ(p.source, "prediction");
  EXPECT_EQ(p.width, 40);
  // Closing by 10 m from 1500 m: the region grows by 1500/1490.
  EXPECT_NEAR(p.scale() / reference.scale(), state_.x.head<3>().norm() / truth.head<3>().norm(),
              1e-4);
  // The lateral uncertainty (2 m at 1.5 km, plus the velocity's over 10 s) in pixels.
  const double lateral_px = std::sqrt(4 + 1e-4 * 100) / 1500 * farCamera().fx;
  EXPECT_NEAR(std::sqrt(p.covariance(0, 0)), lateral_px, 0.1 * lateral_px);
}

TEST_F(BearingPredictionTest, NoAttitudeNearTheImageGivesNoPredictionAndAWarning) {
  attitudeAt(0, 0);
  dfn_->in.image.set(imageAt(10'000'000));
  ASSERT_TRUE(dfn_->process().isOk());
  EXPECT_EQ(dfn_->out.prediction.get(), nullptr);
  ASSERT_FALSE(dfn_->diagnostics().warnings.empty());
  EXPECT_NE(dfn_->diagnostics().warnings.back().find("no servicer attitude within"),
            std::string::npos);
}

TEST_F(BearingPredictionTest, AStateInAnotherFrame) {
  attitudeAt(0, 0);
  RigidBodyState wrong = tracking::toRigidBodyState(state_);
  wrong.pose.parent_frame = "servicer";
  dfn_->in.state.set(wrong);
  dfn_->in.image.set(imageAt(1'000'000));
  testing::expectRejected(*dfn_, "expected lvlh_T_servicer");
}

TEST_F(BearingPredictionTest, AnImageOlderThanTheState) {
  state_.stamp = 5'000'000;
  dfn_->in.state.set(tracking::toRigidBodyState(state_));
  attitudeAt(4'000'000, 0);
  dfn_->in.image.set(imageAt(4'000'000));
  testing::expectRejected(*dfn_, "is older than the state");
}

TEST_F(BearingPredictionTest, WithTheImuItFollowsTheThrustLessTheStatesBias) {
  // The filter's state knows the accelerometer's bias (servicer axes); the IMU measures 0.2
  // m/s^2 of thrust along the servicer's y (across the line of sight) plus that bias for 5 s
  // (the attitude history spans 6.4 s): 2.5 m at 1.5 km, 10 px, which the prediction must
  // follow to a small fraction of a pixel.
  const Eigen::Vector3d bias(0.01, -0.02, 0.005), thrust(0, 0.2, 0);
  state_.x.tail<3>() = bias;
  state_.covariance.bottomRightCorner<3, 3>() = 1e-8 * Eigen::Matrix3d::Identity();
  dfn_->in.state.set(tracking::toRigidBodyState(state_));
  dfn_->in.imu_mount.set(Transform::identity("servicer", "imu", 0));
  for (int k = 0; k < 600; ++k) {  // as a stream: an AHRS sample every 12 IMU samples
    if (k % 12 == 0) attitudeAt(k * 1'000'000 / 120, 0);
    ImuSample s;
    s.stamp = k * 1'000'000 / 120;
    s.frame_id = "imu";
    s.linear_acceleration = thrust + bias;
    dfn_->in.imu.set(s);
    ASSERT_TRUE(dfn_->process().isOk()) << dfn_->diagnostics().last_error;
  }
  attitudeAt(5'000'000, 0);
  dfn_->in.image.set(imageAt(5'000'000));
  ASSERT_TRUE(dfn_->process().isOk()) << dfn_->diagnostics().last_error;
  EXPECT_TRUE(dfn_->diagnostics().warnings.empty());
  // The truth: the free motion less the thrust's (p = target - servicer), in the closed form
  // plus the constant acceleration's response (n T = 0.006: its coupling is below 1 mm here).
  tracking::Vector6d truth =
      tracking::cwTransition(tracking::meanMotion(500e3), 5.0) * state_.x.head<6>();
  truth.head<3>() -= 0.5 * 25 * servicerAttitude(0) * thrust;
  const tracking::BearingGeometry g{farCamera(), cameraMount().rotation.toRotationMatrix(),
                                    servicerAttitude(0), cameraMount().translation};
  const Eigen::Vector2d expected = *g.pixelOf(truth.head<3>());
  const Eigen::Vector2d free = *g.pixelOf(
      (tracking::cwTransition(tracking::meanMotion(500e3), 5.0) * state_.x.head<6>()).head<3>());
  EXPECT_GT((free - expected).norm(), 5.0);
  EXPECT_LT((dfn_->out.prediction->centre() - expected).norm(), 0.05);
}

TEST_F(BearingPredictionTest, ANanImuSampleOrOneWithoutTheMount) {
  ImuSample s;
  s.stamp = 1'000'000;
  s.frame_id = "imu";
  dfn_->in.imu.set(s);
  testing::expectRejected(*dfn_, "came before 'imu_mount'");
  dfn_->in.imu_mount.set(Transform::identity("servicer", "imu", 0));
  s.linear_acceleration.x() = std::nan("");
  dfn_->in.imu.set(s);
  testing::expectRejected(*dfn_, "input 'imu' at t = 1000000 us");
}

}  // namespace
}  // namespace cdff::dfn
