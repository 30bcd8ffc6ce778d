// ConsiderCovariance: the added covariance is the spread of the errors it stands for (sampled
// mounting errors and range-scale errors applied to an exact measurement), zero sigmas leave the
// state unchanged, the model's extent sets the scale term, and bad inputs are reported.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "ConsiderCovariance.gen.hpp"
#include "cdff/types/geometry.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr double kDeg = M_PI / 180.0;

Transform servicerTLidar() {
  return Transform::fromIsometry(Eigen::Translation3d(0.45, 0.1, -0.2) *
                                     Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()),
                                 "servicer", "lidar");
}

Transform lidarTTarget() {
  return Transform::fromIsometry(
      Eigen::Translation3d(1.0, -2.0, 12.5) * Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitY()),
      "lidar", "target", 1234);
}

RigidBodyState servicerState() {
  RigidBodyState s;
  s.pose = servicerTLidar().compose(lidarTTarget()).value();
  s.twist.linear = Eigen::Vector3d(0.1, -0.2, 0.05);
  s.twist.angular = Eigen::Vector3d(0.01, 0.02, -0.03);
  Eigen::Matrix<double, 12, 12> a = Eigen::Matrix<double, 12, 12>::Random() * 0.01;
  s.covariance = a * a.transpose() + Matrix12d::Identity() * 1e-6;
  return s;
}

std::unique_ptr<ConsiderCovariance> make(const std::string& yaml) {
  return testing::makeDfn<ConsiderCovariance>("ConsiderCovariance", "FirstOrder", yaml);
}

Matrix6d added(ConsiderCovariance& dfn, const RigidBodyState& in) {
  dfn.in.state.set(in);
  EXPECT_OK(dfn.process());
  EXPECT_TRUE(dfn.out.state.hasValue());
  return dfn.out.state->covariance.topLeftCorner<6, 6>() - in.covariance.topLeftCorner<6, 6>();
}

Vector6d poseError(const Transform& estimate, const Transform& truth) {
  Vector6d e;
  e.head<3>() = estimate.translation - truth.translation;
  e.tail<3>() = logSO3(estimate.rotation * truth.rotation.conjugate());
  return e;
}

// An exact measurement lidar_T_target re-expressed with a mounting off by a Gaussian rotation
// and translation (sensor frame, about its origin): the spread of the resulting servicer-frame
// errors is the added covariance.
TEST(ConsiderCovarianceFirstOrder, TheMountingTermIsTheSpreadOfMountingErrors) {
  auto dfn = make("{extrinsic_angle_sigma: 0.2, extrinsic_position_sigma: 0.002}");
  dfn->in.extrinsic.set(servicerTLidar());
  const RigidBodyState truth = servicerState();
  const Matrix6d c = added(*dfn, truth);
  std::mt19937 rng(7);
  std::normal_distribution<double> n;
  constexpr int kSamples = 40000;
  Matrix6d spread = Matrix6d::Zero();
  for (int k = 0; k < kSamples; ++k) {
    const Eigen::Vector3d dtheta(0.2 * kDeg * n(rng), 0.2 * kDeg * n(rng), 0.2 * kDeg * n(rng));
    const Eigen::Vector3d dt(0.002 * n(rng), 0.002 * n(rng), 0.002 * n(rng));
    Transform mounting = servicerTLidar();
    mounting.translation += mounting.rotation * dt;
    mounting.rotation = mounting.rotation * expSO3(dtheta);
    const Vector6d e = poseError(mounting.compose(lidarTTarget()).value(), truth.pose);
    spread += e * e.transpose() / kSamples;
  }
  // Sampling error over 40 000 samples: under 1 % of the entries' scale; first order in 0.2 deg.
  EXPECT_LT((spread - c).norm(), 0.02 * c.norm());
  // At 12.7 m, 0.2 deg is 4.4 cm across the line of sight: the position term is dominated by it.
  EXPECT_NEAR(std::sqrt(c.topLeftCorner<3, 3>().trace()),
              std::sqrt(2.0 * std::pow(0.2 * kDeg * lidarTTarget().translation.norm(), 2) +
                        3.0 * 0.002 * 0.002),
              1e-9);
}

// A range scale error moves the position along the line of sight from the sensor only.
TEST(ConsiderCovarianceFirstOrder, TheRangeScaleTermIsAlongTheLineOfSight) {
  auto dfn = make("{range_scale_sigma: 0.01}");
  dfn->in.extrinsic.set(servicerTLidar());
  const RigidBodyState truth = servicerState();
  const Matrix6d c = added(*dfn, truth);
  const Eigen::Vector3d r = truth.pose.translation - servicerTLidar().translation;
  const double along = std::pow(0.01 * r.norm(), 2);
  EXPECT_NEAR(r.normalized().dot(c.topLeftCorner<3, 3>() * r.normalized()), along, 1e-12);
  const double trace = c.topLeftCorner<3, 3>().trace();
  EXPECT_NEAR(trace, along, 1e-12);
  EXPECT_EQ(c.bottomRows<3>().norm(), 0.0);
}

// The model term is isotropic with the model's RMS radius as lever arm: points on a sphere of
// radius 2 m give (sigma * 2 m)^2 per axis.
TEST(ConsiderCovarianceFirstOrder, TheModelScaleTermUsesTheModelsExtent) {
  auto dfn = make("{model_scale_sigma: 0.01}");
  dfn->in.extrinsic.set(servicerTLidar());
  std::vector<Eigen::Vector3f> sphere;
  for (int i = 0; i < 200; ++i) {
    const double z = -1.0 + (2.0 * i + 1.0) / 200.0, phi = i * 2.399963;
    const double rho = std::sqrt(1.0 - z * z);
    sphere.emplace_back(2.0f * Eigen::Vector3f(rho * std::cos(phi), rho * std::sin(phi), z));
  }
  dfn->in.model.set(PointCloud::fromXyz(sphere, "target"));
  const Matrix6d c = added(*dfn, servicerState());
  EXPECT_LT(
      (c.topLeftCorner<3, 3>() - std::pow(0.01 * 2.0, 2) * Eigen::Matrix3d::Identity()).norm(),
      1e-9);
}

TEST(ConsiderCovarianceFirstOrder, ZeroSigmasLeaveTheStateUnchanged) {
  auto dfn = make("{}");
  dfn->in.extrinsic.set(servicerTLidar());
  const RigidBodyState s = servicerState();
  dfn->in.state.set(s);
  ASSERT_OK(dfn->process());
  EXPECT_EQ(dfn->out.state->covariance, s.covariance);
  EXPECT_EQ(dfn->out.state->pose.translation, s.pose.translation);
  EXPECT_EQ(dfn->out.state->twist.angular, s.twist.angular);
  EXPECT_EQ(dfn->out.state->pose.stamp, s.pose.stamp);
}

// A systematic covariance computed elsewhere (ScanPosition's position_bias) is added as given
// while it is recent, and no longer once older than systematic_max_age_s.
TEST(ConsiderCovarianceFirstOrder, ASystematicCovarianceIsAddedWhileRecent) {
  auto dfn = make("{systematic_max_age_s: 1.0}");
  dfn->in.extrinsic.set(servicerTLidar());
  RigidBodyState s = servicerState();
  PoseWithCovariance systematic;
  systematic.pose = Transform::identity("servicer", "target", s.pose.stamp - 500'000);
  systematic.covariance.topLeftCorner<3, 3>() << 0.04, 0.01, 0, 0.01, 0.09, 0, 0, 0, 0.25;
  dfn->in.systematic.set(systematic);
  EXPECT_TRUE(added(*dfn, s).isApprox(systematic.covariance));

  s.pose.stamp += 1'000'000;  // 1.5 s after the systematic covariance: it no longer applies
  EXPECT_TRUE(added(*dfn, s).isZero());

  systematic.pose.parent_frame = "lidar";
  dfn->in.systematic.set(systematic);
  dfn->in.state.set(servicerState());
  testing::expectRejected(
      *dfn, "input 'systematic' is lidar_T_target; expected a covariance in frame 'servicer'");
  systematic.pose.parent_frame = "servicer";
  systematic.covariance(0, 0) = std::numeric_limits<double>::infinity();
  dfn->in.systematic.set(systematic);
  dfn->in.state.set(servicerState());
  testing::expectRejected(*dfn, "input 'systematic'");
}

// A DFPC keeps, but does not freshen, what an asleep instance receives (a latched mounting that
// came before the instance's condition held): the kept value is read at the first state.
TEST(ConsiderCovarianceFirstOrder, AnInputKeptWhileAsleepIsRead) {
  auto dfn = make("{extrinsic_position_sigma: 0.01}");
  dfn->in.extrinsic.set(servicerTLidar());
  dfn->in.extrinsic.markConsumed();  // as the DFPC leaves it for an instance that slept
  const Matrix6d c = added(*dfn, servicerState());
  EXPECT_NEAR(c(0, 0), 1e-4, 1e-12);
}

TEST(ConsiderCovarianceFirstOrder, BadInputsAreReported) {
  auto dfn = make("{extrinsic_angle_sigma: 0.2}");
  dfn->in.extrinsic.set(Transform::fromIsometry(Eigen::Isometry3d::Identity(), "servicer", "tof"));
  dfn->in.state.set(servicerState());
  testing::expectRejected(*dfn, "no extrinsic with child frame 'lidar' yet");

  dfn->in.extrinsic.set(servicerTLidar());
  RigidBodyState wrong = servicerState();
  wrong.pose.parent_frame = "lidar";
  dfn->in.state.set(wrong);
  testing::expectRejected(*dfn, "input 'state' is lidar_T_target; expected a state in frame");

  RigidBodyState nan = servicerState();
  nan.covariance(2, 2) = std::numeric_limits<double>::quiet_NaN();
  dfn->in.state.set(nan);
  EXPECT_FALSE(dfn->process().isOk());

  auto scaled = make("{model_scale_sigma: 0.01}");
  scaled->in.extrinsic.set(servicerTLidar());
  scaled->in.state.set(servicerState());
  testing::expectRejected(*scaled, "model_scale_sigma is 0.01 but no model arrived");
  scaled->in.model.set(PointCloud::fromXyz({{0.f, std::nanf(""), 1.f}}, "target"));
  testing::expectRejected(*scaled, "input 'model'");

  for (const char* bad : {"{frame: ''}", "{extrinsic_angle_sigma: -1}", "{range_scale_sigma: 2}"}) {
    auto d =
        dfn::Registry::instance().createAs<ConsiderCovariance>("ConsiderCovariance", "FirstOrder");
    ASSERT_OK(d.status());
    EXPECT_FALSE(d.value()->configure(YAML::Load(bad)).isOk()) << bad;
  }
}

}  // namespace
}  // namespace cdff::dfn
