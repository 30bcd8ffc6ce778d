// The only translation unit of this area that includes PCL's features (slow to compile).
#include <pcl/features/normal_3d.h>
#include <pcl/search/kdtree.h>

#include "NormalsEstimation.gen.hpp"
#include "cdff/types/pcl.hpp"
#include "normals_common.hpp"

namespace cdff::dfn {

class NormalsEstimationPcl final : public NormalsEstimationPclBase {
 protected:
  Status onProcess() override {
    const PointCloud& cloud = *in.cloud;
    CDFF_RETURN_IF_ERROR(cloud.validate("input 'cloud'"));
    const pcl::PointCloud<pcl::PointXYZ>::Ptr input = toPcl(cloud);
    pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimator;
    estimator.setInputCloud(input);
    estimator.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    if (params_.radius > 0)
      estimator.setRadiusSearch(params_.radius);
    else
      estimator.setKSearch(params_.neighbours);
    estimator.setViewPoint(static_cast<float>(params_.viewpoint[0]),
                           static_cast<float>(params_.viewpoint[1]),
                           static_cast<float>(params_.viewpoint[2]));
    pcl::PointCloud<pcl::Normal> result;
    estimator.compute(result);
    const Eigen::Vector3f viewpoint(params_.viewpoint[0], params_.viewpoint[1],
                                    params_.viewpoint[2]);
    std::vector<std::uint32_t> keep;
    std::vector<Point4f> normals;
    keep.reserve(cloud.size());
    normals.reserve(cloud.size());
    for (std::size_t i = 0; i < result.size(); ++i) {
      Eigen::Vector3f n = result[i].getNormalVector3fMap();
      if (!normals::orient(n, cloud.points[i].vec(), viewpoint)) continue;
      keep.push_back(static_cast<std::uint32_t>(i));
      normals.emplace_back(n.x(), n.y(), n.z());
    }
    normals::publish(out, cloud, keep, std::move(normals),
                     [this](std::string m) { warn(std::move(m)); });
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(NormalsEstimationPcl);

}  // namespace cdff::dfn
