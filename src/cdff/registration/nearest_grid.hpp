#pragma once
// A nearest-point lookup grid over a model: a dense grid over the model's bounding box (plus a
// band) whose cells within `band` of the surface hold the model point nearest to their centre.
// It answers a nearest-neighbour query in constant time for the fine ICP iterations, where
// correspondences are short. The point returned is the nearest to the query's cell centre, at
// most half a cell diagonal from the query, so it lies on the same face as the true nearest
// except right at an edge: point-to-plane residuals on a face are then exact.

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/kd_tree.hpp"
#include "cdff/types/point_cloud.hpp"

namespace cdff::registration {

/// The grid's geometry. A cell of 0 means no grid (the KD-tree only).
struct NearestGridOptions {
  double cell = 0.02;  // m
  double band = 0.3;   // m, how far from the model surface the grid reaches
};

class NearestGrid {
 public:
  static constexpr std::uint32_t kNone = ~std::uint32_t{0};
  static constexpr std::size_t kOutside = ~std::size_t{0};
  /// The most cells a grid may have: 64 MB of labels.
  static constexpr std::size_t kMaxCells = std::size_t{1} << 24;

  bool empty() const { return labels_.empty(); }
  double band() const { return band_; }

  /// Builds the grid over `points` by a wavefront from the cells holding model points; false
  /// (and an empty grid) when it would exceed `max_cells`.
  bool build(const Buffer<Point4f>& points, double cell, double band, std::size_t max_cells);

  /// The cell holding `q`, or kOutside.
  std::size_t cellAt(const Eigen::Vector3f& q) const;
  /// The model point nearest to the cell's centre, or kNone outside the band.
  std::uint32_t label(std::size_t cell) const { return labels_[cell]; }

  /// The model point nearest to the cell's centre among those whose normal opposes its label's
  /// (the other side of a thin part), or kNone; found by `tree` at the first request and kept,
  /// since a tracked target keeps showing the same cells. Thread-safe: the grid is shared
  /// between registrations that may run in different threads.
  std::uint32_t opposite(std::size_t cell, const KdTree3f& tree, const Buffer<Point4f>& normals);

 private:
  /// The cells holding model points, each labelled with its point nearest to the cell's centre
  /// (`distance`: squared, per cell); returns them.
  std::vector<std::uint32_t> seed(const Buffer<Point4f>& points, std::vector<float>& distance);
  /// Spreads the seeds' labels through the band, one layer of cells at a time.
  void propagate(const Buffer<Point4f>& points, std::vector<std::uint32_t> queue,
                 std::vector<float>& distance);
  Eigen::Vector3f centre(int x, int y, int z) const {
    return origin_ + cell_ * Eigen::Vector3f(x + 0.5f, y + 0.5f, z + 0.5f);
  }
  Eigen::Vector3i cellOf(const Eigen::Vector3f& p) const;
  std::size_t linear(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * size_[1] + y) * size_[0] + x;
  }

  static constexpr std::uint32_t kUnknown = kNone - 1;
  std::vector<std::uint32_t> labels_;
  std::vector<std::uint32_t> opposite_;  // kUnknown until asked for
  std::mutex opposite_mutex_;
  Eigen::Vector3f origin_ = Eigen::Vector3f::Zero();
  float cell_ = 0, inverse_ = 0;
  double band_ = 0;
  int size_[3] = {0, 0, 0};
};

}  // namespace cdff::registration
