#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "PointCloudFiltering.gen.hpp"
#include "cdff/types/kd_tree.hpp"
#include "filtering_common.hpp"

namespace cdff::dfn {

class PointCloudFilteringFast final : public PointCloudFilteringFastBase {
 protected:
  Status onConfigure() override { return filtering::checkParameters(params_); }

  Status onProcess() override {
    const PointCloud& cloud = *in.cloud;
    Result<Eigen::Isometry3f> box_T_cloud = filtering::checkInputs(cloud, in.box_pose.get());
    if (!box_T_cloud) return box_T_cloud.status();
    if (params_.crop_box)
      CDFF_RETURN_IF_ERROR(box_.update(params_, in.box_extent.shared(), in.box_uncertainty.get()));

    // Finite points inside the box.
    keep_.clear();
    keep_.reserve(cloud.size());
    const Eigen::Vector3f& lo = box_.min();
    const Eigen::Vector3f& hi = box_.max();
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Point4f& p = cloud.points[i];
      if (!filtering::isFinite(p)) continue;
      if (params_.crop_box) {
        const Eigen::Vector3f b = *box_T_cloud * p.vec();
        if ((b.array() < lo.array()).any() || (b.array() > hi.array()).any()) continue;
      }
      keep_.push_back(static_cast<std::uint32_t>(i));
    }
    PointCloud current;
    if (params_.voxel_size > 0) {
      Result<PointCloud> voxels = voxelGrid(cloud);
      if (!voxels) return voxels.status();
      current = std::move(voxels).value();
    } else {
      current = filtering::subset(cloud, keep_);
    }
    if (params_.outlier_neighbours > 0 && current.size() > 1) current = removeOutliers(current);
    filtering::publish(out, cloud, std::move(current),
                       [this](std::string m) { warn(std::move(m)); });
    return Status::ok();
  }

 private:
  /// Centroids of the voxels occupied by the kept points, in first-come order.
  Result<PointCloud> voxelGrid(const PointCloud& cloud) {
    // Single precision, as PCL's VoxelGrid computes the indices: both DFIs then agree on which
    // voxel a point on a boundary belongs to.
    const float inverse = 1.0f / static_cast<float>(params_.voxel_size);
    constexpr std::int64_t kHalf = std::int64_t{1} << 20;  // 21 bits per axis
    std::size_t capacity = std::bit_ceil(std::max<std::size_t>(16, 2 * keep_.size()));
    keys_.assign(capacity, kEmpty);
    slots_.resize(capacity);
    sums_.clear();
    counts_.clear();
    const std::uint64_t mask = capacity - 1;
    const int shift = 64 - std::countr_zero(capacity);  // the product's top bits hash best
    for (std::uint32_t i : keep_) {
      const Point4f& p = cloud.points[i];
      const std::int64_t ix = static_cast<std::int64_t>(std::floor(p.x * inverse));
      const std::int64_t iy = static_cast<std::int64_t>(std::floor(p.y * inverse));
      const std::int64_t iz = static_cast<std::int64_t>(std::floor(p.z * inverse));
      if (std::abs(ix) >= kHalf || std::abs(iy) >= kHalf || std::abs(iz) >= kHalf)
        return invalidInput(
            "input 'cloud' point {} ({}, {}, {}) is more than 2^20 voxels of {} m from the "
            "origin; expected a larger voxel_size or a cropped cloud",
            i, p.x, p.y, p.z, params_.voxel_size);
      const std::uint64_t key = (static_cast<std::uint64_t>(ix + kHalf) << 42) |
                                (static_cast<std::uint64_t>(iy + kHalf) << 21) |
                                static_cast<std::uint64_t>(iz + kHalf);
      std::uint64_t slot = (key * 0x9E3779B97F4A7C15ull) >> shift;
      while (keys_[slot] != kEmpty && keys_[slot] != key) slot = (slot + 1) & mask;
      if (keys_[slot] == kEmpty) {
        keys_[slot] = key;
        slots_[slot] = static_cast<std::uint32_t>(sums_.size());
        sums_.emplace_back(0.0, 0.0, 0.0);
        counts_.push_back(0);
      }
      const std::uint32_t v = slots_[slot];
      sums_[v] += Eigen::Vector3d(p.x, p.y, p.z);
      ++counts_[v];
    }
    std::vector<Point4f> centroids;
    centroids.reserve(sums_.size());
    for (std::size_t v = 0; v < sums_.size(); ++v) {
      const Eigen::Vector3d c = sums_[v] / static_cast<double>(counts_[v]);
      centroids.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()),
                             static_cast<float>(c.z()));
    }
    PointCloud out;
    out.stamp = cloud.stamp;
    out.frame_id = cloud.frame_id;
    out.points = Buffer<Point4f>::fromVector(std::move(centroids));
    return out;
  }

  /// Drops the points whose mean distance to their k nearest neighbours is unusually large.
  PointCloud removeOutliers(const PointCloud& cloud) {
    tree_.build(cloud.points.span());
    const int k = params_.outlier_neighbours;
    const double threshold = outlierDistanceThreshold(
        tree_, cloud.points.span(), k, params_.outlier_std_ratio, mean_distance_, neighbours_);
    keep_.clear();
    for (std::size_t i = 0; i < cloud.size(); ++i)
      if (mean_distance_[i] <= threshold) keep_.push_back(static_cast<std::uint32_t>(i));
    return filtering::subset(cloud, keep_);
  }

  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  filtering::CropBox box_;
  // Scratch kept between calls.
  std::vector<std::uint32_t> keep_;
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> slots_;
  std::vector<Eigen::Vector3d> sums_;
  std::vector<std::uint32_t> counts_;
  std::vector<double> mean_distance_;
  std::vector<KdTree3f::Neighbour> neighbours_;
  KdTree3f tree_;
};

CDFF_REGISTER_DFI(PointCloudFilteringFast);

}  // namespace cdff::dfn
