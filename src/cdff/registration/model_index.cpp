#include "cdff/registration/model_index.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

#include "cdff/registration/median.hpp"

namespace cdff::registration {

bool ModelIndex::holds(const PointCloud& model) const {
  return !points.empty() && points.sharesMemoryWith(model.points) &&
         normals.sharesMemoryWith(model.normals) && points.size() == model.points.size();
}

Status ModelIndex::update(const PointCloud& model) {
  if (holds(model)) return Status::ok();
  CDFF_RETURN_IF_ERROR(model.validate("input 'model'"));
  if (!model.hasNormals())
    return invalidInput(
        "input 'model' ({} points, frame '{}') has no normals; expected one unit normal per "
        "point for the point-to-plane error (sample the model from a mesh with "
        "ModelPointCloud, or run NormalsEstimation on it)",
        model.size(), model.frame_id);
  for (std::size_t i = 0; i < model.normals.size(); ++i) {
    const Point4f& n = model.normals[i];
    const float norm = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (!std::isfinite(norm) || std::abs(norm - 1.0f) > 1e-2f)
      return invalidInput(
          "input 'model' normal {} is ({}, {}, {}) with norm {}; expected a finite unit vector", i,
          n.x, n.y, n.z, norm);
  }
  points = model.points;
  normals = model.normals;
  tree.build(model.points.span(), 12, model.normals.span());
  static std::atomic<std::uint64_t> generation{0};
  builds = ++generation;
  return Status::ok();
}

double modelSpacing(const ModelIndex& index) {
  std::vector<float> distances;
  std::vector<KdTree3f::Neighbour> found;
  const std::size_t n = index.points.size(), samples = std::min<std::size_t>(n, 201);
  for (std::size_t k = 0; k < samples; ++k) {
    index.tree.kNearest(index.points[k * n / samples].vec(), 2, found);
    if (found.size() == 2) distances.push_back(std::sqrt(found[1].squared_distance));
  }
  return distances.empty() ? 0.01 : median(distances);
}

ModelBounds modelBounds(const ModelIndex& index) {
  ModelBounds b{Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()),
                Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity())};
  for (const Point4f& p : index.points) {
    b.low = b.low.cwiseMin(p.vec().cast<double>());
    b.high = b.high.cwiseMax(p.vec().cast<double>());
  }
  return b;
}

Eigen::Vector3d modelCentroid(const ModelIndex& index) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Point4f& p : index.points) sum += p.vec().cast<double>();
  return sum / static_cast<double>(std::max<std::size_t>(1, index.points.size()));
}

}  // namespace cdff::registration
