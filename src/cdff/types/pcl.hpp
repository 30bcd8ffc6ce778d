#pragma once
// Conversions between cdff::PointCloud and PCL. Kept in their own header and library because PCL
// headers are slow to compile: include this only where PCL is used.
//
// From PCL: zero-copy (the CDFF cloud keeps the pcl::PointCloud alive and views its points,
// whose layout is identical). To PCL: one memcpy, because a pcl::PointCloud always owns its
// std::vector and cannot view foreign memory.

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "cdff/types/point_cloud.hpp"

namespace cdff {

pcl::PointCloud<pcl::PointXYZ>::Ptr toPcl(const PointCloud& cloud);
/// Points and normals; fails when the cloud has no normals.
Result<pcl::PointCloud<pcl::PointNormal>::Ptr> toPclWithNormals(const PointCloud& cloud);

PointCloud fromPcl(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud);
PointCloud fromPcl(const pcl::PointCloud<pcl::PointNormal>::ConstPtr& cloud);

}  // namespace cdff
