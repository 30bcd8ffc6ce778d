// OctomapUpdate/OcTree: contacts on a moving target land on one map in its frame, with the
// contacts' mean point, normal and force per voxel; repeated contacts merge and raise the
// confidence; bad contacts and poses are faults that leave the map as it was.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "OctomapUpdate.gen.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<OctomapUpdate> make(const std::string& yaml = "{output_period: 0}") {
  return testing::makeDfn<OctomapUpdate>("OctomapUpdate", "OcTree", yaml);
}

/// The target's pose in the arm's base at `t` seconds: 1.2 m ahead, turning at 0.2 rad/s about
/// a tilted axis and drifting at 2 cm/s, so that no two contacts see it in the same place.
Eigen::Isometry3d baseTTarget(double t) {
  return Eigen::Translation3d(1.2, 0.02 * t, 0.3) *
         Eigen::AngleAxisd(0.2 * t, Eigen::Vector3d(0.2, 0.3, 1).normalized());
}

/// The sensor somewhere near the target, its pose changing with `t`.
Eigen::Isometry3d baseTSensor(double t) {
  return Eigen::Translation3d(0.8, -0.1 + 0.05 * t, 0.5) *
         Eigen::AngleAxisd(1.0 + 0.3 * t, Eigen::Vector3d(1, -0.5, 0.3).normalized());
}

/// The inputs of one contact at `point` with `normal` (target frame) and `force`, at `t` s.
void feed(OctomapUpdate& dfn, double t, const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
          float force) {
  const Timestamp stamp = fromSeconds(t);
  const Eigen::Isometry3d sensor_T_target = baseTSensor(t).inverse() * baseTTarget(t);
  const Eigen::Vector3f p = (sensor_T_target * point).cast<float>();
  const Eigen::Vector3f n = (sensor_T_target.linear() * normal).cast<float>();
  PointCloud contact = PointCloud::fromXyz({p}, "ft_sensor", stamp);
  contact.normals = Buffer<Point4f>::copyOf(std::vector<Point4f>{{n.x(), n.y(), n.z()}});
  contact.intensity = Buffer<float>::copyOf(std::vector<float>{force});
  dfn.in.contact.set(std::move(contact));
  dfn.in.sensor_pose.set(Transform::fromIsometry(baseTSensor(t), "base_link", "ft_sensor", stamp));
  PoseWithCovariance target;
  target.pose = Transform::fromIsometry(baseTTarget(t), "base_link", "target", stamp);
  dfn.in.target_pose.set(target);
}

/// The face at x = 0.301 m of a box (target frame): a point of it and its outward normal. The
/// face is mid-voxel at the default resolution (2 mm): a face on a voxel boundary would put a
/// point's repeated contacts on either side of it by float rounding.
Eigen::Vector3d onFace(double u, double v) {
  return {0.301, u, v};
}
const Eigen::Vector3d kFaceNormal = Eigen::Vector3d::UnitX();

TEST(OctomapUpdateOcTree, ContactsOnAMovingTargetLandOnOneMapInItsFrame) {
  auto dfn = make();
  // A 5 x 5 grid of contacts 1 cm apart on the face, one every 0.1 s while the target moves by
  // 2 mm and turns by 1 deg between them.
  std::vector<Eigen::Vector3d> truth;
  for (int i = 0; i < 25; ++i) {
    truth.push_back(onFace(0.01 * (i % 5), 0.01 * (i / 5)));
    feed(*dfn, 0.1 * i, truth.back(), kFaceNormal, 5.0f + static_cast<float>(i));
    ASSERT_OK(dfn->process());
  }
  const PointCloud& map = *dfn->out.contacts;
  EXPECT_EQ(map.frame_id, "target");
  EXPECT_EQ(map.stamp, fromSeconds(2.4));
  EXPECT_EQ(*dfn->out.voxels, 25);
  ASSERT_EQ(map.size(), 25u);
  for (std::size_t i = 0; i < map.size(); ++i) {
    // The transforms chain in double and the clouds carry floats: 1e-6 relative at 1.5 m.
    EXPECT_LT((map.points[i].vec().cast<double>() - truth[i]).norm(), 5e-6) << i;
    EXPECT_LT((map.normals[i].vec().cast<double>() - kFaceNormal).norm(), 1e-6) << i;
    EXPECT_FLOAT_EQ(map.intensity[i], 5.0f + static_cast<float>(i));
  }
}

TEST(OctomapUpdateOcTree, RepeatedContactsMergeIntoOneVoxelWithTheirMean) {
  auto dfn = make();
  // The same surface point touched at three target poses, the estimates 0.2 mm apart across
  // the face with normals 1 deg off on either side and forces of 8, 10 and 12 N.
  const Eigen::Vector3d centre = onFace(0.0105, 0.0105);  // mid-voxel at 2 mm resolution
  const double tilt = M_PI / 180;
  const Eigen::Vector3d normals[] = {
      Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitZ()) * kFaceNormal, kFaceNormal,
      Eigen::AngleAxisd(-tilt, Eigen::Vector3d::UnitZ()) * kFaceNormal};
  for (int k = 0; k < 3; ++k) {
    feed(*dfn, 1.0 * k, centre + Eigen::Vector3d(0, 2e-4 * (k - 1), 0), normals[k],
         8.0f + 2.0f * static_cast<float>(k));
    ASSERT_OK(dfn->process());
  }
  EXPECT_EQ(*dfn->out.voxels, 1);
  const PointCloud& map = *dfn->out.contacts;
  ASSERT_EQ(map.size(), 1u);
  EXPECT_LT((map.points[0].vec().cast<double>() - centre).norm(), 5e-6);
  EXPECT_LT((map.normals[0].vec().cast<double>() - kFaceNormal).norm(), 1e-6);
  EXPECT_FLOAT_EQ(map.intensity[0], 10.0f);
}

TEST(OctomapUpdateOcTree, TheConfidenceGrowsWithTheContactsOfAVoxel) {
  // 0.8: a voxel is output from its second contact sample (0.7, then 0.845).
  auto dfn = make("{output_period: 0, min_confidence: 0.8}");
  feed(*dfn, 0.0, onFace(0.0011, 0.0011), kFaceNormal, 10);
  ASSERT_OK(dfn->process());
  EXPECT_EQ(*dfn->out.voxels, 1);
  EXPECT_FALSE(dfn->out.contacts.hasValue());
  feed(*dfn, 0.1, onFace(0.0011, 0.0011), kFaceNormal, 10);
  ASSERT_OK(dfn->process());
  ASSERT_TRUE(dfn->out.contacts.hasValue());
  EXPECT_EQ(dfn->out.contacts->size(), 1u);
}

TEST(OctomapUpdateOcTree, TheMapIsOutputOnANewVoxelOrAfterTheOutputPeriod) {
  auto dfn = make("{output_period: 0.1}");
  feed(*dfn, 0.000, onFace(0.0011, 0.0011), kFaceNormal, 10);
  ASSERT_OK(dfn->process());
  ASSERT_TRUE(dfn->out.contacts.hasValue());
  const Timestamp first = dfn->out.contacts->stamp;
  feed(*dfn, 0.050, onFace(0.0011, 0.0011), kFaceNormal, 12);  // same voxel, within the period
  ASSERT_OK(dfn->process());
  EXPECT_EQ(dfn->out.contacts->stamp, first);
  feed(*dfn, 0.060, onFace(0.0151, 0.0011), kFaceNormal, 12);  // a new voxel
  ASSERT_OK(dfn->process());
  EXPECT_EQ(dfn->out.contacts->stamp, fromSeconds(0.060));
  EXPECT_EQ(dfn->out.contacts->size(), 2u);
  feed(*dfn, 0.161, onFace(0.0011, 0.0011), kFaceNormal, 14);  // the period elapsed
  ASSERT_OK(dfn->process());
  EXPECT_EQ(dfn->out.contacts->stamp, fromSeconds(0.161));
  EXPECT_FLOAT_EQ(dfn->out.contacts->intensity[0], 12.0f);  // (10 + 12 + 14) / 3
}

TEST(OctomapUpdateOcTree, BadContactsAndPosesAreFaultsThatLeaveTheMapAsItWas) {
  auto dfn = make();
  feed(*dfn, 0.0, onFace(0.0011, 0.0011), kFaceNormal, 10);
  ASSERT_OK(dfn->process());
  const double nan = std::numeric_limits<double>::quiet_NaN();

  feed(*dfn, 0.1, Eigen::Vector3d(nan, 0, 0), kFaceNormal, 10);
  testing::expectRejected(*dfn, "input 'contact'");
  feed(*dfn, 0.1, onFace(0.02, 0.02), 2 * kFaceNormal, 10);
  testing::expectRejected(*dfn, "has a normal of norm 2");
  feed(*dfn, 0.1, onFace(0.02, 0.02), kFaceNormal, -3);
  testing::expectRejected(*dfn, "normal force (intensity) of -3 N");
  feed(*dfn, 0.1, onFace(0.02, 0.02), kFaceNormal, 10);
  PointCloud bare = *dfn->in.contact;
  bare.normals = {};
  dfn->in.contact.set(bare);
  testing::expectRejected(*dfn, "has no normals");

  // The contact in another frame than the sensor pose's, and poses of other bases.
  feed(*dfn, 0.1, onFace(0.02, 0.02), kFaceNormal, 10);
  PointCloud elsewhere = *dfn->in.contact;
  elsewhere.frame_id = "wrist_camera";
  dfn->in.contact.set(elsewhere);
  testing::expectRejected(*dfn, "in frame 'wrist_camera'");
  feed(*dfn, 0.1, onFace(0.02, 0.02), kFaceNormal, 10);
  PoseWithCovariance servicer = *dfn->in.target_pose;
  servicer.pose.parent_frame = "servicer";
  dfn->in.target_pose.set(servicer);
  testing::expectRejected(*dfn, "expected both in the arm's base frame 'base_link'");

  // A target pose too old (the pose estimator has stopped): no contact is placed without it.
  feed(*dfn, 0.1, onFace(0.02, 0.02), kFaceNormal, 10);
  PoseWithCovariance stale = *dfn->in.target_pose;
  stale.pose.stamp -= fromSeconds(0.5);
  dfn->in.target_pose.set(stale);
  testing::expectRejected(*dfn, "0.5000 s before the contact");
  feed(*dfn, 0.1, onFace(0.02, 0.02), kFaceNormal, 10);
  Transform late = *dfn->in.sensor_pose;
  late.stamp -= fromSeconds(0.01);
  dfn->in.sensor_pose.set(late);
  testing::expectRejected(*dfn, "0.0100 s from the contact");
  feed(*dfn, 0.1, Eigen::Vector3d(500, 0, 0), kFaceNormal, 10);
  testing::expectRejected(*dfn, "outside the octree's range");
  feed(*dfn, 0.1, onFace(0.02, 0.02), kFaceNormal, 10);
  PoseWithCovariance broken = *dfn->in.target_pose;
  broken.pose.rotation.coeffs() *= 2;
  dfn->in.target_pose.set(broken);
  testing::expectRejected(*dfn, "input 'target_pose'");

  // None of them touched the map: one voxel, its one contact.
  feed(*dfn, 0.2, onFace(0.0011, 0.0011), kFaceNormal, 20);
  ASSERT_OK(dfn->process());
  EXPECT_EQ(*dfn->out.voxels, 1);
  EXPECT_FLOAT_EQ(dfn->out.contacts->intensity[0], 15.0f);
}

TEST(OctomapUpdateOcTree, AMissingTargetPoseIsAnError) {
  auto dfn = make();
  PointCloud contact = PointCloud::fromXyz({Eigen::Vector3f(0, 0, 0.13)}, "ft_sensor", 1000);
  contact.normals = Buffer<Point4f>::copyOf(std::vector<Point4f>{{0, 0, -1}});
  contact.intensity = Buffer<float>::copyOf(std::vector<float>{10});
  dfn->in.contact.set(contact);
  dfn->in.sensor_pose.set(Transform::identity("base_link", "ft_sensor", 1000));
  testing::expectRejected(*dfn, "required input 'target_pose'");
}

TEST(OctomapUpdateOcTree, BadParametersAreRefused) {
  auto d = Registry::instance().createAs<OctomapUpdate>("OctomapUpdate", "OcTree");
  ASSERT_TRUE(d.isOk());
  EXPECT_FALSE(d.value()->configure(YAML::Load("{resolution: 0}")).isOk());
  EXPECT_FALSE(d.value()->configure(YAML::Load("{hit_probability: 0.4}")).isOk());
  EXPECT_FALSE(d.value()->configure(YAML::Load("{min_confidence: 1.5}")).isOk());
}

}  // namespace
}  // namespace cdff::dfn
