#include "cdff/types/point_spacing.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "cdff/types/kd_tree.hpp"

namespace cdff {

double pointSpacing(const PointCloud& cloud, std::size_t max_samples) {
  constexpr int kNeighbours = 8;
  if (cloud.empty()) return 0;
  const KdTree3f tree(cloud.points.span());
  const std::size_t step =
      std::max<std::size_t>(1, cloud.size() / std::max<std::size_t>(1, max_samples));
  std::vector<KdTree3f::Neighbour> found;
  std::vector<float> distances;
  distances.reserve(cloud.size() / step + 1);
  for (std::size_t i = 0; i < cloud.size(); i += step) {
    if (!cloud.points[i].vec().allFinite()) continue;
    tree.kNearest(cloud.points[i].vec(), kNeighbours + 1, found);  // the point itself first
    if (found.size() == kNeighbours + 1 && found.back().squared_distance > 0)
      distances.push_back(std::sqrt(found.back().squared_distance));
  }
  if (distances.empty()) return 0;
  auto middle = distances.begin() + static_cast<std::ptrdiff_t>(distances.size() / 2);
  std::nth_element(distances.begin(), middle, distances.end());
  return *middle * std::sqrt(M_PI / kNeighbours);
}

}  // namespace cdff
