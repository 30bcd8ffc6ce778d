// The only translation unit of this area that includes PCL's filters (slow to compile).
#include <cmath>
#include <limits>

#include <pcl/filters/crop_box.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>

#include "PointCloudFiltering.gen.hpp"
#include "cdff/types/pcl.hpp"
#include "filtering_common.hpp"

namespace cdff::dfn {

class PointCloudFilteringPcl final : public PointCloudFilteringPclBase {
 protected:
  Status onConfigure() override { return filtering::checkParameters(params_); }

  Status onProcess() override {
    const PointCloud& cloud = *in.cloud;
    Result<Eigen::Isometry3f> box_T_cloud = filtering::checkInputs(cloud, in.box_pose.get());
    if (!box_T_cloud) return box_T_cloud.status();
    if (params_.crop_box)
      CDFF_RETURN_IF_ERROR(box_.update(params_, in.box_extent.shared(), in.box_uncertainty.get()));
    const pcl::PointCloud<pcl::PointXYZ>::Ptr pcl_cloud = toPcl(cloud);
    auto finite = std::make_shared<pcl::Indices>();
    finite->reserve(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i)
      if (filtering::isFinite(cloud.points[i])) finite->push_back(static_cast<int>(i));

    pcl::Indices kept = *finite;
    if (params_.crop_box) {
      pcl::CropBox<pcl::PointXYZ> crop;
      crop.setInputCloud(pcl_cloud);
      crop.setIndices(finite);
      crop.setMin(Eigen::Vector4f(box_.min().x(), box_.min().y(), box_.min().z(), 1));
      crop.setMax(Eigen::Vector4f(box_.max().x(), box_.max().y(), box_.max().z(), 1));
      crop.setTransform(Eigen::Affine3f(box_T_cloud->matrix()));  // applied to the points
      crop.filter(kept);
    }
    PointCloud current;
    if (params_.voxel_size > 0) {
      Result<pcl::PointCloud<pcl::PointXYZ>::Ptr> voxels = voxelGrid(pcl_cloud, kept);
      if (!voxels) return voxels.status();
      current = fromPcl(pcl::PointCloud<pcl::PointXYZ>::ConstPtr(voxels.value()));
      current.stamp = cloud.stamp;
      current.frame_id = cloud.frame_id;
    } else {
      current = filtering::subset(cloud, toKeep(kept));
    }
    if (params_.outlier_neighbours > 0 && current.size() > 1) {
      pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
      sor.setInputCloud(toPcl(current));
      sor.setMeanK(params_.outlier_neighbours);
      sor.setStddevMulThresh(params_.outlier_std_ratio);
      pcl::Indices inliers;
      sor.filter(inliers);
      current = filtering::subset(current, toKeep(inliers));
    }
    filtering::publish(out, cloud, std::move(current),
                       [this](std::string m) { warn(std::move(m)); });
    return Status::ok();
  }

 private:
  filtering::CropBox box_;

  static std::vector<std::uint32_t> toKeep(const pcl::Indices& indices) {
    return {indices.begin(), indices.end()};
  }

  Result<pcl::PointCloud<pcl::PointXYZ>::Ptr> voxelGrid(
      const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, const pcl::Indices& kept) const {
    auto out = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    if (kept.empty()) return out;
    // PCL's VoxelGrid numbers voxels with 32-bit integers and silently returns its input when
    // the grid would overflow them: report that case instead.
    Eigen::Array3f lo = Eigen::Array3f::Constant(std::numeric_limits<float>::max());
    Eigen::Array3f hi = -lo;
    for (int i : kept) {
      lo = lo.min((*cloud)[i].getArray3fMap());
      hi = hi.max((*cloud)[i].getArray3fMap());
    }
    const Eigen::Array3d cells = ((hi - lo).cast<double>() / params_.voxel_size).floor() + 1.0;
    if (cells.prod() > static_cast<double>(std::numeric_limits<std::int32_t>::max()))
      return invalidInput(
          "input 'cloud' spans {:.1f} x {:.1f} x {:.1f} m: {:.3g} voxels of {} m, more than "
          "PCL's VoxelGrid can index (2^31); expected a larger voxel_size or a crop box",
          hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], cells.prod(), params_.voxel_size);
    pcl::VoxelGrid<pcl::PointXYZ> grid;
    grid.setInputCloud(cloud);
    grid.setIndices(std::make_shared<pcl::Indices>(kept));
    const float leaf = static_cast<float>(params_.voxel_size);
    grid.setLeafSize(leaf, leaf, leaf);
    grid.filter(*out);
    return out;
  }
};

CDFF_REGISTER_DFI(PointCloudFilteringPcl);

}  // namespace cdff::dfn
