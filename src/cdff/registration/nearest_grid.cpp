#include "cdff/registration/nearest_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cdff::registration {

bool NearestGrid::build(const Buffer<Point4f>& points, double cell, double band,
                        std::size_t max_cells) {
  labels_.clear();
  opposite_.clear();
  if (points.empty() || !(cell > 0)) return false;
  Eigen::Vector3f lo = points[0].vec(), hi = lo;
  for (const Point4f& p : points) {
    lo = lo.cwiseMin(p.vec());
    hi = hi.cwiseMax(p.vec());
  }
  cell_ = static_cast<float>(cell);
  inverse_ = 1.0f / cell_;
  band_ = band;
  const float margin = static_cast<float>(band) + cell_;
  origin_ = lo - Eigen::Vector3f::Constant(margin);
  const Eigen::Vector3f extent = hi - lo + Eigen::Vector3f::Constant(2 * margin);
  for (int a = 0; a < 3; ++a) size_[a] = static_cast<int>(std::ceil(extent[a] * inverse_)) + 1;
  const double cells = static_cast<double>(size_[0]) * size_[1] * size_[2];
  if (cells > static_cast<double>(max_cells)) return false;
  labels_.assign(static_cast<std::size_t>(cells), kNone);
  std::vector<float> distance(labels_.size(), std::numeric_limits<float>::infinity());
  propagate(points, seed(points, distance), distance);
  return true;
}

std::vector<std::uint32_t> NearestGrid::seed(const Buffer<Point4f>& points,
                                             std::vector<float>& distance) {
  std::vector<std::uint32_t> queue;
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f p = points[i].vec();
    const Eigen::Vector3i c = cellOf(p);
    const std::size_t k = linear(c.x(), c.y(), c.z());
    const float d = (centre(c.x(), c.y(), c.z()) - p).squaredNorm();
    if (d < distance[k]) {
      if (labels_[k] == kNone) queue.push_back(static_cast<std::uint32_t>(k));
      distance[k] = d;
      labels_[k] = i;
    }
  }
  return queue;
}

// Wavefront, one layer of cells at a time: the cells of a layer offer their points to their
// unsettled neighbours (26-connected), which keep the nearest offer within the band and form the
// next layer. Every cell is settled once: a cell's point is the nearest to its centre among its
// neighbours' points (approximately the nearest of all, as in vector-propagation distance
// transforms).
void NearestGrid::propagate(const Buffer<Point4f>& points, std::vector<std::uint32_t> queue,
                            std::vector<float>& distance) {
  const float band2 = static_cast<float>(band_ * band_);
  std::vector<std::uint8_t> settled(labels_.size(), 0);
  for (std::uint32_t k : queue) settled[k] = 1;
  std::vector<std::uint32_t> next;
  while (!queue.empty()) {
    next.clear();
    for (const std::uint32_t k : queue) {
      const int z = static_cast<int>(k / (size_[0] * size_[1]));
      const int y = static_cast<int>(k / size_[0] % size_[1]);
      const int x = static_cast<int>(k % size_[0]);
      const Eigen::Vector3f p = points[labels_[k]].vec();
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int nx = x + dx, ny = y + dy, nz = z + dz;
            if (nx < 0 || ny < 0 || nz < 0 || nx >= size_[0] || ny >= size_[1] || nz >= size_[2])
              continue;
            const std::size_t m = linear(nx, ny, nz);
            if (settled[m]) continue;
            const float d = (centre(nx, ny, nz) - p).squaredNorm();
            if (d < distance[m] && d <= band2) {
              if (labels_[m] == kNone) next.push_back(static_cast<std::uint32_t>(m));
              distance[m] = d;
              labels_[m] = labels_[k];
            }
          }
    }
    for (std::uint32_t m : next) settled[m] = 1;
    queue.swap(next);
  }
}

std::size_t NearestGrid::cellAt(const Eigen::Vector3f& q) const {
  const Eigen::Vector3f f = (q - origin_) * inverse_;
  const int x = static_cast<int>(std::floor(f.x())), y = static_cast<int>(std::floor(f.y())),
            z = static_cast<int>(std::floor(f.z()));
  if (x < 0 || y < 0 || z < 0 || x >= size_[0] || y >= size_[1] || z >= size_[2]) return kOutside;
  return linear(x, y, z);
}

std::uint32_t NearestGrid::opposite(std::size_t cell, const KdTree3f& tree,
                                    const Buffer<Point4f>& normals) {
  const std::lock_guard<std::mutex> lock(opposite_mutex_);
  if (opposite_.size() != labels_.size()) opposite_.assign(labels_.size(), kUnknown);
  std::uint32_t& alt = opposite_[cell];
  if (alt != kUnknown) return alt;
  alt = kNone;
  const auto z = static_cast<int>(cell / (static_cast<std::size_t>(size_[0]) * size_[1]));
  const auto y = static_cast<int>(cell / size_[0] % size_[1]);
  const auto x = static_cast<int>(cell % size_[0]);
  const Eigen::Vector3f c = origin_ + cell_ * Eigen::Vector3f(x + 0.5f, y + 0.5f, z + 0.5f);
  // Facing a far point behind the label's normal = a normal opposing it.
  const Eigen::Vector3f eye = c - 1e4f * normals[labels_[cell]].vec();
  KdTree3f::Neighbour found;
  if (tree.nearestFacing(c, eye, static_cast<float>(band_ * band_), found)) alt = found.index;
  return alt;
}

Eigen::Vector3i NearestGrid::cellOf(const Eigen::Vector3f& p) const {
  const Eigen::Vector3f f = (p - origin_) * inverse_;
  return {std::clamp(static_cast<int>(std::floor(f.x())), 0, size_[0] - 1),
          std::clamp(static_cast<int>(std::floor(f.y())), 0, size_[1] - 1),
          std::clamp(static_cast<int>(std::floor(f.z())), 0, size_[2] - 1)};
}

}  // namespace cdff::registration
