// PointCloudAssembly/Pcl: every fused point kept in the model frame, then PCL's VoxelGrid and
// StatisticalOutlierRemoval at each output. The only translation unit of this area that includes
// PCL's filters (slow to compile).
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>

#include "PointCloudAssembly.gen.hpp"
#include "assembly_common.hpp"
#include "cdff/types/pcl.hpp"

namespace cdff::dfn {

class PointCloudAssemblyPcl final : public PointCloudAssemblyPclBase {
 protected:
  Status onConfigure() override {
    clear();
    return Status::ok();
  }

  Status onProcess() override {
    const bool resetting = in.reset.isFresh() && *in.reset;
    const PointCloud& cloud = *in.cloud;
    const PoseWithCovariance& pose = *in.pose;
    CDFF_RETURN_IF_ERROR(assembly::checkInputs(cloud, pose, resetting ? std::string() : frame_,
                                               params_.max_pose_offset));
    // The points in the model frame, checked before the map is touched.
    const Eigen::Isometry3d model_T_s = pose.pose.isometry();
    const double inverse = 1.0 / params_.voxel_size;
    scratch_.clear();
    std::size_t skipped = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Point4f& p = cloud.points[i];
      if (!assembly::isFinite(p) || p.vec().squaredNorm() == 0) {
        ++skipped;
        continue;
      }
      const Eigen::Vector3d m = model_T_s * p.vec().cast<double>();
      if (!assembly::voxelKey(m, inverse))
        return invalidInput(
            "input 'cloud' point {} at ({:.3f}, {:.3f}, {:.3f}) m in the model frame is more "
            "than 2^20 voxels of {} m from its origin; expected a point on the target",
            i, m.x(), m.y(), m.z(), params_.voxel_size);
      scratch_.emplace_back(static_cast<float>(m.x()), static_cast<float>(m.y()),
                            static_cast<float>(m.z()));
    }
    if (resetting) clear();
    Eigen::Array3f lo = lo_, hi = hi_;
    for (const pcl::PointXYZ& p : scratch_) {
      lo = lo.min(p.getArray3fMap());
      hi = hi.max(p.getArray3fMap());
    }
    CDFF_RETURN_IF_ERROR(checkGrid(lo, hi));
    lo_ = lo;
    hi_ = hi;
    assembly::warnSkipped(cloud, skipped, [this](std::string m) { warn(std::move(m)); });
    if (!scratch_.empty()) {
      if (frame_.empty()) frame_ = pose.pose.parent_frame;
      for (const pcl::PointXYZ& p : scratch_) fused_->push_back(p);
      ++frames_;
    }

    assembly::Statistics stats;
    stats.frames = frames_;
    stats.points = fused_->size();
    stats.skipped_points = skipped;
    pcl::PointCloud<pcl::PointXYZ>::Ptr kept = voxelGrid();
    stats.supported_voxels = kept->size();
    stats.voxels = stats.supported_voxels;  // VoxelGrid does not count the others
    if (params_.outlier_neighbours > 0 && kept->size() > 1) {
      pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
      sor.setInputCloud(kept);
      sor.setMeanK(params_.outlier_neighbours);
      sor.setStddevMulThresh(params_.outlier_std_ratio);
      auto inliers = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
      sor.filter(*inliers);
      kept = inliers;
    }
    stats.outliers_removed = stats.supported_voxels - kept->size();
    PointCloud assembled = fromPcl(pcl::PointCloud<pcl::PointXYZ>::ConstPtr(kept));
    assembled.stamp = cloud.stamp;
    assembled.frame_id = frame_.empty() ? pose.pose.parent_frame : frame_;
    stats.output_points = assembled.size();
    out.assembled.set(std::move(assembled));
    out.statistics.set(stats.toJson());
    return Status::ok();
  }

 private:
  void clear() {
    fused_ = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    lo_ = Eigen::Array3f::Constant(std::numeric_limits<float>::max());
    hi_ = -lo_;
    frame_.clear();
    frames_ = 0;
  }

  /// PCL's VoxelGrid numbers voxels with 32-bit integers and returns its input unchanged (with a
  /// console message) when the grid would overflow them: that case is an error, found before
  /// the points that would cause it are fused.
  Status checkGrid(const Eigen::Array3f& lo, const Eigen::Array3f& hi) const {
    if (!(lo <= hi).all()) return Status::ok();  // nothing fused
    const Eigen::Array3d cells = ((hi - lo).cast<double>() / params_.voxel_size).floor() + 1.0;
    if (cells.prod() > static_cast<double>(std::numeric_limits<std::int32_t>::max()))
      return invalidInput(
          "the fused points span {:.1f} x {:.1f} x {:.1f} m: {:.3g} voxels of {} m, more than "
          "PCL's VoxelGrid can index (2^31); expected a larger voxel_size (or VoxelFusion)",
          hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], cells.prod(), params_.voxel_size);
    return Status::ok();
  }

  pcl::PointCloud<pcl::PointXYZ>::Ptr voxelGrid() const {
    auto out = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    if (fused_->empty()) return out;
    pcl::VoxelGrid<pcl::PointXYZ> grid;
    grid.setInputCloud(fused_);
    const float leaf = static_cast<float>(params_.voxel_size);
    grid.setLeafSize(leaf, leaf, leaf);
    grid.setMinimumPointsNumberPerVoxel(static_cast<unsigned int>(params_.min_observations));
    grid.filter(*out);
    return out;
  }

  pcl::PointCloud<pcl::PointXYZ>::Ptr fused_;  // every fused point, model frame
  Eigen::Array3f lo_, hi_;                     // their bounding box
  std::string frame_;
  std::uint64_t frames_ = 0;
  pcl::PointCloud<pcl::PointXYZ> scratch_;
};

CDFF_REGISTER_DFI(PointCloudAssemblyPcl);

}  // namespace cdff::dfn
