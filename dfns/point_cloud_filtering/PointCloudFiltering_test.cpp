// PointCloudFiltering: each stage against a brute-force reference on random clouds (the crop box
// keeps exactly the points inside the moved box with all their fields; every voxel centroid is
// the mean of its voxel's points; outliers far from a noisy plane go, the plane stays), both DFIs
// give the same result, invalid points are dropped and bad inputs are reported.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <tuple>

#include "PointCloudFiltering.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

PointCloud randomCloud(std::size_t n, float half, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-half, half);
  std::vector<Point4f> points;
  std::vector<float> intensity;
  for (std::size_t i = 0; i < n; ++i) {
    points.emplace_back(u(rng), u(rng), u(rng));
    intensity.push_back(static_cast<float>(i));
  }
  PointCloud cloud;
  cloud.frame_id = "lidar";
  cloud.stamp = 42;
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  cloud.intensity = Buffer<float>::fromVector(std::move(intensity));
  return cloud;
}

std::vector<Eigen::Vector3f> sorted(const PointCloud& cloud) {
  std::vector<Eigen::Vector3f> v;
  for (const Point4f& p : cloud.points) v.push_back(p.vec());
  std::sort(v.begin(), v.end(), [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
    return std::tie(a.x(), a.y(), a.z()) < std::tie(b.x(), b.y(), b.z());
  });
  return v;
}

struct FastName {
  static constexpr const char* name = "Fast";
};
struct PclName {
  static constexpr const char* name = "Pcl";
};

template <typename Dfi>
class PointCloudFilteringTest : public ::testing::Test {
 public:
  static std::unique_ptr<PointCloudFiltering> make(const std::string& yaml) {
    return testing::makeDfn<PointCloudFiltering>("PointCloudFiltering", Dfi::name, yaml);
  }
};
using Dfis = ::testing::Types<FastName, PclName>;
TYPED_TEST_SUITE(PointCloudFilteringTest, Dfis);

TYPED_TEST(PointCloudFilteringTest, TheCropBoxKeepsExactlyThePointsInsideTheMovedBox) {
  auto filter =
      this->make("{crop_box: true, crop_min: [-0.5, -1.0, -0.2], crop_max: [1.0, 0.4, 0.3]}");
  const PointCloud cloud = randomCloud(20'000, 3.0f, 1);
  Transform box = Transform::identity("lidar", "target");
  box.translation = {0.5, -0.3, 0.2};
  box.rotation = expSO3(Eigen::Vector3d(0.2, -0.4, 0.7));
  filter->in.cloud.set(cloud);
  filter->in.box_pose.set(box);
  ASSERT_OK(filter->process());
  const PointCloud& kept = *filter->out.filtered;
  const Eigen::Isometry3d box_T_lidar = box.isometry().inverse();
  std::size_t expected = 0;
  for (const Point4f& p : cloud.points) {
    const Eigen::Vector3d b = box_T_lidar * p.vec().cast<double>();
    if (b.x() >= -0.5 && b.x() <= 1.0 && b.y() >= -1.0 && b.y() <= 0.4 && b.z() >= -0.2 &&
        b.z() <= 0.3)
      ++expected;
  }
  ASSERT_GT(expected, 100u);
  EXPECT_EQ(kept.size(), expected);
  ASSERT_EQ(kept.intensity.size(), kept.size()) << "fields of kept points are kept";
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const auto source = static_cast<std::size_t>(kept.intensity[i]);
    EXPECT_EQ(kept.points[i].vec(), cloud.points[source].vec());
  }
  EXPECT_EQ(kept.frame_id, "lidar");
  EXPECT_EQ(kept.stamp, 42);
  EXPECT_DOUBLE_EQ(*filter->out.kept_fraction, static_cast<double>(expected) / cloud.size());
}

// The box from a model's extent, grown by the margin and by 3 sigma of the box pose's position
// and attitude (times the box's radius): the same graph crops any target, as tightly as the
// prediction allows.
TYPED_TEST(PointCloudFilteringTest, TheBoxFromAModelsExtentGrowsWithThePredictionsUncertainty) {
  auto filter = this->make("{crop_box: true, crop_margin: 0.1, crop_sigmas: 3}");
  std::vector<Point4f> model_points;  // a 0.6 x 1.0 x 0.4 m box's corners, off-centre
  for (float x : {-0.2f, 0.4f})
    for (float y : {-0.5f, 0.5f})
      for (float z : {0.0f, 0.4f}) model_points.emplace_back(x, y, z);
  PointCloud model;
  model.frame_id = "target";
  model.points = Buffer<Point4f>::fromVector(std::move(model_points));
  const PointCloud cloud = randomCloud(20'000, 2.0f, 7);
  const auto count = [&](const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
    std::size_t n = 0;
    for (const Point4f& p : cloud.points) {
      const Eigen::Vector3d q = p.vec().cast<double>();
      n += (q.array() >= lo.array()).all() && (q.array() <= hi.array()).all();
    }
    return n;
  };
  filter->in.cloud.set(cloud);
  filter->in.box_pose.set(Transform::identity("lidar", "target"));
  filter->in.box_extent.set(model);
  ASSERT_OK(filter->process());
  const Eigen::Vector3d lo(-0.2, -0.5, 0.0), hi(0.4, 0.5, 0.4);
  EXPECT_EQ(filter->out.filtered->size(), count(lo.array() - 0.1, hi.array() + 0.1));
  // Position sigma 0.1 m (largest axis), attitude sigma 0.02 rad: the box radius is
  // |(0.4, 0.5, 0.4)| = 0.755 m, so the margin is 0.1 + 3 (0.1 + 0.02 x 0.755) = 0.445 m.
  RigidBodyState predicted;
  predicted.covariance.setZero();
  predicted.covariance.diagonal().head<6>() << 0.05 * 0.05, 0.1 * 0.1, 0.01 * 0.01, 1e-6,
      0.02 * 0.02, 1e-6;
  filter->in.box_uncertainty.set(predicted);
  ASSERT_OK(filter->process());
  const double margin = 0.1 + 3 * (0.1 + 0.02 * Eigen::Vector3d(0.4, 0.5, 0.4).norm());
  const std::size_t expected = count(lo.array() - margin, hi.array() + margin);
  EXPECT_GT(expected, count(lo.array() - 0.1, hi.array() + 0.1) + 100);
  EXPECT_NEAR(static_cast<double>(filter->out.filtered->size()), static_cast<double>(expected),
              2.0);  // points within float rounding of a face
  // A non-finite covariance or an extent without a finite point is rejected.
  predicted.covariance(0, 0) = std::nan("");
  filter->in.box_uncertainty.set(predicted);
  testing::expectRejected(*filter, "input 'box_uncertainty' has a non-finite pose covariance");
  filter->in.box_uncertainty.set(RigidBodyState{});
  PointCloud empty_model;
  empty_model.points = Buffer<Point4f>::fromVector({Point4f(std::nanf(""), 0.0f, 0.0f)});
  filter->in.box_extent.set(empty_model);
  testing::expectRejected(*filter, "input 'box_extent' has no finite point");
}

TYPED_TEST(PointCloudFilteringTest, EveryVoxelBecomesTheCentroidOfItsPoints) {
  constexpr double kVoxel = 0.25;
  auto filter = this->make(fmt::format("{{voxel_size: {}}}", kVoxel));
  const PointCloud cloud = randomCloud(20'000, 1.0f, 2);
  filter->in.cloud.set(cloud);
  ASSERT_OK(filter->process());
  std::map<std::tuple<int, int, int>, std::pair<Eigen::Vector3d, int>> voxels;
  const float inverse = 1.0f / static_cast<float>(kVoxel);
  for (const Point4f& p : cloud.points) {
    auto& v = voxels
                  .try_emplace({static_cast<int>(std::floor(p.x * inverse)),
                                static_cast<int>(std::floor(p.y * inverse)),
                                static_cast<int>(std::floor(p.z * inverse))},
                               Eigen::Vector3d::Zero(), 0)
                  .first->second;
    v.first += p.vec().cast<double>();
    ++v.second;
  }
  PointCloud expected;
  std::vector<Eigen::Vector3f> centroids;
  for (const auto& entry : voxels) {
    const Eigen::Vector3d c = entry.second.first / entry.second.second;
    centroids.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()),
                           static_cast<float>(c.z()));
  }
  expected = PointCloud::fromXyz(centroids);
  const auto got = sorted(*filter->out.filtered), want = sorted(expected);
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_LT((got[i] - want[i]).norm(), 1e-5f);
}

TYPED_TEST(PointCloudFilteringTest, OutliersFarFromANoisyPlaneAreRemoved) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::normal_distribution<float> noise(0.0f, 0.005f);
  std::vector<Point4f> points;
  for (int i = 0; i < 4000; ++i) points.emplace_back(u(rng), u(rng), noise(rng));
  for (int i = 0; i < 40; ++i)  // stray points, 0.3 to 0.8 m off the plane
    points.emplace_back(u(rng), u(rng), 0.3f + 0.5f * std::abs(u(rng)));
  PointCloud cloud;
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  auto filter = this->make("{outlier_neighbours: 8, outlier_std_ratio: 1.0}");
  filter->in.cloud.set(cloud);
  ASSERT_OK(filter->process());
  std::size_t plane = 0, stray = 0;
  for (const Point4f& p : filter->out.filtered->points) (std::abs(p.z) < 0.05f ? plane : stray)++;
  EXPECT_EQ(stray, 0u);
  EXPECT_GT(plane, 3800u);
}

TYPED_TEST(PointCloudFilteringTest, NonFinitePointsAreDroppedAndAnEmptyResultIsAWarning) {
  auto filter = this->make("{}");
  std::vector<Point4f> points{
      {0, 0, 1}, {std::nanf(""), 0, 0}, {1, 2, 3}, {0, std::numeric_limits<float>::infinity(), 0}};
  PointCloud cloud;
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  filter->in.cloud.set(cloud);
  ASSERT_OK(filter->process());
  ASSERT_EQ(filter->out.filtered->size(), 2u);
  EXPECT_OK(filter->out.filtered->validate());
  EXPECT_DOUBLE_EQ(*filter->out.kept_fraction, 0.5);

  auto crop = this->make("{crop_box: true, crop_min: [5, 5, 5], crop_max: [6, 6, 6]}");
  crop->in.cloud.set(cloud);
  ASSERT_OK(crop->process());
  EXPECT_TRUE(crop->out.filtered->empty());
  EXPECT_EQ(*crop->out.kept_fraction, 0.0);
  EXPECT_EQ(crop->diagnostics().warning_count, 1u);
}

TYPED_TEST(PointCloudFilteringTest, BadInputsAndParametersAreReported) {
  auto filter = this->make("{crop_box: true}");
  filter->in.cloud.set(PointCloud{});
  testing::expectRejected(*filter, "input 'cloud' has no points");

  PointCloud cloud = randomCloud(100, 1.0f, 4);
  filter->in.cloud.set(cloud);
  Transform wrong = Transform::identity("camera", "target");
  filter->in.box_pose.set(wrong);
  testing::expectRejected(*filter, "expected its parent frame to be the cloud's frame 'lidar'");
  Transform nan = Transform::identity("lidar", "target");
  nan.translation.x() = std::nan("");
  filter->in.box_pose.set(nan);
  testing::expectRejected(*filter, "box_pose");

  auto node = Registry::instance().create("PointCloudFiltering", TypeParam::name);
  ASSERT_TRUE(node.isOk());
  Status s = node.value()->configure(YAML::Load("{crop_min: [0, 0, 0], crop_max: [1, 0, 1]}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("crop_min"), std::string::npos) << s.message();
  s = node.value()->configure(YAML::Load("{voxel_size: -0.1}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  s = node.value()->configure(YAML::Load("{crop_min: [0, 0]}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
}

TEST(PointCloudFiltering, BothDfisKeepTheSamePointsThroughTheWholePipeline) {
  const std::string yaml =
      "{crop_box: true, crop_min: [-1.5, -1.5, -1.5], crop_max: [1.5, 1.5, 1.5], "
      "voxel_size: 0.1, outlier_neighbours: 6, outlier_std_ratio: 1.5}";
  auto fast = testing::makeDfn<PointCloudFiltering>("PointCloudFiltering", "Fast", yaml);
  auto pcl = testing::makeDfn<PointCloudFiltering>("PointCloudFiltering", "Pcl", yaml);
  const PointCloud cloud = randomCloud(30'000, 2.0f, 5);
  for (auto* f : {fast.get(), pcl.get()}) {
    f->in.cloud.set(cloud);
    ASSERT_OK(f->process());
  }
  const auto a = sorted(*fast->out.filtered), b = sorted(*pcl->out.filtered);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_LT((a[i] - b[i]).norm(), 1e-5f);
}

}  // namespace
}  // namespace cdff::dfn
