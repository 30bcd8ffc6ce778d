#pragma once
// Shared by the CorrespondenceGrouping DFIs that call PCL: the keypoints and matches as PCL
// wants them, and PCL's clusters back as grouping::Cluster. Only PCL's light headers here; each
// DFI includes its own algorithm.

#include <exception>
#include <vector>

#include <pcl/console/print.h>
#include <pcl/correspondence.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "grouping_common.hpp"

namespace cdff::dfn::grouping {

inline pcl::PointCloud<pcl::PointXYZ>::Ptr pclCloudOf(const std::vector<Eigen::Vector3f>& points) {
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(points.size());
  for (const Eigen::Vector3f& p : points) cloud->push_back({p.x(), p.y(), p.z()});
  return cloud;
}

/// PCL's grouping takes the model as its input and the scene as its "scene": index_query is the
/// model keypoint (the match's train), index_match the scene keypoint (the match's query).
inline pcl::CorrespondencesPtr pclCorrespondencesOf(const Matches& matches,
                                                    const std::vector<bool>& usable = {}) {
  auto correspondences = std::make_shared<pcl::Correspondences>();
  correspondences->reserve(matches.size());
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (!usable.empty() && !usable[i]) continue;
    const Match& m = matches.matches[i];
    correspondences->emplace_back(m.train, m.query, m.distance);
  }
  return correspondences;
}

using PclTransforms = std::vector<Eigen::Matrix4f, Eigen::aligned_allocator<Eigen::Matrix4f>>;

inline std::vector<Cluster> clustersOf(const PclTransforms& scene_T_model,
                                       const std::vector<pcl::Correspondences>& grouped) {
  std::vector<Cluster> clusters;
  for (std::size_t c = 0; c < grouped.size() && c < scene_T_model.size(); ++c) {
    Cluster cluster;
    cluster.scene_T_model = scene_T_model[c];
    for (const pcl::Correspondence& corr : grouped[c])
      cluster.pairs.push_back({corr.index_query, corr.index_match});
    clusters.push_back(std::move(cluster));
  }
  return clusters;
}

/// PCL's RANSAC prints to stderr for each candidate cluster it cannot fit a pose to (too few or
/// degenerate points): an expected outcome here, which verification drops. As
/// Registration3D/PclIcpPointToPlane does, PCL's console is limited to what it always prints.
inline void quietPcl() {
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
}

/// PCL reports some failures by throwing (pcl::PCLException derives from std::runtime_error);
/// a DFI never lets an exception out.
template <typename Call>
Status catchingPcl(const char* what, Call&& call) {
  try {
    return call();
  } catch (const std::exception& e) {
    return numericalFailure("{} failed in PCL: {}", what, e.what());
  }
}

}  // namespace cdff::dfn::grouping
