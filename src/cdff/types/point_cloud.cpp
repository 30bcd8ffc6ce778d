#include "cdff/types/point_cloud.hpp"

#include "cdff/types/cloud_extent.hpp"

#include <cmath>
#include <limits>

namespace cdff {

PointCloud PointCloud::fromXyz(const std::vector<Eigen::Vector3f>& xyz, std::string frame_id,
                               Timestamp stamp) {
  std::vector<Point4f> points;
  points.reserve(xyz.size());
  for (const auto& p : xyz) points.emplace_back(p.x(), p.y(), p.z());
  PointCloud cloud;
  cloud.stamp = stamp;
  cloud.frame_id = std::move(frame_id);
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  return cloud;
}

PointCloud::ConstMap3Xf PointCloud::xyzMatrix() const {
  return ConstMap3Xf(reinterpret_cast<const float*>(points.data()), 3,
                     static_cast<Eigen::Index>(points.size()), Eigen::OuterStride<4>(4));
}

Eigen::Map<const Eigen::Matrix4Xf, Eigen::Aligned16> PointCloud::homogeneousMatrix() const {
  return Eigen::Map<const Eigen::Matrix4Xf, Eigen::Aligned16>(
      reinterpret_cast<const float*>(points.data()), 4, static_cast<Eigen::Index>(points.size()));
}

Status PointCloud::validate(const char* what, bool require_finite) const {
  if (points.empty()) return invalidInput("{} has no points; expected at least one", what);
  auto check_size = [&](std::size_t n, const char* field) -> Status {
    if (n != 0 && n != points.size())
      return invalidInput("{} has {} points but {} {} values; expected one per point or none", what,
                          points.size(), n, field);
    return Status::ok();
  };
  CDFF_RETURN_IF_ERROR(check_size(normals.size(), "normal"));
  CDFF_RETURN_IF_ERROR(check_size(intensity.size(), "intensity"));
  CDFF_RETURN_IF_ERROR(check_size(ring.size(), "ring"));
  CDFF_RETURN_IF_ERROR(check_size(time_offset_us.size(), "time offset"));
  if (require_finite) {
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Point4f& p = points[i];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        return invalidInput("{} point {} is ({}, {}, {}); expected finite coordinates", what, i,
                            p.x, p.y, p.z);
    }
  }
  return Status::ok();
}

double boxDiagonal(const PointCloud& cloud) {
  Eigen::Vector3f low = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f high = -low;
  for (const Point4f& p : cloud.points) {
    if (!p.vec().allFinite()) continue;
    low = low.cwiseMin(p.vec());
    high = high.cwiseMax(p.vec());
  }
  return (high.array() >= low.array()).all() ? static_cast<double>((high - low).norm()) : 0.0;
}

Status checkModelScale(const PointCloud& scene, double model_diameter, const char* scene_port,
                       const char* model_port) {
  const double extent = boxDiagonal(scene);
  if (!(extent > 0) || model_diameter <= kMostModelToSceneExtent * extent) return Status::ok();
  return invalidInput(
      "input '{}' is {:.4g} m across but input '{}' spans {:.4g} m: the model is {:.0f} times "
      "the scene; expected both in metres and the scene to span at least 1/{:.0f} of the model "
      "(a model in millimetres against a scene in metres is 1000 times too large)",
      model_port, model_diameter, scene_port, extent, model_diameter / extent,
      kMostModelToSceneExtent);
}

}  // namespace cdff
