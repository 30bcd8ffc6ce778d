#include "cdff/types/point_cloud.hpp"

#include <cmath>

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
      return invalidInput("{} has {} points but {} {} values; expected one per point or none",
                          what, points.size(), n, field);
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

}  // namespace cdff
