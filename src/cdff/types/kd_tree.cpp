#include "cdff/types/kd_tree.hpp"

#include <algorithm>
#include <cmath>

namespace cdff {

namespace {

struct Entry {
  Eigen::Vector4f p;
  std::uint32_t index;
};

inline bool facing(const Eigen::Vector4f& n, const Eigen::Vector4f& p, const float* eye) {
  return n.x() * (eye[0] - p.x()) + n.y() * (eye[1] - p.y()) + n.z() * (eye[2] - p.z()) > 0;
}

inline float squaredDistance(const Eigen::Vector4f& p, const float* q) {
  const float dx = p.x() - q[0], dy = p.y() - q[1], dz = p.z() - q[2];
  return dx * dx + dy * dy + dz * dz;
}

bool heapLess(const KdTree3f::Neighbour& a, const KdTree3f::Neighbour& b) {
  return a.squared_distance < b.squared_distance;
}

}  // namespace

void KdTree3f::build(std::span<const Point4f> points, int leaf_size,
                     std::span<const Point4f> normals) {
  nodes_.clear();
  points_.clear();
  normals_.clear();
  indices_.clear();
  const bool with_normals = !normals.empty() && normals.size() == points.size();
  std::vector<Entry> entries;
  entries.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point4f& p = points[i];
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      entries.push_back({Eigen::Vector4f(p.x, p.y, p.z, 0.0f), static_cast<std::uint32_t>(i)});
  }
  if (entries.empty()) return;
  leaf_size = std::max(1, leaf_size);
  nodes_.reserve(2 * entries.size() / static_cast<std::size_t>(leaf_size) + 1);

  // Recursive median split on the widest axis; the entries are partitioned in place, so that
  // every node's points are one contiguous range.
  struct Builder {
    std::vector<Entry>& e;
    std::vector<Node>& nodes;
    int leaf;
    std::uint32_t make(std::uint32_t begin, std::uint32_t end) {
      const auto id = static_cast<std::uint32_t>(nodes.size());
      nodes.emplace_back();
      if (end - begin <= static_cast<std::uint32_t>(leaf)) {
        nodes[id] = {0.0f, 3u, begin, end};
        return id;
      }
      Eigen::Vector4f lo = e[begin].p, hi = e[begin].p;
      for (std::uint32_t i = begin + 1; i < end; ++i) {
        lo = lo.cwiseMin(e[i].p);
        hi = hi.cwiseMax(e[i].p);
      }
      int axis = 0;
      const Eigen::Vector4f extent = hi - lo;
      if (extent[1] > extent[axis]) axis = 1;
      if (extent[2] > extent[axis]) axis = 2;
      const std::uint32_t mid = begin + (end - begin) / 2;
      std::nth_element(e.begin() + begin, e.begin() + mid, e.begin() + end,
                       [axis](const Entry& a, const Entry& b) { return a.p[axis] < b.p[axis]; });
      const float split = e[mid].p[axis];
      const std::uint32_t left = make(begin, mid);
      const std::uint32_t right = make(mid, end);
      nodes[id] = {split, static_cast<std::uint32_t>(axis), left, right};
      return id;
    }
  };
  Builder{entries, nodes_, leaf_size}.make(0, static_cast<std::uint32_t>(entries.size()));
  points_.reserve(entries.size());
  indices_.reserve(entries.size());
  for (const Entry& entry : entries) {
    points_.push_back(entry.p);
    indices_.push_back(entry.index);
    if (with_normals) {
      const Point4f& n = normals[entry.index];
      normals_.emplace_back(n.x, n.y, n.z, 0.0f);
    }
  }
}

// The searches carry a lower bound on the squared distance from the query to the current node's
// cell (`cell`), built from the per-axis offsets to the split planes crossed so far: a far child
// is visited only when its cell can still hold a closer point (the classic incremental bound).

template <bool kFacing>
void KdTree3f::searchNearest(const float* q, const float* eye, float& best,
                             std::uint32_t& best_index) const {
  float offsets[3] = {0, 0, 0};
  struct Rec {
    const KdTree3f& t;
    const float* q;
    const float* eye;
    float& best;
    std::uint32_t& best_index;
    float* off;
    void go(std::uint32_t id, float cell) {
      const Node& n = t.nodes_[id];
      if (n.axis == 3) {
        for (std::uint32_t i = n.first; i < n.second; ++i) {
          const float d = squaredDistance(t.points_[i], q);
          if (d < best && (!kFacing || facing(t.normals_[i], t.points_[i], eye))) {
            best = d;
            best_index = i;
          }
        }
        return;
      }
      const float diff = q[n.axis] - n.split;
      const std::uint32_t near = diff < 0 ? n.first : n.second;
      const std::uint32_t far = diff < 0 ? n.second : n.first;
      go(near, cell);
      const float old = off[n.axis];
      const float far_cell = cell - old * old + diff * diff;
      if (far_cell < best) {
        off[n.axis] = diff;
        go(far, far_cell);
        off[n.axis] = old;
      }
    }
  };
  Rec{*this, q, eye, best, best_index, offsets}.go(0, 0.0f);
}

bool KdTree3f::nearest(const Eigen::Vector3f& query, float max_squared_distance,
                       Neighbour& found) const {
  if (points_.empty()) return false;
  float best = max_squared_distance;
  std::uint32_t best_index = std::numeric_limits<std::uint32_t>::max();
  searchNearest<false>(query.data(), nullptr, best, best_index);
  if (best_index == std::numeric_limits<std::uint32_t>::max()) return false;
  found = {indices_[best_index], best};
  return true;
}

bool KdTree3f::nearestFacing(const Eigen::Vector3f& query, const Eigen::Vector3f& eye,
                             float max_squared_distance, Neighbour& found) const {
  if (points_.empty() || normals_.empty()) return false;
  float best = max_squared_distance;
  std::uint32_t best_index = std::numeric_limits<std::uint32_t>::max();
  searchNearest<true>(query.data(), eye.data(), best, best_index);
  if (best_index == std::numeric_limits<std::uint32_t>::max()) return false;
  found = {indices_[best_index], best};
  return true;
}

void KdTree3f::searchKNearest(std::uint32_t id, const float* q, std::size_t k, float limit,
                              std::vector<Neighbour>& heap) const {
  // The heap holds indices into points_ while searching; kNearest maps them back.
  float offsets[3] = {0, 0, 0};
  struct Rec {
    const KdTree3f& t;
    const float* q;
    std::size_t k;
    float limit;
    std::vector<Neighbour>& heap;
    float* off;
    float bound() const { return heap.size() < k ? limit : heap.front().squared_distance; }
    void go(std::uint32_t id, float cell) {
      const Node& n = t.nodes_[id];
      if (n.axis == 3) {
        for (std::uint32_t i = n.first; i < n.second; ++i) {
          const float d = squaredDistance(t.points_[i], q);
          if (d < bound()) {
            if (heap.size() == k) {
              std::pop_heap(heap.begin(), heap.end(), heapLess);
              heap.pop_back();
            }
            heap.push_back({i, d});
            std::push_heap(heap.begin(), heap.end(), heapLess);
          }
        }
        return;
      }
      const float diff = q[n.axis] - n.split;
      const std::uint32_t near = diff < 0 ? n.first : n.second;
      const std::uint32_t far = diff < 0 ? n.second : n.first;
      go(near, cell);
      const float old = off[n.axis];
      const float far_cell = cell - old * old + diff * diff;
      if (far_cell < bound()) {
        off[n.axis] = diff;
        go(far, far_cell);
        off[n.axis] = old;
      }
    }
  };
  Rec{*this, q, k, limit, heap, offsets}.go(id, 0.0f);
}

void KdTree3f::kNearest(const Eigen::Vector3f& query, int k, std::vector<Neighbour>& found,
                        float max_squared_distance) const {
  found.clear();
  if (points_.empty() || k <= 0) return;
  found.reserve(static_cast<std::size_t>(k));
  searchKNearest(0, query.data(), static_cast<std::size_t>(k), max_squared_distance, found);
  std::sort_heap(found.begin(), found.end(), heapLess);
  for (Neighbour& n : found) n.index = indices_[n.index];
}

void KdTree3f::searchRadius(std::uint32_t id, const float* q, float r2,
                            std::vector<Neighbour>& found) const {
  float offsets[3] = {0, 0, 0};
  struct Rec {
    const KdTree3f& t;
    const float* q;
    float r2;
    std::vector<Neighbour>& found;
    float* off;
    void go(std::uint32_t id, float cell) {
      const Node& n = t.nodes_[id];
      if (n.axis == 3) {
        for (std::uint32_t i = n.first; i < n.second; ++i) {
          const float d = squaredDistance(t.points_[i], q);
          if (d <= r2) found.push_back({t.indices_[i], d});
        }
        return;
      }
      const float diff = q[n.axis] - n.split;
      const std::uint32_t near = diff < 0 ? n.first : n.second;
      const std::uint32_t far = diff < 0 ? n.second : n.first;
      go(near, cell);
      const float old = off[n.axis];
      const float far_cell = cell - old * old + diff * diff;
      if (far_cell <= r2) {
        off[n.axis] = diff;
        go(far, far_cell);
        off[n.axis] = old;
      }
    }
  };
  Rec{*this, q, r2, found, offsets}.go(id, 0.0f);
}

void KdTree3f::withinRadius(const Eigen::Vector3f& query, float radius,
                            std::vector<Neighbour>& found) const {
  found.clear();
  if (points_.empty() || !(radius >= 0)) return;
  searchRadius(0, query.data(), radius * radius, found);
}

double outlierDistanceThreshold(const KdTree3f& tree, std::span<const Point4f> points, int k,
                                double std_ratio, std::vector<double>& mean_distance,
                                std::vector<KdTree3f::Neighbour>& neighbours) {
  mean_distance.resize(points.size());
  double sum = 0, sum2 = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    tree.kNearest(points[i].vec(), k + 1, neighbours);  // k + 1: the nearest is the point itself
    double d = 0;
    for (std::size_t j = 1; j < neighbours.size(); ++j)
      d += std::sqrt(static_cast<double>(neighbours[j].squared_distance));
    d /= static_cast<double>(std::max<std::size_t>(1, neighbours.size() - 1));
    mean_distance[i] = d;
    sum += d;
    sum2 += d * d;
  }
  const double n = static_cast<double>(points.size());
  const double mean = sum / n;
  const double std = std::sqrt(std::max(0.0, (sum2 - sum * sum / n) / std::max(1.0, n - 1)));
  return mean + std_ratio * std;
}

}  // namespace cdff
