#include "cdff/registration/crop.hpp"

#include <algorithm>

namespace cdff::registration {

void pointsWithin(const PointCloud& cloud, std::span<const Eigen::Vector3f> centres, float radius,
                  std::vector<Eigen::Vector3f>& inside, std::size_t stride) {
  const float r2 = radius * radius;
  inside.clear();
  for (std::size_t i = 0; i < cloud.points.size(); i += std::max<std::size_t>(stride, 1)) {
    const Eigen::Vector3f v = cloud.points[i].vec();
    if (std::any_of(centres.begin(), centres.end(),
                    [&](const Eigen::Vector3f& c) { return (v - c).squaredNorm() <= r2; }))
      inside.push_back(v);
  }
}

void thinEvenly(std::span<const Eigen::Vector3f> points, std::size_t most,
                std::vector<Eigen::Vector3f>& kept) {
  const std::size_t n = points.size();
  const std::size_t keep = std::min(n, most);
  kept.clear();
  for (std::size_t k = 0; k < keep; ++k) kept.push_back(points[k * n / keep]);
}

}  // namespace cdff::registration
