// PointCloudMotionCompensation: a scan of a target that moves at a constant twist during the
// sweep, compensated with that twist, is the target at the stamp (to float precision), for slow
// and fast tumbles; a state stamped earlier is propagated; a velocity the state is unsure of is
// not applied; clouds without time offsets pass unchanged; bad inputs are reported.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "PointCloudMotionCompensation.gen.hpp"
#include "cdff/types/geometry.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr Timestamp kStamp = 5'000'000;

std::unique_ptr<PointCloudMotionCompensation> make(const std::string& yaml = "{}") {
  return testing::makeDfn<PointCloudMotionCompensation>("PointCloudMotionCompensation",
                                                        "ConstantTwist", yaml);
}

/// A target moving at a constant twist relative to the sensor (linear and angular velocity in
/// the sensor frame, the rotation about the target's origin).
struct Motion {
  Eigen::Vector3d position{1.2, -0.4, 6.0};
  Eigen::Quaterniond attitude{Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized())};
  Eigen::Vector3d velocity{0.05, 0.02, -0.25};
  Eigen::Vector3d angular_velocity;

  Eigen::Isometry3d at(double dt) const {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = (expSO3(angular_velocity * dt) * attitude).toRotationMatrix();
    t.translation() = position + velocity * dt;
    return t;
  }

  RigidBodyState state(double dt = 0.0) const {
    RigidBodyState s;
    s.pose = Transform::fromIsometry(at(dt), "lidar", "target", kStamp + std::llround(dt * 1e6));
    s.twist.linear = velocity;
    s.twist.angular = angular_velocity;
    s.covariance = Matrix12d::Identity() * 1e-4;
    return s;
  }
};

/// Points on a 1.5 x 2 x 1 m box, in the target frame, with their outward normals.
struct Model {
  std::vector<Eigen::Vector3d> points, normals;
};

Model boxSurface(int count) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> face(0, 5);
  const Eigen::Vector3d half(0.75, 1.0, 0.5);
  Model m;
  for (int i = 0; i < count; ++i) {
    const int f = face(rng), axis = f / 2;
    Eigen::Vector3d p(u(rng) * half.x(), u(rng) * half.y(), u(rng) * half.z());
    p[axis] = (f % 2 ? 1.0 : -1.0) * half[axis];
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    n[axis] = f % 2 ? 1.0 : -1.0;
    m.points.push_back(p);
    m.normals.push_back(n);
  }
  return m;
}

/// The sweep of one 100 ms scan: point i measured at its time offset, the target where the
/// motion puts it then. The offsets run from 0 to 99.9 ms and wrap, as when the sweep starts
/// inside the target.
PointCloud sweep(const Model& model, const Motion& motion, bool with_normals) {
  std::vector<Point4f> points, normals;
  std::vector<std::int32_t> offsets;
  for (std::size_t i = 0; i < model.points.size(); ++i) {
    const std::int32_t offset_us = static_cast<std::int32_t>((i * 7919) % 100'000);
    const Eigen::Isometry3d pose = motion.at(offset_us * 1e-6);
    const Eigen::Vector3d p = pose * model.points[i], n = pose.linear() * model.normals[i];
    points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                        static_cast<float>(p.z()));
    normals.emplace_back(static_cast<float>(n.x()), static_cast<float>(n.y()),
                         static_cast<float>(n.z()));
    offsets.push_back(offset_us);
  }
  PointCloud cloud;
  cloud.stamp = kStamp;
  cloud.frame_id = "lidar";
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  if (with_normals) cloud.normals = Buffer<Point4f>::fromVector(std::move(normals));
  cloud.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(offsets));
  return cloud;
}

Eigen::Vector3d xyz(const Point4f& p) {
  return {p.x, p.y, p.z};
}

/// Largest distance between the cloud's points and the model placed at the stamp.
double worstDistanceAtStamp(const PointCloud& cloud, const Model& model, const Motion& motion) {
  const Eigen::Isometry3d pose = motion.at(0.0);
  double worst = 0.0;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    worst = std::max(worst, (xyz(cloud.points[i]) - pose * model.points[i]).norm());
  return worst;
}

class CompensationAtTumbleRate : public ::testing::TestWithParam<double> {};

TEST_P(CompensationAtTumbleRate, TheCompensatedScanIsTheTargetAtTheStamp) {
  // 5 deg/s is the tumbling scenario's rate; 90 deg/s turns 0.16 rad in a scan (past the
  // series' range, so both branches of the rotation are checked).
  Motion motion;
  motion.angular_velocity =
      Eigen::Vector3d(0.3, -1.0, 0.6).normalized() * GetParam() * M_PI / 180.0;
  const Model model = boxSurface(4000);
  const PointCloud raw = sweep(model, motion, /*with_normals=*/true);
  auto dfn = make();
  dfn->in.cloud.set(raw);
  dfn->in.state.set(motion.state());
  ASSERT_OK(dfn->process());
  const PointCloud& out = *dfn->out.compensated;
  ASSERT_EQ(out.size(), raw.size());
  EXPECT_EQ(out.stamp, raw.stamp);
  EXPECT_EQ(out.frame_id, raw.frame_id);

  const double before = worstDistanceAtStamp(raw, model, motion);
  const double after = worstDistanceAtStamp(out, model, motion);
  // The raw scan is off by the motion over up to 100 ms (2.5 cm of approach alone); the
  // compensated one only by float rounding of coordinates of about 7 m (about 1 um).
  EXPECT_GT(before, 0.02);
  EXPECT_LT(after, 5e-6) << "raw scan off by " << before << " m";
  EXPECT_NEAR(*dfn->out.max_correction, before, 1e-5);

  const Eigen::Matrix3d r = motion.at(0.0).linear();
  for (std::size_t i = 0; i < out.size(); ++i) {
    ASSERT_EQ(out.time_offset_us[i], 0);
    ASSERT_LT((xyz(out.normals[i]) - r * model.normals[i]).norm(), 1e-6) << "normal " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(PointCloudMotionCompensationConstantTwist, CompensationAtTumbleRate,
                         ::testing::Values(5.0, 90.0));

TEST(PointCloudMotionCompensationConstantTwist, AnEarlierStateIsPropagatedToTheStamp) {
  // The filter's prediction from its previous step, 60 ms before the scan.
  Motion motion;
  motion.angular_velocity = Eigen::Vector3d(0.0, 0.0, 10.0 * M_PI / 180.0);
  const Model model = boxSurface(1000);
  auto dfn = make();
  dfn->in.cloud.set(sweep(model, motion, /*with_normals=*/false));
  dfn->in.state.set(motion.state(-0.060));
  ASSERT_OK(dfn->process());
  EXPECT_LT(worstDistanceAtStamp(*dfn->out.compensated, model, motion), 5e-6);
  EXPECT_TRUE(dfn->out.compensated->normals.empty());
}

TEST(PointCloudMotionCompensationConstantTwist, AnUncertainVelocityIsNotApplied) {
  // An acquiring filter: the angular velocity is its prior (0.1 rad/s per axis), the linear
  // one already converged. Only the motion along the known velocity is removed.
  Motion motion;
  motion.angular_velocity = Eigen::Vector3d(0.0, 0.0, 0.0);
  const Model model = boxSurface(1000);
  const PointCloud raw = sweep(model, motion, /*with_normals=*/false);
  RigidBodyState state = motion.state();
  state.twist.angular = Eigen::Vector3d(0.0, 0.15, 0.0);  // a wrong estimate
  state.covariance.block<3, 3>(9, 9) = Eigen::Matrix3d::Identity() * 0.01;
  auto dfn = make();
  dfn->in.cloud.set(raw);
  dfn->in.state.set(state);
  ASSERT_OK(dfn->process());
  EXPECT_TRUE(*dfn->out.linear_compensated);
  EXPECT_FALSE(*dfn->out.angular_compensated);
  EXPECT_LT(worstDistanceAtStamp(*dfn->out.compensated, model, motion), 5e-6);

  // Both unknown: the points are not moved.
  state.covariance.block<3, 3>(6, 6) = Eigen::Matrix3d::Identity() * 0.09;
  dfn->in.state.set(state);
  ASSERT_OK(dfn->process());
  EXPECT_FALSE(*dfn->out.linear_compensated);
  EXPECT_EQ(*dfn->out.max_correction, 0.0);
  EXPECT_EQ(dfn->out.compensated->points.data(), raw.points.data());
}

TEST(PointCloudMotionCompensationConstantTwist, ACloudWithoutTimeOffsetsPassesUnchanged) {
  Motion motion;
  motion.angular_velocity = Eigen::Vector3d(0.1, 0.0, 0.0);
  PointCloud cloud = sweep(boxSurface(100), motion, /*with_normals=*/false);
  cloud.time_offset_us = {};
  auto dfn = make();
  dfn->in.cloud.set(cloud);
  dfn->in.state.set(motion.state());
  ASSERT_OK(dfn->process());
  EXPECT_EQ(dfn->out.compensated->points.data(), cloud.points.data());  // shared, not copied
  EXPECT_EQ(*dfn->out.max_correction, 0.0);
}

TEST(PointCloudMotionCompensationConstantTwist, NonFinitePointsStayNonFiniteAndDoNotCount) {
  Motion motion;
  motion.angular_velocity = Eigen::Vector3d(0.0, 0.05, 0.0);
  const Model model = boxSurface(200);
  PointCloud cloud = sweep(model, motion, /*with_normals=*/false);
  std::vector<Point4f> points(cloud.points.begin(), cloud.points.end());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  points[17] = Point4f(nan, 0.0f, 1.0f);
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  auto dfn = make();
  dfn->in.cloud.set(cloud);
  dfn->in.state.set(motion.state());
  ASSERT_OK(dfn->process());
  EXPECT_TRUE(std::isnan(dfn->out.compensated->points[17].x));
  EXPECT_TRUE(std::isfinite(*dfn->out.max_correction));
  EXPECT_LT(*dfn->out.max_correction, 0.05);
}

TEST(PointCloudMotionCompensationConstantTwist, BadInputsAreReported) {
  Motion motion;
  motion.angular_velocity = Eigen::Vector3d(0.0, 0.0, 0.1);
  const PointCloud good = sweep(boxSurface(50), motion, /*with_normals=*/false);
  auto dfn = make("{max_time_offset: 0.2, max_state_age: 0.5}");

  RigidBodyState other_frame = motion.state();
  other_frame.pose.parent_frame = "servicer";
  dfn->in.cloud.set(good);
  dfn->in.state.set(other_frame);
  testing::expectRejected(*dfn, "expected the target's state in the cloud's frame 'lidar'");

  dfn->in.state.set(motion.state(-0.8));
  testing::expectRejected(*dfn, "max_state_age = 0.5 s");

  RigidBodyState nan_twist = motion.state();
  nan_twist.twist.angular.y() = std::numeric_limits<double>::quiet_NaN();
  dfn->in.state.set(nan_twist);
  testing::expectRejected(*dfn, "angular velocity");

  PointCloud late = good;
  std::vector<std::int32_t> offsets(late.size(), 1000);
  offsets[3] = 300'000;
  late.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(offsets));
  dfn->in.state.set(motion.state());
  dfn->in.cloud.set(late);
  testing::expectRejected(*dfn, "point 3 has time offset 300000 us");

  PointCloud short_offsets = good;
  short_offsets.time_offset_us = Buffer<std::int32_t>::fromVector({0, 1, 2});
  dfn->in.cloud.set(short_offsets);
  testing::expectRejected(*dfn, "input 'cloud'");

  dfn->in.cloud.set(PointCloud{});
  testing::expectRejected(*dfn, "input 'cloud'");
}

}  // namespace
}  // namespace cdff::dfn
