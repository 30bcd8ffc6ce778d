// KeypointExtraction3D: uniform sampling keeps, in each occupied voxel, the input point nearest
// its centre (with that point's normal); ISS keypoints of a box lie at its edges and corners and
// are repeatable under a rigid motion; the default radii follow the point spacing, whatever the
// sampling and the scale; small clouds give no keypoint and a warning; bad inputs and
// parameters are reported with the port or parameter and the value.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include "KeypointExtraction3D.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/types/kd_tree.hpp"
#include "cdff/types/mesh.hpp"
#include "keypoints_common.hpp"
#include "support/dfn_testing.hpp"
#include "support/lidar.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<KeypointExtraction3D> make(const std::string& dfi, const std::string& yaml) {
  return testing::makeDfn<KeypointExtraction3D>("KeypointExtraction3D", dfi, yaml);
}

/// `cloud` with its points moved by `motion` and Gaussian noise of `sigma` per axis (normals
/// rotated, not noised).
PointCloud moved(const PointCloud& cloud, const Eigen::Isometry3f& motion, float sigma,
                 std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, sigma);
  std::vector<Point4f> points, normals;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    Eigen::Vector3f p = motion * cloud.points[i].vec();
    if (sigma > 0) p += Eigen::Vector3f(noise(rng), noise(rng), noise(rng));
    points.emplace_back(p.x(), p.y(), p.z());
    if (cloud.hasNormals()) {
      const Eigen::Vector3f n = motion.linear() * cloud.normals[i].vec();
      normals.emplace_back(n.x(), n.y(), n.z());
    }
  }
  PointCloud out = cloud;
  out.points = Buffer<Point4f>::fromVector(std::move(points));
  if (cloud.hasNormals()) out.normals = Buffer<Point4f>::fromVector(std::move(normals));
  return out;
}

PointCloud scaled(const PointCloud& cloud, float factor) {
  return moved(cloud, Eigen::Isometry3f(Eigen::Scaling(factor)), 0, 0);
}

/// The index of the cloud point at exactly `position`, or -1.
long indexOf(const KdTree3f& tree, const Eigen::Vector3f& position) {
  KdTree3f::Neighbour found;
  if (!tree.nearest(position, 1e-20f, found)) return -1;
  return found.index;
}

/// Every keypoint is a point of `cloud` and carries that point's normal (unit), or the zero
/// vector when the cloud has none.
void expectInputPointsWithTheirNormals(const Features3D& keypoints, const PointCloud& cloud) {
  const KdTree3f tree(cloud.points.span());
  for (std::size_t k = 0; k < keypoints.size(); ++k) {
    const Keypoint3D& keypoint = keypoints.keypoints[k];
    const long i = indexOf(tree, keypoint.position);
    ASSERT_GE(i, 0) << "keypoint " << k << " is not a point of the cloud";
    if (cloud.hasNormals())
      EXPECT_LT((keypoint.normal - cloud.normals[i].vec().normalized()).norm(), 1e-6f)
          << "keypoint " << k;
    else
      EXPECT_EQ(keypoint.normal, Eigen::Vector3f::Zero()) << "keypoint " << k;
  }
}

// ---------------------------------------------------------------------------------------------
// The point spacing from which the default radii follow.

TEST(KeypointExtraction3D, PointSpacingIsThePitchForAGridAndForRandomSamples) {
  // A 100 x 100 grid of pitch 1 cm, and 10 000 uniform random points on the same 1 m^2 (mean
  // pitch 1 cm too). The estimate r8 sqrt(pi/8) is 0.89 pitch on the grid (its 8th neighbour is
  // at the diagonal, sqrt(2) pitch) and 0.98 pitch for random samples (a disc holding 8 points
  // on average has its median 8th neighbour at sqrt(7.67/pi) pitch): both within 15 %, where
  // the nearest neighbour would differ by a factor 2.
  std::vector<Eigen::Vector3f> grid, random;
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j) {
      grid.emplace_back(0.01f * i, 0.01f * j, 2.0f);
      random.emplace_back(u(rng), u(rng), 2.0f);
    }
  EXPECT_NEAR(pointSpacing(PointCloud::fromXyz(grid)), 0.01, 0.0015);
  EXPECT_NEAR(pointSpacing(PointCloud::fromXyz(random)), 0.01, 0.0015);
}

// ---------------------------------------------------------------------------------------------
// UniformSampling

TEST(KeypointExtraction3DUniformSampling, KeepsThePointNearestTheCentreOfEachOccupiedVoxel) {
  // 20 000 random points on [0.01, 0.99]^2 at z = 0.3123 (inside one voxel layer), each with its
  // own slightly tilted normal; voxels of 5 cm: 20 x 20 occupied voxels of 40 to 50 points (an
  // empty one has probability e^-40).
  const double radius = 0.05;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.01f, 0.99f);
  std::vector<Point4f> points, normals;
  for (int i = 0; i < 20'000; ++i) {
    points.emplace_back(u(rng), u(rng), 0.3123f);
    const Eigen::Vector3f n =
        Eigen::Vector3f(0.1f * std::sin(0.1f * i), 0.1f * std::cos(0.1f * i), 1.0f).normalized();
    normals.emplace_back(n.x(), n.y(), n.z());
  }
  PointCloud cloud;
  cloud.frame_id = "target";
  cloud.stamp = 42;
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  cloud.normals = Buffer<Point4f>::fromVector(std::move(normals));

  auto sampler = make("UniformSampling", "{radius: 0.05}");
  sampler->in.cloud.set(cloud);
  ASSERT_OK(sampler->process());
  const Features3D& keypoints = *sampler->out.keypoints;
  EXPECT_EQ(keypoints.frame_id, "target");
  EXPECT_EQ(keypoints.stamp, 42);
  EXPECT_TRUE(keypoints.descriptors.empty());
  expectInputPointsWithTheirNormals(keypoints, cloud);

  // The truth, computed as the rule states it (voxel coordinates floor(x / radius) in float, as
  // PCL computes them, so that a point on a voxel boundary is counted in the same voxel):
  // the point nearest the centre of each occupied voxel.
  const float inverse = 1.0f / static_cast<float>(radius);
  std::map<std::tuple<int, int, int>, std::pair<double, Eigen::Vector3f>> nearest;
  for (const Point4f& p : cloud.points) {
    const Eigen::Vector3i ijk((p.vec() * inverse).array().floor().cast<int>());
    const Eigen::Vector3d centre = (ijk.cast<double>().array() + 0.5) * radius;
    const double d = (p.vec().cast<double>() - centre).norm();
    auto [it, inserted] =
        nearest.try_emplace({ijk.x(), ijk.y(), ijk.z()}, std::make_pair(d, p.vec()));
    if (!inserted && d < it->second.first) it->second = {d, p.vec()};
  }
  ASSERT_EQ(nearest.size(), 20u * 20u) << "the square spans 20 x 20 voxels";
  ASSERT_EQ(keypoints.size(), nearest.size()) << "one keypoint per occupied voxel";
  std::set<std::tuple<float, float, float>> expected, got;
  for (const auto& [voxel, best] : nearest)
    expected.emplace(best.second.x(), best.second.y(), best.second.z());
  for (const Keypoint3D& k : keypoints.keypoints)
    got.emplace(k.position.x(), k.position.y(), k.position.z());
  EXPECT_EQ(got, expected);

  // Hence every point of the cloud is within a voxel diagonal (radius sqrt(3)) of a keypoint.
  std::vector<Point4f> keypoint_points;
  for (const Keypoint3D& k : keypoints.keypoints)
    keypoint_points.emplace_back(k.position.x(), k.position.y(), k.position.z());
  const KdTree3f keypoint_tree(keypoint_points);
  const float diagonal = static_cast<float>(radius * std::sqrt(3.0));
  KdTree3f::Neighbour found;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    ASSERT_TRUE(keypoint_tree.nearest(cloud.points[i].vec(), diagonal * diagonal, found))
        << "point " << i << " is farther than a voxel diagonal from every keypoint";
}

TEST(KeypointExtraction3DUniformSampling, DefaultVoxelGivesTheExpectedKeypointCountOnABox) {
  // A 1.0 x 0.8 x 0.6 m box (3.76 m^2) sampled at 20 000 random points: s = sqrt(3.76 / 20 000)
  // = 13.7 mm, voxels of 4 s = 54.8 mm, so about 3.76 / 0.0548^2 = 1252 voxels meet the faces.
  // The estimate of s is within 10 % (so the voxel area within 20 %), and voxels along the 12
  // edges are shared by two faces or cut a face partly (together +-15 %): [0.7, 1.4] x 1252.
  const TriangleMesh box = testing::boxMesh({0.5, 0.4, 0.3});
  const PointCloud cloud = sampleSurface(box, 20'000, 1).value();
  auto sampler = make("UniformSampling", "{}");
  sampler->in.cloud.set(cloud);
  ASSERT_OK(sampler->process());
  const double expected =
      box.surfaceArea() / std::pow(4 * std::sqrt(box.surfaceArea() / 20'000), 2);
  EXPECT_GT(sampler->out.keypoints->size(), 0.7 * expected);
  EXPECT_LT(sampler->out.keypoints->size(), 1.4 * expected);
  expectInputPointsWithTheirNormals(*sampler->out.keypoints, cloud);
}

TEST(KeypointExtraction3DUniformSampling, AGridTooFineForPclIsAnError) {
  // Two points 1 km apart along the diagonal and a 0.1 mm voxel: 10^7 voxels per axis, far more
  // than PCL's 32-bit voxel index; the radius is below the extent, so only this check catches it.
  auto sampler = make("UniformSampling", "{radius: 0.0001}");
  sampler->in.cloud.set(PointCloud::fromXyz({{0, 0, 0}, {1000, 1000, 1000}}));
  testing::expectRejected(*sampler, "parameter 'radius' = 0.0001 m", StatusCode::kInvalidParameter);
}

// ---------------------------------------------------------------------------------------------
// Iss

/// The distance from `p` to the nearest edge of the box of half extents `half` at the origin,
/// for a point near its surface: the second smallest distance to the three face pairs.
float distanceToEdge(const Eigen::Vector3f& p, const Eigen::Vector3f& half) {
  Eigen::Vector3f gaps = (half - p.cwiseAbs()).cwiseAbs();
  std::sort(gaps.data(), gaps.data() + 3);
  return std::hypot(gaps[0], gaps[1]);
}

TEST(KeypointExtraction3DIss, KeypointsOfANoisyBoxAreAtItsEdgesAndCorners) {
  // The box of the count test with 2 mm noise per axis: s = 13.7 mm, salient radius R = 4 s
  // = 55 mm. A point farther than R from every edge sees one noisy plane, whose l3/l1 is about
  // 18 sigma^2/R^2 = 0.024 (0.09 at most over the face, measured), below min_saliency = 0.1;
  // within R of an edge it sees two faces (l3/l1 0.2 to 0.7). So every keypoint is within R of
  // an edge, and each of the 8 corners (three faces, the most salient places) has one within R.
  const Eigen::Vector3f half(0.5f, 0.4f, 0.3f);
  const TriangleMesh box = testing::boxMesh(half.cast<double>());
  const PointCloud cloud =
      moved(sampleSurface(box, 20'000, 1).value(), Eigen::Isometry3f::Identity(), 0.002f, 2);
  auto iss = make("Iss", "{}");
  iss->in.cloud.set(cloud);
  ASSERT_OK(iss->process());
  const Features3D& keypoints = *iss->out.keypoints;
  ASSERT_GE(keypoints.size(), 8u);
  expectInputPointsWithTheirNormals(keypoints, cloud);
  const float salient_radius = 4 * std::sqrt(static_cast<float>(box.surfaceArea()) / 20'000);
  for (std::size_t k = 0; k < keypoints.size(); ++k)
    EXPECT_LT(distanceToEdge(keypoints.keypoints[k].position, half), salient_radius)
        << "keypoint " << k << " at " << keypoints.keypoints[k].position.transpose()
        << " is on a flat face";
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3f c(corner & 1 ? half.x() : -half.x(), corner & 2 ? half.y() : -half.y(),
                            corner & 4 ? half.z() : -half.z());
    const bool found =
        std::any_of(keypoints.keypoints.begin(), keypoints.keypoints.end(),
                    [&](const Keypoint3D& k) { return (k.position - c).norm() < salient_radius; });
    EXPECT_TRUE(found) << "no keypoint near corner " << c.transpose();
  }

  // Without the saliency bound (PCL's ISS as it is), the noise of the faces gives keypoints all
  // over them: the bound is what keeps the flat faces out.
  auto plain_iss = make("Iss", "{min_saliency: 0}");
  plain_iss->in.cloud.set(cloud);
  ASSERT_OK(plain_iss->process());
  std::size_t on_faces = 0;
  for (const Keypoint3D& k : plain_iss->out.keypoints->keypoints)
    on_faces += distanceToEdge(k.position, half) >= salient_radius;
  EXPECT_GT(on_faces, plain_iss->out.keypoints->size() / 2);
}

TEST(KeypointExtraction3DIss, KeypointsAreRepeatableUnderARigidMotion) {
  // The satellite sampled at 20 000 points with 1 mm noise, and the same points moved by a
  // rigid motion: the neighbourhoods are the same, the eigenvalues equal up to float rounding,
  // so the keypoints must be the same points except where two rounding-level near-ties in the
  // non-maximum suppression or at min_saliency flip: at least 90 % of them.
  const PointCloud cloud = moved(sampleSurface(testing::satelliteMesh(), 20'000, 3).value(),
                                 Eigen::Isometry3f::Identity(), 0.001f, 4);
  Eigen::Isometry3f motion =
      Eigen::Translation3f(3.0f, -2.0f, 5.0f) *
      Eigen::AngleAxisf(0.7f, Eigen::Vector3f(1.0f, 2.0f, -0.5f).normalized());
  const PointCloud moved_cloud = moved(cloud, motion, 0, 0);
  auto iss = make("Iss", "{}");
  iss->in.cloud.set(cloud);
  ASSERT_OK(iss->process());
  const std::vector<Keypoint3D> first = iss->out.keypoints->keypoints;
  iss->in.cloud.set(moved_cloud);
  ASSERT_OK(iss->process());
  const std::vector<Keypoint3D>& second = iss->out.keypoints->keypoints;
  ASSERT_GE(first.size(), 50u);
  std::vector<Point4f> back;
  for (const Keypoint3D& k : second) {
    const Eigen::Vector3f p = motion.inverse() * k.position;
    back.emplace_back(p.x(), p.y(), p.z());
  }
  const KdTree3f tree(back);
  std::size_t repeated = 0;
  KdTree3f::Neighbour found;
  for (const Keypoint3D& k : first) repeated += tree.nearest(k.position, 1e-3f * 1e-3f, found);
  EXPECT_GE(repeated, 0.9 * first.size()) << repeated << " of " << first.size();
  EXPECT_LE(second.size(), 1.1 * first.size());
}

// ---------------------------------------------------------------------------------------------
// Both DFIs

struct UniformSamplingDfi {
  static constexpr const char* name = "UniformSampling";
  static constexpr const char* radius = "radius";
};
struct IssDfi {
  static constexpr const char* name = "Iss";
  static constexpr const char* radius = "salient_radius";
};

template <typename Dfi>
class KeypointExtraction3DTest : public ::testing::Test {};
using Dfis = ::testing::Types<UniformSamplingDfi, IssDfi>;
TYPED_TEST_SUITE(KeypointExtraction3DTest, Dfis);

TYPED_TEST(KeypointExtraction3DTest, DefaultRadiusFollowsTheCloudScale) {
  // The same satellite cloud in metres and scaled by 10: the derived radii scale by 10 with the
  // spacing, every neighbourhood (and UniformSampling's grid, aligned on the origin) scales
  // with them, so the keypoints are the same up to float rounding at voxel boundaries and
  // near-ties: counts within 3 %.
  const PointCloud cloud = sampleSurface(testing::satelliteMesh(), 20'000, 5).value();
  auto node = make(TypeParam::name, "{}");
  node->in.cloud.set(cloud);
  ASSERT_OK(node->process());
  const double count = static_cast<double>(node->out.keypoints->size());
  node->in.cloud.set(scaled(cloud, 10.0f));
  ASSERT_OK(node->process());
  const double count_scaled = static_cast<double>(node->out.keypoints->size());
  EXPECT_GT(count, 50);
  EXPECT_NEAR(count_scaled, count, 0.03 * count);
  EXPECT_EQ(node->diagnostics().warning_count, 0u);
}

TYPED_TEST(KeypointExtraction3DTest, CloudsTooSmallGiveNoKeypointAndAWarning) {
  auto node = make(TypeParam::name, "{}");
  // 4 points: too few to derive the spacing from (8 neighbours), and fewer than ISS's
  // min_neighbors (5).
  PointCloud tiny =
      PointCloud::fromXyz({{0, 0, 1}, {0.1f, 0, 1}, {0, 0.1f, 1}, {0, 0, 1.1f}}, "lidar", 9);
  node->in.cloud.set(tiny);
  ASSERT_OK(node->process());
  EXPECT_EQ(node->out.keypoints->size(), 0u);
  EXPECT_EQ(node->out.keypoints->frame_id, "lidar");
  EXPECT_EQ(node->out.keypoints->stamp, 9);
  EXPECT_EQ(node->diagnostics().warning_count, 1u);
  // 50 copies of one point: no extent, nothing to pick from.
  node->in.cloud.set(PointCloud::fromXyz(std::vector<Eigen::Vector3f>(50, {1, 2, 3})));
  ASSERT_OK(node->process());
  EXPECT_EQ(node->out.keypoints->size(), 0u);
  EXPECT_EQ(node->diagnostics().warning_count, 2u);
  EXPECT_NE(node->diagnostics().warnings.back().find("coincide"), std::string::npos)
      << node->diagnostics().warnings.back();
}

TYPED_TEST(KeypointExtraction3DTest, BadInputsAndParametersAreReported) {
  auto node = make(TypeParam::name, "{}");
  node->in.cloud.set(PointCloud{});
  testing::expectRejected(*node, "input 'cloud' has no points");
  node->in.cloud.set(PointCloud::fromXyz({{0, 0, 1}, {0, std::nanf(""), 1}, {1, 0, 1}}));
  testing::expectRejected(*node, "input 'cloud' point 1");
  node->in.cloud.set(PointCloud::fromXyz({{0, 0, 1}, {INFINITY, 0, 1}}));
  testing::expectRejected(*node, "input 'cloud' point 1");

  // A radius larger than the cloud's bounding-box diagonal (here 0.9 sqrt(3) = 1.56 m): metres
  // given as mm.
  const std::string radius = TypeParam::radius;
  auto too_large = make(TypeParam::name, "{" + radius + ": 50}");
  std::vector<Eigen::Vector3f> cube;
  for (int i = 0; i < 1000; ++i)
    cube.emplace_back(0.1f * (i % 10), 0.1f * (i / 10 % 10), 0.1f * (i / 100));
  too_large->in.cloud.set(PointCloud::fromXyz(cube));
  testing::expectRejected(*too_large, "parameter '" + radius + "' = 50 m is larger than",
                          StatusCode::kInvalidParameter);
  testing::expectRejected(*too_large, "bounding-box diagonal 1.559 m",
                          StatusCode::kInvalidParameter);

  auto fresh = Registry::instance().create("KeypointExtraction3D", TypeParam::name);
  ASSERT_TRUE(fresh.isOk());
  const Status s = fresh.value()->configure(YAML::Load("{" + radius + ": -0.1}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find(radius), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("-0.1"), std::string::npos) << s.message();
}

TEST(KeypointExtraction3DIss, NonMaxRadiusLargerThanTheCloudIsAnError) {
  auto iss = make("Iss", "{non_max_radius: 3}");
  std::vector<Eigen::Vector3f> square;
  for (int i = 0; i < 100; ++i) square.emplace_back(0.01f * (i % 10), 0.01f * (i / 10), 1.0f);
  iss->in.cloud.set(PointCloud::fromXyz(square));
  testing::expectRejected(*iss, "parameter 'non_max_radius' = 3 m", StatusCode::kInvalidParameter);
}

}  // namespace
}  // namespace cdff::dfn
