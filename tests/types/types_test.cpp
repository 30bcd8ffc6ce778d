// Core types: sharing semantics, validation messages and geometry conventions.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "cdff/types/statistics.hpp"
#include "cdff/types/triangle.hpp"
#include "cdff/types/types.hpp"
#include "support/synthetic.hpp"

namespace cdff {
namespace {

TEST(Buffer, CopiesShareTheSameMemory) {
  Buffer<int> a = Buffer<int>::fromVector({1, 2, 3});
  Buffer<int> b = a;
  EXPECT_TRUE(a.sharesMemoryWith(b));
  EXPECT_EQ(b.size(), 3u);
  EXPECT_EQ(b[2], 3);
  EXPECT_EQ(a.owner().use_count(), 2);
}

TEST(Buffer, FromVectorDoesNotCopyTheElements) {
  std::vector<double> values(1000, 1.5);
  const double* original = values.data();
  Buffer<double> buffer = Buffer<double>::fromVector(std::move(values));
  EXPECT_EQ(buffer.data(), original);
}

TEST(Image, FromBytesValidatesTheSize) {
  auto ok = Image::fromBytes(std::vector<std::uint8_t>(12 * 10), 12, 10, PixelFormat::kGray8);
  ASSERT_TRUE(ok.isOk()) << ok.status().toString();
  EXPECT_EQ(ok->stride_bytes, 12u);

  auto bad = Image::fromBytes(std::vector<std::uint8_t>(100), 12, 10, PixelFormat::kGray8);
  ASSERT_FALSE(bad.isOk());
  EXPECT_EQ(bad.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(bad.status().message().find("holds 100 bytes; expected >= 120"), std::string::npos)
      << bad.status().message();
}

TEST(Image, EmptyImageIsInvalid) {
  Status s = Image{}.validate("input 'image'");
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("input 'image' is empty"), std::string::npos) << s.message();
}

TEST(Image, CameraModelMustMatchTheImageSize) {
  auto image = Image::fromBytes(std::vector<std::uint8_t>(64 * 48), 64, 48, PixelFormat::kGray8);
  ASSERT_TRUE(image.isOk());
  image->camera = testing::pinholeCamera(640, 480, 500);
  Status s = image->validate();
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("64x48"), std::string::npos) << s.message();
}

TEST(Image, FormatCheckNamesTheAcceptedFormats) {
  auto image = Image::fromBytes(std::vector<std::uint8_t>(4 * 4 * 4), 4, 4, PixelFormat::kFloat32);
  ASSERT_TRUE(image.isOk());
  Status s = image->validate("image", {PixelFormat::kGray8, PixelFormat::kBgr8});
  EXPECT_NE(s.message().find("32FC1; expected one of [8UC1, 8UC3]"), std::string::npos)
      << s.message();
}

TEST(CameraModel, RejectsNonPositiveFocalLengthAndWrongCoefficientCounts) {
  CameraModel c = testing::pinholeCamera(640, 480, 500);
  EXPECT_OK(c.validate());
  c.fx = 0;
  EXPECT_FALSE(c.validate().isOk());
  c = testing::pinholeCamera(640, 480, 500);
  c.distortion_model = DistortionModel::kEquidistant;
  c.distortion = {0.1, 0.2};
  EXPECT_NE(c.validate().message().find("expected 4"), std::string::npos);
  c.distortion = {0.1, 0.2, std::nan(""), 0.0};
  EXPECT_FALSE(c.validate().isOk());
}

TEST(Transform, ComposeAndInverseFollowTheNamingConvention) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    Transform a_T_b = Transform::identity("a", "b");
    a_T_b.translation = {n(rng), n(rng), n(rng)};
    a_T_b.rotation = expSO3({n(rng), n(rng), n(rng)});
    Transform b_T_c = Transform::identity("b", "c");
    b_T_c.translation = {n(rng), n(rng), n(rng)};
    b_T_c.rotation = expSO3({n(rng), n(rng), n(rng)});
    const Eigen::Vector3d p_c(n(rng), n(rng), n(rng));

    auto a_T_c = a_T_b.compose(b_T_c);
    ASSERT_TRUE(a_T_c.isOk());
    EXPECT_EQ(a_T_c->parent_frame, "a");
    EXPECT_EQ(a_T_c->child_frame, "c");
    EXPECT_LT(((*a_T_c) * p_c - a_T_b * (b_T_c * p_c)).norm(), 1e-12);

    const Transform b_T_a = a_T_b.inverse();
    EXPECT_EQ(b_T_a.parent_frame, "b");
    EXPECT_LT((b_T_a * (a_T_b * p_c) - p_c).norm(), 1e-12);
    EXPECT_LT((a_T_b.isometry() * p_c - a_T_b * p_c).norm(), 1e-12);
  }
}

TEST(Transform, ComposeRejectsMismatchedFrames) {
  auto r = Transform::identity("a", "b").compose(Transform::identity("x", "c"));
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("'b' and 'x' differ"), std::string::npos)
      << r.status().message();
}

TEST(Transform, ValidateRejectsNanAndNonUnitQuaternions) {
  Transform t = Transform::identity("a", "b");
  EXPECT_OK(t.validate());
  t.translation.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(t.validate().message().find("non-finite"), std::string::npos);
  t = Transform::identity("a", "b");
  t.rotation.coeffs() << 0, 0, 0, 2;
  EXPECT_NE(t.validate().message().find("norm 2"), std::string::npos) << t.validate().message();
}

TEST(SO3, ExpAndLogAreInverse) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int i = 0; i < 200; ++i) {
    Eigen::Vector3d v(u(rng), u(rng), u(rng));
    if (v.norm() >= M_PI) v *= 3.0 / v.norm();  // the log returns angles in [0, pi]
    EXPECT_LT((logSO3(expSO3(v)) - v).norm(), 1e-9) << v.transpose();
  }
  EXPECT_LT(logSO3(expSO3(Eigen::Vector3d(1e-14, 0, 0))).norm(), 1e-13);
}

TEST(PoseWithCovariance, RejectsAsymmetricOrNegativeCovariance) {
  PoseWithCovariance p;
  p.pose = Transform::identity("a", "b");
  p.covariance = Matrix6d::Identity() * 0.01;
  EXPECT_OK(p.validate());
  p.covariance(0, 1) = 0.5;
  EXPECT_NE(p.validate().message().find("not symmetric"), std::string::npos);
  p.covariance = Matrix6d::Identity();
  p.covariance(3, 3) = -1;
  EXPECT_NE(p.validate().message().find("negative variance"), std::string::npos);
}

TEST(PointCloud, EigenViewsShareMemory) {
  PointCloud cloud = PointCloud::fromXyz({{1, 2, 3}, {4, 5, 6}}, "lidar", 10);
  auto xyz = cloud.xyzMatrix();
  EXPECT_EQ(xyz.cols(), 2);
  EXPECT_EQ(xyz(2, 1), 6.0f);
  EXPECT_EQ(xyz.data(), reinterpret_cast<const float*>(cloud.points.data()));
  auto homogeneous = cloud.homogeneousMatrix();
  EXPECT_EQ(homogeneous(3, 0), 1.0f);
  EXPECT_EQ(homogeneous(0, 1), 4.0f);
}

TEST(PointCloud, ValidateFindsNanPointsAndFieldSizeMismatches) {
  PointCloud cloud = PointCloud::fromXyz({{1, 2, 3}, {NAN, 0, 0}});
  Status s = cloud.validate("input 'cloud'");
  EXPECT_NE(s.message().find("point 1"), std::string::npos) << s.message();
  EXPECT_OK(cloud.validate("cloud", /*require_finite=*/false));
  cloud = PointCloud::fromXyz({{1, 2, 3}, {4, 5, 6}});
  cloud.intensity = Buffer<float>::fromVector({1.0f});
  EXPECT_NE(cloud.validate().message().find("2 points but 1 intensity"), std::string::npos);
  EXPECT_NE(PointCloud{}.validate().message().find("no points"), std::string::npos);
}

TEST(Features, DescriptorRowsMustMatchKeypoints) {
  Features2D f;
  f.keypoints.resize(3);
  f.descriptors.rows = 2;
  f.descriptors.cols = 32;
  f.descriptors.data = Buffer<std::uint8_t>::fromVector(std::vector<std::uint8_t>(64));
  EXPECT_NE(f.validate().message().find("3 keypoints but 2 descriptors"), std::string::npos);
  f.descriptors.rows = 3;
  EXPECT_NE(f.validate().message().find("hold 64 bytes; expected 96"), std::string::npos);
}

TEST(Correspondences, CountsMustAgree) {
  Correspondences2D3D c;
  c.points.resize(4);
  c.pixels.resize(3);
  EXPECT_FALSE(c.validate().isOk());
  c.pixels.resize(4, Eigen::Vector2d::Zero());
  for (auto& p : c.points) p.setZero();
  EXPECT_OK(c.validate());
}

TEST(TriangleMesh, IndicesMustBeInRange) {
  TriangleMesh mesh;
  mesh.vertices = Buffer<Eigen::Vector3f>::fromVector({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector({{0, 1, 2}});
  EXPECT_OK(mesh.validate());
  mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector({{0, 1, 3}});
  EXPECT_NE(mesh.validate().message().find("uses vertex 3; expected an index < 3"),
            std::string::npos);
}

TEST(JointState, ValueCountsMustMatchNames) {
  JointState j;
  j.names = {"shoulder", "elbow"};
  j.position = {0.1, 0.2};
  EXPECT_OK(j.validate());
  j.velocity = {0.0};
  EXPECT_FALSE(j.validate().isOk());
  j.velocity = {};
  j.position[1] = std::nan("");
  EXPECT_NE(j.validate().message().find("'elbow'"), std::string::npos);
}

TEST(Sensors, NonFiniteSamplesAreRejected) {
  ImuSample imu;
  EXPECT_OK(imu.validate());
  imu.angular_velocity.y() = INFINITY;
  EXPECT_FALSE(imu.validate().isOk());
  Wrench w;
  w.torque.z() = NAN;
  EXPECT_FALSE(w.validate().isOk());
}

TEST(LidarInfo, ValidateNamesTheFieldAndTheValue) {
  LidarInfo info;
  info.frame_id = "lidar";
  info.elevations = {0.1, -0.2, 0.1};
  info.min_range = 0.5;
  EXPECT_OK(info.validate());
  // Sorted, lowest first, lasers within the tolerance one.
  EXPECT_EQ(info.sortedElevations(), (std::vector<double>{-0.2, 0.1}));
  LidarInfo close = info;
  close.elevations = {0.3, 0.1, 0.105, -0.2};
  EXPECT_EQ(close.sortedElevations(0.01), (std::vector<double>{-0.2, 0.1, 0.3}));
  auto rejected = [](const LidarInfo& bad, const std::string& fragment) {
    const Status s = bad.validate();
    EXPECT_EQ(s.code(), StatusCode::kInvalidInput) << fragment;
    EXPECT_NE(s.message().find(fragment), std::string::npos) << s.message();
  };
  LidarInfo bad = info;
  bad.elevations.clear();
  rejected(bad, "LIDAR info 'lidar' has no laser elevation");
  bad = info;
  bad.elevations[2] = 1.6;
  rejected(bad, "laser 2 elevation is 1.6 rad; expected a finite angle within +-pi/2");
  bad.elevations[2] = std::nan("");
  rejected(bad, "laser 2 elevation is nan");
  bad = info;
  bad.rotation_rate = 0;
  rejected(bad, "rotation_rate is 0 Hz; expected a finite rate > 0");
  bad = info;
  bad.max_range = 0.5;
  rejected(bad, "range is [0.5, 0.5] m; expected finite bounds with 0 <= min_range < max_range");
  bad = info;
  bad.min_range = -1;
  rejected(bad, "range is [-1, 100] m");
  bad = info;
  bad.range_noise = INFINITY;
  rejected(bad, "range_noise is inf m");
}

TEST(Detections, ValidateNamesTheDetectionTheFieldAndTheValue) {
  Detections d;
  d.frame_id = "camera_optical";
  EXPECT_OK(d.validate());  // no detection: nothing found
  Detection det;
  det.pose = Transform::identity("camera_optical", "target_body");
  det.pose.translation = Eigen::Vector3d(0.1, 0.2, 5.0);
  det.similarity = 0.9;
  det.template_id = "range_3/1234";
  det.width = 64;
  det.height = 48;
  d.detections = {det, det};
  EXPECT_OK(d.validate());
  auto rejected = [](const Detections& bad, const std::string& fragment) {
    const Status s = bad.validate();
    EXPECT_EQ(s.code(), StatusCode::kInvalidInput) << fragment;
    EXPECT_NE(s.message().find(fragment), std::string::npos) << s.message();
  };
  Detections bad = d;
  bad.detections[1].similarity = std::nan("");
  rejected(bad, "detection 1 similarity is nan; expected a finite value in [0, 1]");
  bad = d;
  bad.detections[0].similarity = 1.5;
  rejected(bad, "detection 0 similarity is 1.5");
  bad = d;
  bad.detections[1].pose.rotation = Eigen::Quaterniond(1.0, 0.5, 0.0, 0.0);  // norm 1.118
  rejected(bad,
           "detection 1 pose: transform camera_optical_T_target_body rotation quaternion "
           "has norm 1.11803399; expected a unit quaternion");
  bad = d;
  bad.detections[0].pose.translation.z() = INFINITY;
  rejected(bad, "detection 0 pose");
  bad = d;
  bad.detections[1].width = -3;
  rejected(bad, "detection 1 box is -3x48 pixels");
}

TEST(Time, SecondsConversionRoundsToTheNearestMicrosecond) {
  EXPECT_EQ(fromSeconds(1.0000004), 1'000'000);
  EXPECT_EQ(fromSeconds(-0.0000006), -1);
  EXPECT_DOUBLE_EQ(toSeconds(2'500'000), 2.5);
}

}  // namespace
}  // namespace cdff

namespace cdff {
namespace {

TEST(Statistics, ChiSquareQuantilesMatchPublishedTables) {
  // Values from standard chi-square tables (5 significant digits).
  EXPECT_NEAR(chiSquareQuantile(0.95, 1), 3.8415, 1e-4);
  EXPECT_NEAR(chiSquareQuantile(0.95, 6), 12.592, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(0.999, 6), 22.458, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(0.025, 12), 4.4038, 1e-4);
  EXPECT_NEAR(chiSquareQuantile(0.975, 300), 349.87, 1e-2);
  for (int dof : {1, 3, 6, 12, 600})
    for (double p : {0.001, 0.025, 0.5, 0.975, 0.999})
      EXPECT_NEAR(chiSquareCdf(chiSquareQuantile(p, dof), dof), p, 1e-9) << dof << " " << p;
  EXPECT_TRUE(std::isnan(chiSquareQuantile(1.0, 6)));
  EXPECT_TRUE(std::isnan(chiSquareQuantile(0.5, 0)));
}

TEST(Geometry, TheClosestPointOnATriangleIsInItsPlaneOnAnEdgeOrAtAVertex) {
  const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
  // Above the inside: the projection; beyond an edge: on it; beyond a vertex: the vertex.
  EXPECT_LT((closestPointOnTriangle({0.5, 0.5, 3}, a, b, c) - Eigen::Vector3d(0.5, 0.5, 0)).norm(),
            1e-15);
  EXPECT_LT((closestPointOnTriangle({1, -1, 1}, a, b, c) - Eigen::Vector3d(1, 0, 0)).norm(), 1e-15);
  EXPECT_LT((closestPointOnTriangle({2, 2, 0}, a, b, c) - Eigen::Vector3d(1, 1, 0)).norm(), 1e-15);
  EXPECT_LT((closestPointOnTriangle({-1, -1, 0}, a, b, c) - a).norm(), 1e-15);
  EXPECT_LT((closestPointOnTriangle({3, -1, 0}, a, b, c) - b).norm(), 1e-15);
  // A degenerate triangle (a segment) gives a point on it, never NaN.
  const Eigen::Vector3d q = closestPointOnTriangle({1, 1, 0}, a, b, Eigen::Vector3d(1, 0, 0));
  EXPECT_TRUE(q.allFinite());
  EXPECT_NEAR(q.y(), 0.0, 1e-15);
}

TEST(Geometry, LeftJacobianLinearisesTheExponentialAndItsInverseUndoesIt) {
  const Eigen::Vector3d phi(0.4, -0.9, 0.3);
  const Eigen::Matrix3d jl = leftJacobianSO3(phi);
  EXPECT_LT((jl * inverseLeftJacobianSO3(phi) - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  // exp(phi + d) = exp(J_l d) exp(phi) + O(|d|^2)
  const Eigen::Vector3d d = 1e-6 * Eigen::Vector3d(1.0, 2.0, -1.5);
  const Eigen::Quaterniond lhs = expSO3(phi + d);
  const Eigen::Quaterniond rhs = expSO3(jl * d) * expSO3(phi);
  EXPECT_LT(angularDistance(lhs, rhs), 1e-11);
  // Near zero the series branch agrees with the closed form.
  const Eigen::Vector3d tiny(1e-7, -2e-7, 3e-7);
  EXPECT_LT((leftJacobianSO3(tiny) - Eigen::Matrix3d::Identity()).norm(), 1e-6);
  EXPECT_LT((skew(phi) * d - phi.cross(d)).norm(), 1e-18);
}

}  // namespace
}  // namespace cdff
