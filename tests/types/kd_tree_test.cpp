// KdTree3f against brute force on random clouds: nearest, k nearest (in order) and radius
// queries must return exactly the brute-force answers; non-finite points are left out.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "cdff/types/kd_tree.hpp"

namespace cdff {
namespace {

std::vector<Point4f> randomPoints(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  std::vector<Point4f> points;
  for (std::size_t i = 0; i < n; ++i) points.emplace_back(u(rng), u(rng), 0.1f * u(rng));
  return points;  // a flat slab, like a surface: unbalanced extents exercise the axis choice
}

std::vector<KdTree3f::Neighbour> bruteForce(const std::vector<Point4f>& points,
                                            const Eigen::Vector3f& q) {
  std::vector<KdTree3f::Neighbour> all;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (std::isfinite(points[i].x))
      all.push_back({static_cast<std::uint32_t>(i), (points[i].vec() - q).squaredNorm()});
  std::sort(all.begin(), all.end(),
            [](const auto& a, const auto& b) { return a.squared_distance < b.squared_distance; });
  return all;
}

TEST(KdTree3f, QueriesMatchBruteForce) {
  std::vector<Point4f> points = randomPoints(5000, 1);
  points[10].x = std::nanf("");
  points[20].z = std::numeric_limits<float>::infinity();
  const KdTree3f tree(points, 8);
  EXPECT_EQ(tree.size(), 4998u);
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-2.5f, 2.5f);
  std::vector<KdTree3f::Neighbour> found;
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3f q(u(rng), u(rng), 0.3f * u(rng));
    const auto truth = bruteForce(points, q);
    KdTree3f::Neighbour nn;
    ASSERT_TRUE(tree.nearest(q, 100.0f, nn));
    EXPECT_FLOAT_EQ(nn.squared_distance, truth[0].squared_distance);
    // Bounded: nothing when the nearest is farther than the bound.
    EXPECT_FALSE(tree.nearest(q, truth[0].squared_distance * 0.99f, nn));

    tree.kNearest(q, 7, found);
    ASSERT_EQ(found.size(), 7u);
    for (int k = 0; k < 7; ++k)
      EXPECT_FLOAT_EQ(found[k].squared_distance, truth[k].squared_distance);

    const float radius = 0.15f;
    tree.withinRadius(q, radius, found);
    const auto inside = std::count_if(truth.begin(), truth.end(), [&](const auto& n) {
      return n.squared_distance <= radius * radius;
    });
    EXPECT_EQ(static_cast<long>(found.size()), inside);
  }
}

TEST(KdTree3f, EmptyAndTinyTrees) {
  const KdTree3f empty(std::vector<Point4f>{});
  KdTree3f::Neighbour nn;
  EXPECT_FALSE(empty.nearest(Eigen::Vector3f::Zero(), 1e9f, nn));
  std::vector<KdTree3f::Neighbour> found;
  empty.kNearest(Eigen::Vector3f::Zero(), 3, found);
  EXPECT_TRUE(found.empty());

  const std::vector<Point4f> two{{0, 0, 0}, {1, 0, 0}};
  const KdTree3f tree(two);
  tree.kNearest(Eigen::Vector3f(0.9f, 0, 0), 5, found);
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0].index, 1u);
  EXPECT_EQ(found[1].index, 0u);
}

TEST(KdTree3f, NearestFacingSkipsPointsWhoseNormalFacesAway) {
  // Two parallel sheets 2 cm apart, like the faces of a thin panel: the top one faces +z, the
  // bottom one -z. A sensor above sees only the top; a query just above the bottom sheet must
  // get a top point although bottom points are nearer.
  std::vector<Point4f> points, normals;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) {
      points.emplace_back(0.01f * i, 0.01f * j, 0.0f);
      normals.emplace_back(0, 0, 1);
      points.emplace_back(0.01f * i, 0.01f * j, -0.02f);
      normals.emplace_back(0, 0, -1);
    }
  const KdTree3f tree(points, 4, normals);
  const Eigen::Vector3f q(0.1f, 0.1f, -0.015f), eye(0.1f, 0.1f, 5.0f);
  KdTree3f::Neighbour plain, facing;
  ASSERT_TRUE(tree.nearest(q, 1.0f, plain));
  EXPECT_EQ(points[plain.index].z, -0.02f);
  ASSERT_TRUE(tree.nearestFacing(q, eye, 1.0f, facing));
  EXPECT_EQ(points[facing.index].z, 0.0f);
  EXPECT_NEAR(facing.squared_distance, 0.015f * 0.015f, 1e-7f);
  // Seen from below, the bottom sheet is the visible one.
  ASSERT_TRUE(tree.nearestFacing(Eigen::Vector3f(0.1f, 0.1f, -0.004f), Eigen::Vector3f(0, 0, -5),
                                 1.0f, facing));
  EXPECT_EQ(points[facing.index].z, -0.02f);
  // Without normals at build there is nothing to face.
  const KdTree3f bare(points, 4);
  EXPECT_FALSE(bare.nearestFacing(q, eye, 1.0f, facing));
}

}  // namespace
}  // namespace cdff
