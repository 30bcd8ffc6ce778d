// NormalsEstimation: on a spherical cap the normals must be radial, on a noisy plane normal to
// it, both facing the viewpoint; both DFIs must agree; points without enough neighbours are left
// out with a warning; bad inputs and parameters are reported.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "NormalsEstimation.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

struct PcaName {
  static constexpr const char* name = "Pca";
};
struct PclName {
  static constexpr const char* name = "Pcl";
};

template <typename Dfi>
class NormalsEstimationTest : public ::testing::Test {
 public:
  static std::unique_ptr<NormalsEstimation> make(const std::string& yaml) {
    return testing::makeDfn<NormalsEstimation>("NormalsEstimation", Dfi::name, yaml);
  }
};
using Dfis = ::testing::Types<PcaName, PclName>;
TYPED_TEST_SUITE(NormalsEstimationTest, Dfis);

// Points on the cap z > 0.5 of the unit sphere, uniform by area.
PointCloud sphereCap(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3f> points;
  while (points.size() < n) {
    const double z = 0.5 + 0.5 * u(rng), phi = 2 * M_PI * u(rng);
    const double r = std::sqrt(1 - z * z);
    points.emplace_back(static_cast<float>(r * std::cos(phi)),
                        static_cast<float>(r * std::sin(phi)), static_cast<float>(z));
  }
  return PointCloud::fromXyz(points, "model", 7);
}

TYPED_TEST(NormalsEstimationTest, NormalsOfASphericalCapAreRadialAndFaceTheViewpoint) {
  auto normals = this->make("{neighbours: 15, viewpoint: [0, 0, 10]}");
  const PointCloud cap = sphereCap(20'000, 1);
  normals->in.cloud.set(cap);
  ASSERT_OK(normals->process());
  const PointCloud& out = *normals->out.with_normals;
  ASSERT_EQ(out.size(), cap.size());
  ASSERT_TRUE(out.hasNormals());
  EXPECT_TRUE(out.points.sharesMemoryWith(cap.points)) << "points are shared, not copied";
  EXPECT_EQ(out.frame_id, "model");
  EXPECT_EQ(out.stamp, 7);
  double worst = 0, sum = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const Eigen::Vector3f n = out.normals[i].vec();
    EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
    const double angle =
        std::acos(std::clamp<double>(n.dot(out.points[i].vec().normalized()), -1, 1));
    worst = std::max(worst, angle);
    sum += angle;
  }
  // 20 000 points on 3.14 m^2: 12 mm spacing; a 15-point patch spans ~2.5 cm of a 1 m sphere,
  // whose curvature then tilts a fitted plane by well under a degree.
  EXPECT_LT(sum / out.size(), 0.2 * M_PI / 180.0);
  EXPECT_LT(worst, 2.0 * M_PI / 180.0);
}

TYPED_TEST(NormalsEstimationTest, NormalsOfANoisyPlaneArePerpendicularToIt) {
  // A tilted plane with 2 mm noise, 20 000 points on 4 m^2 (2 cm^2 each): a 5 cm radius holds
  // about 40 points spread by R/2 = 2.5 cm, so each normal errs by about
  // 0.002 / (0.025 sqrt(40)) = 0.73 deg per axis, 0.9 deg on average (Rayleigh mean).
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::normal_distribution<float> noise(0.0f, 0.002f);
  const Eigen::Vector3f normal = Eigen::Vector3f(0.2f, -0.3f, 1.0f).normalized();
  const Eigen::Vector3f e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 20'000; ++i)
    points.push_back(Eigen::Vector3f(0, 0, 3) + u(rng) * e1 + u(rng) * e2 + noise(rng) * normal);
  auto normals = this->make("{radius: 0.05}");  // viewpoint: the origin, below the plane
  normals->in.cloud.set(PointCloud::fromXyz(points));
  ASSERT_OK(normals->process());
  const PointCloud& out = *normals->out.with_normals;
  ASSERT_EQ(out.size(), points.size());
  double sum = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const Eigen::Vector3f n = out.normals[i].vec();
    EXPECT_LT(n.dot(normal), 0.0f) << "point " << i << " faces away from the viewpoint";
    sum += std::acos(std::min(1.0f, std::abs(n.dot(normal))));
  }
  EXPECT_LT(sum / out.size(), 1.3 * M_PI / 180.0);
}

TYPED_TEST(NormalsEstimationTest, IsolatedPointsGetNoNormalAndAWarning) {
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) points.emplace_back(0.01f * i, 0.01f * j, 1.0f);
  points.emplace_back(5.0f, 5.0f, 5.0f);  // alone
  std::vector<float> intensity(points.size());
  for (std::size_t i = 0; i < intensity.size(); ++i) intensity[i] = static_cast<float>(i);
  PointCloud cloud = PointCloud::fromXyz(points);
  cloud.intensity = Buffer<float>::fromVector(std::move(intensity));
  auto normals = this->make("{radius: 0.03}");
  normals->in.cloud.set(cloud);
  ASSERT_OK(normals->process());
  const PointCloud& out = *normals->out.with_normals;
  EXPECT_EQ(out.size(), 100u);
  EXPECT_OK(out.validate());
  EXPECT_EQ(out.intensity[99], 99.0f);
  EXPECT_EQ(normals->diagnostics().warning_count, 1u);
}

TYPED_TEST(NormalsEstimationTest, BadInputsAndParametersAreReported) {
  auto normals = this->make("{}");
  normals->in.cloud.set(PointCloud{});
  testing::expectRejected(*normals, "input 'cloud' has no points");
  normals->in.cloud.set(PointCloud::fromXyz({{0, 0, 1}, {0, std::nanf(""), 1}, {1, 0, 1}}));
  testing::expectRejected(*normals, "input 'cloud' point 1");

  auto node = Registry::instance().create("NormalsEstimation", TypeParam::name);
  ASSERT_TRUE(node.isOk());
  Status s = node.value()->configure(YAML::Load("{neighbours: 2}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("neighbours"), std::string::npos) << s.message();
  s = node.value()->configure(YAML::Load("{viewpoint: [0, 0]}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
}

TEST(NormalsEstimation, BothDfisFindTheSameNormals) {
  const PointCloud cap = sphereCap(5'000, 3);
  auto pca = testing::makeDfn<NormalsEstimation>("NormalsEstimation", "Pca", "{neighbours: 10}");
  auto pcl = testing::makeDfn<NormalsEstimation>("NormalsEstimation", "Pcl", "{neighbours: 10}");
  for (auto* n : {pca.get(), pcl.get()}) {
    n->in.cloud.set(cap);
    ASSERT_OK(n->process());
  }
  ASSERT_EQ(pca->out.with_normals->size(), pcl->out.with_normals->size());
  for (std::size_t i = 0; i < cap.size(); ++i)
    EXPECT_GT(pca->out.with_normals->normals[i].vec().dot(pcl->out.with_normals->normals[i].vec()),
              std::cos(1e-3f))
        << "point " << i;
}

}  // namespace
}  // namespace cdff::dfn
