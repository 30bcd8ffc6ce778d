#pragma once
// Shared by the FeaturesDescription3D DFIs: the inputs as PCL clouds of PCL's standard point
// types (whose feature estimators are precompiled in libpcl_features), and PCL's exceptions
// turned into a Status.

#include <exception>
#include <string>

#include <pcl/exceptions.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "cdff/types/features.hpp"
#include "cdff/types/pcl.hpp"

namespace cdff::dfn::description {

/// The keypoints' positions.
inline pcl::PointCloud<pcl::PointXYZ>::Ptr keypointsToPcl(const Features3D& keypoints) {
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(keypoints.size());
  for (const Keypoint3D& k : keypoints.keypoints)
    cloud->push_back(pcl::PointXYZ(k.position.x(), k.position.y(), k.position.z()));
  return cloud;
}

/// The surface's normals (the cloud has them: checked before).
inline pcl::PointCloud<pcl::Normal>::Ptr normalsToPcl(const PointCloud& surface) {
  auto normals = std::make_shared<pcl::PointCloud<pcl::Normal>>();
  normals->reserve(surface.size());
  for (const Point4f& n : surface.normals) normals->push_back(pcl::Normal(n.x, n.y, n.z));
  return normals;
}

/// Runs `compute` (PCL calls), turning an exception into an internal-error Status that names
/// `what` (PCL throws on states our checks should have ruled out, and on allocation failure).
template <typename Compute>
Status guarded(const char* what, Compute&& compute) {
  try {
    return compute();
  } catch (const pcl::PCLException& e) {
    return {StatusCode::kInternal, fmt::format("{} threw a PCL exception: {}", what, e.what())};
  } catch (const std::exception& e) {
    return {StatusCode::kInternal, fmt::format("{} threw: {}", what, e.what())};
  }
}

/// The error for a PCL estimator that returned fewer results than keypoints (it prints why).
inline Status incomplete(const char* what, std::size_t results, std::size_t keypoints) {
  return {StatusCode::kInternal,
          fmt::format("{} returned {} results for {} keypoints; expected one per keypoint (see "
                      "PCL's message above)",
                      what, results, keypoints)};
}

}  // namespace cdff::dfn::description
