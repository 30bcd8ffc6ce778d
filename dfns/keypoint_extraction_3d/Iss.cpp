// KeypointExtraction3D/Iss: PCL's ISSKeypoint3D. PCL 1.13 has no precompiled instantiation of
// it (pcl/keypoints/iss_3d.h always includes its implementation), so this is the one slow
// translation unit of the area.
#include <cstdint>
#include <exception>
#include <vector>

#include <pcl/exceptions.h>
#include <pcl/keypoints/iss_3d.h>
#include <pcl/search/kdtree.h>
#include <Eigen/Eigenvalues>

#include "KeypointExtraction3D.gen.hpp"
#include "cdff/types/pcl.hpp"
#include "keypoints_common.hpp"

namespace cdff::dfn {

class KeypointExtraction3DIss final : public KeypointExtraction3DIssBase {
 public:
  /// The default radii (the rules are in the description of salient_radius and non_max_radius).
  static constexpr double kSalientInSpacings = 4.0;
  static constexpr double kNonMaxInSalient = 2.0 / 3.0;

 protected:
  Status onProcess() override {
    const PointCloud& cloud = *in.cloud;
    CDFF_RETURN_IF_ERROR(cloud.validate("input 'cloud'"));
    const keypoints::Extent extent = keypoints::extentOf(cloud);
    if (extent.diagonal() == 0) return noKeypoint(cloud, "its points all coincide");
    if (params_.salient_radius > 0)
      CDFF_RETURN_IF_ERROR(
          keypoints::checkRadiusAgainstExtent("salient_radius", params_.salient_radius, extent));
    if (params_.non_max_radius > 0)
      CDFF_RETURN_IF_ERROR(
          keypoints::checkRadiusAgainstExtent("non_max_radius", params_.non_max_radius, extent));
    if (cloud.size() < static_cast<std::size_t>(params_.min_neighbors))
      return noKeypoint(
          cloud, fmt::format("it has fewer points than min_neighbors = {}", params_.min_neighbors));
    double salient_radius = params_.salient_radius;
    if (salient_radius == 0) {
      const double spacing = pointSpacing(cloud);
      if (spacing == 0)
        return noKeypoint(cloud,
                          "it has too few distinct points to derive the point spacing from "
                          "(salient_radius = 0)");
      salient_radius = kSalientInSpacings * spacing;
    }
    const double non_max_radius =
        params_.non_max_radius > 0 ? params_.non_max_radius : kNonMaxInSalient * salient_radius;

    Result<std::vector<std::uint32_t>> found = detect(cloud, salient_radius, non_max_radius);
    if (!found) return found.status();
    if (found->empty())
      warn(
          fmt::format("input 'cloud' ({} points) gave no keypoint with salient_radius {:.4g} m, "
                      "non_max_radius {:.4g} m and min_saliency {}",
                      cloud.size(), salient_radius, non_max_radius, params_.min_saliency));
    out.keypoints.set(keypoints::keypointsAt(cloud, std::move(found).value()));
    return Status::ok();
  }

 private:
  Status noKeypoint(const PointCloud& cloud, const std::string& why) {
    warn(fmt::format("input 'cloud' ({} points) gives no keypoint: {}", cloud.size(), why));
    out.keypoints.set(keypoints::noKeypoints(cloud));
    return Status::ok();
  }

  /// Indices of the keypoints (PCL's ISS keypoints are copies of input points, and it keeps
  /// their indices), less those below min_saliency.
  Result<std::vector<std::uint32_t>> detect(const PointCloud& cloud, double salient_radius,
                                            double non_max_radius) const {
    try {
      const pcl::PointCloud<pcl::PointXYZ>::Ptr points = toPcl(cloud);
      auto search = std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();
      pcl::ISSKeypoint3D<pcl::PointXYZ, pcl::PointXYZ> iss;
      iss.setInputCloud(points);
      iss.setSearchMethod(search);
      iss.setSalientRadius(salient_radius);
      iss.setNonMaxRadius(non_max_radius);
      iss.setThreshold21(params_.gamma_21);
      iss.setThreshold32(params_.gamma_32);
      iss.setMinNeighbors(params_.min_neighbors);
      iss.setNumberOfThreads(1);  // reproducible (this file is not built with OpenMP anyway)
      pcl::PointCloud<pcl::PointXYZ> detected;
      iss.compute(detected);
      const pcl::PointIndicesConstPtr indices = iss.getKeypointsIndices();
      if (!indices || indices->indices.size() != detected.size())
        return Status(StatusCode::kInternal,
                      fmt::format("PCL's ISSKeypoint3D gave {} keypoints but {} indices",
                                  detected.size(), indices ? indices->indices.size() : 0));
      if (params_.min_saliency == 0)  // PCL's keypoints as they are
        return std::vector<std::uint32_t>(indices->indices.begin(), indices->indices.end());
      std::vector<std::uint32_t> salient;
      salient.reserve(indices->indices.size());
      pcl::Indices neighbours;
      std::vector<float> squared_distances;
      for (const int index : indices->indices) {
        // The scatter matrix about the point, as ISS computes it (the search tree is the one
        // ISS built over the cloud).
        search->radiusSearch(index, salient_radius, neighbours, squared_distances);
        const Eigen::Vector3d centre = (*points)[index].getVector3fMap().cast<double>();
        Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
        for (const int n : neighbours) {
          const Eigen::Vector3d d = (*points)[n].getVector3fMap().cast<double>() - centre;
          scatter += d * d.transpose();
        }
        const Eigen::Vector3d l =
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter, Eigen::EigenvaluesOnly)
                .eigenvalues();  // increasing
        if (l[2] > 0 && l[0] >= params_.min_saliency * l[2])
          salient.push_back(static_cast<std::uint32_t>(index));
      }
      return salient;
    } catch (const pcl::PCLException& e) {
      return Status(StatusCode::kInternal, fmt::format("PCL's ISSKeypoint3D failed: {}", e.what()));
    } catch (const std::exception& e) {
      return Status(StatusCode::kInternal, fmt::format("PCL's ISSKeypoint3D threw: {}", e.what()));
    }
  }
};

CDFF_REGISTER_DFI(KeypointExtraction3DIss);

}  // namespace cdff::dfn
