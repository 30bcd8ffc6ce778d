#include "cdff/types/pcl.hpp"

#include <cstring>

namespace cdff {

static_assert(sizeof(pcl::PointXYZ) == sizeof(Point4f), "layouts must match for zero-copy views");

pcl::PointCloud<pcl::PointXYZ>::Ptr toPcl(const PointCloud& cloud) {
  auto out = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  out->resize(cloud.size());
  if (!cloud.empty())
    std::memcpy(static_cast<void*>(out->points.data()), cloud.points.data(),
                cloud.size() * sizeof(Point4f));
  out->width = static_cast<std::uint32_t>(cloud.size());
  out->height = 1;
  out->is_dense = false;
  out->header.frame_id = cloud.frame_id;
  out->header.stamp = static_cast<std::uint64_t>(cloud.stamp);  // PCL stamps are microseconds too
  return out;
}

Result<pcl::PointCloud<pcl::PointNormal>::Ptr> toPclWithNormals(const PointCloud& cloud) {
  if (!cloud.hasNormals() || cloud.normals.size() != cloud.size())
    return invalidInput("point cloud has {} points and {} normals; expected one normal per point",
                        cloud.size(), cloud.normals.size());
  auto out = std::make_shared<pcl::PointCloud<pcl::PointNormal>>();
  out->resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    auto& p = (*out)[i];
    p.x = cloud.points[i].x;
    p.y = cloud.points[i].y;
    p.z = cloud.points[i].z;
    p.normal_x = cloud.normals[i].x;
    p.normal_y = cloud.normals[i].y;
    p.normal_z = cloud.normals[i].z;
  }
  out->width = static_cast<std::uint32_t>(cloud.size());
  out->height = 1;
  out->header.frame_id = cloud.frame_id;
  out->header.stamp = static_cast<std::uint64_t>(cloud.stamp);
  return out;
}

PointCloud fromPcl(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud) {
  PointCloud out;
  out.frame_id = cloud->header.frame_id;
  out.stamp = static_cast<Timestamp>(cloud->header.stamp);
  out.points = Buffer<Point4f>::view(cloud, reinterpret_cast<const Point4f*>(cloud->points.data()),
                                     cloud->size());
  return out;
}

PointCloud fromPcl(const pcl::PointCloud<pcl::PointNormal>::ConstPtr& cloud) {
  // PointNormal interleaves xyz and normals: split into the two padded arrays (a copy).
  std::vector<Point4f> points(cloud->size());
  std::vector<Point4f> normals(cloud->size());
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    const auto& p = (*cloud)[i];
    points[i] = Point4f(p.x, p.y, p.z);
    normals[i] = Point4f(p.normal_x, p.normal_y, p.normal_z);
    normals[i].pad = 0.0f;
  }
  PointCloud out;
  out.frame_id = cloud->header.frame_id;
  out.stamp = static_cast<Timestamp>(cloud->header.stamp);
  out.points = Buffer<Point4f>::fromVector(std::move(points));
  out.normals = Buffer<Point4f>::fromVector(std::move(normals));
  return out;
}

}  // namespace cdff
