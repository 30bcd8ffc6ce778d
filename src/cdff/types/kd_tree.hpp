#pragma once
// A static 3D KD-tree over a point cloud: nearest neighbour, k nearest and radius queries.
//
// Built once (O(n log n)) and queried many times, e.g. a target model that an ICP registers
// every scan against, or a scan whose neighbourhoods give normals. The tree keeps its own copy
// of the points, reordered so that each leaf's points are contiguous in memory; query results
// are indices into the cloud it was built from. Queries are const and may run concurrently.

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/point_cloud.hpp"

namespace cdff {

class KdTree3f {
 public:
  struct Neighbour {
    std::uint32_t index = 0;     // into the cloud the tree was built from
    float squared_distance = 0;  // m^2
  };

  KdTree3f() = default;
  /// Builds over `points`; points with a non-finite coordinate are left out of the tree.
  /// `normals` (empty, or one per point) enables nearestFacing().
  explicit KdTree3f(std::span<const Point4f> points, int leaf_size = 12,
                    std::span<const Point4f> normals = {}) {
    build(points, leaf_size, normals);
  }
  void build(std::span<const Point4f> points, int leaf_size = 12,
             std::span<const Point4f> normals = {});

  /// Points in the tree (the finite ones).
  std::size_t size() const { return points_.size(); }
  bool empty() const { return points_.empty(); }

  /// The nearest point closer than sqrt(max_squared_distance); false when there is none.
  bool nearest(const Eigen::Vector3f& query, float max_squared_distance, Neighbour& found) const;
  /// The nearest point closer than sqrt(max_squared_distance) whose normal faces `eye`
  /// (n . (eye - p) > 0): the nearest a sensor at `eye` can have seen. Needs normals at build.
  bool nearestFacing(const Eigen::Vector3f& query, const Eigen::Vector3f& eye,
                     float max_squared_distance, Neighbour& found) const;
  /// The k nearest points closer than sqrt(max_squared_distance), nearest first (fewer when the
  /// tree holds fewer). `found` is cleared first.
  void kNearest(const Eigen::Vector3f& query, int k, std::vector<Neighbour>& found,
                float max_squared_distance = std::numeric_limits<float>::infinity()) const;
  /// Every point within `radius`, in no particular order. `found` is cleared first.
  void withinRadius(const Eigen::Vector3f& query, float radius,
                    std::vector<Neighbour>& found) const;

 private:
  struct Node {
    // Inner node: split value and axis (0..2), children at `first` (left) and `second` (right).
    // Leaf: axis = 3, points [first, second) of points_.
    float split = 0;
    std::uint32_t axis = 3;
    std::uint32_t first = 0, second = 0;
  };

  template <bool kFacing>
  void searchNearest(const float* q, const float* eye, float& best,
                     std::uint32_t& best_index) const;
  void searchKNearest(std::uint32_t node, const float* q, std::size_t k, float limit,
                      std::vector<Neighbour>& heap) const;
  void searchRadius(std::uint32_t node, const float* q, float r2,
                    std::vector<Neighbour>& found) const;

  std::vector<Node> nodes_;
  std::vector<Eigen::Vector4f> points_;   // reordered, w unused
  std::vector<Eigen::Vector4f> normals_;  // reordered like points_, or empty
  std::vector<std::uint32_t> indices_;    // original index of points_[i]
};

/// Statistical outlier removal's measure (the rule of PCL's StatisticalOutlierRemoval): each
/// point's mean distance to its k nearest other points of `tree` (built on `points`), written to
/// `mean_distance`; returns mean + std_ratio * std of those distances, above which a point is an
/// outlier. `neighbours` is scratch space.
double outlierDistanceThreshold(const KdTree3f& tree, std::span<const Point4f> points, int k,
                                double std_ratio, std::vector<double>& mean_distance,
                                std::vector<KdTree3f::Neighbour>& neighbours);

}  // namespace cdff
