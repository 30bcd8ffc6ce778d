// KeypointExtraction3D/UniformSampling: PCL's UniformSampling filter (precompiled for
// pcl::PointXYZ in libpcl_filters; only its non-impl header is included).
#include <cstdint>
#include <exception>
#include <limits>
#include <vector>

#include <pcl/exceptions.h>
#include <pcl/filters/uniform_sampling.h>

#include "KeypointExtraction3D.gen.hpp"
#include "cdff/types/pcl.hpp"
#include "keypoints_common.hpp"

namespace cdff::dfn {

class KeypointExtraction3DUniformSampling final : public KeypointExtraction3DUniformSamplingBase {
 public:
  /// The default voxel edge in point spacings (the rule is in the description's `radius`).
  static constexpr double kVoxelInSpacings = 4.0;

 protected:
  Status onProcess() override {
    const PointCloud& cloud = *in.cloud;
    CDFF_RETURN_IF_ERROR(cloud.validate("input 'cloud'"));
    const keypoints::Extent extent = keypoints::extentOf(cloud);
    if (extent.diagonal() == 0) {
      warn(fmt::format("input 'cloud': its {} points all coincide; no keypoint", cloud.size()));
      out.keypoints.set(keypoints::noKeypoints(cloud));
      return Status::ok();
    }
    double voxel = params_.radius;
    if (voxel > 0) {
      CDFF_RETURN_IF_ERROR(keypoints::checkRadiusAgainstExtent("radius", voxel, extent));
    } else {
      const double spacing = pointSpacing(cloud);
      if (spacing == 0) {
        warn(fmt::format(
            "input 'cloud' has too few distinct points ({}) to derive the point spacing from "
            "(radius = 0); no keypoint",
            cloud.size()));
        out.keypoints.set(keypoints::noKeypoints(cloud));
        return Status::ok();
      }
      voxel = kVoxelInSpacings * spacing;
    }
    CDFF_RETURN_IF_ERROR(checkGridSize(extent, voxel));

    Result<std::vector<std::uint32_t>> kept = sample(cloud, voxel);
    if (!kept) return kept.status();
    out.keypoints.set(keypoints::keypointsAt(cloud, std::move(kept).value()));
    return Status::ok();
  }

 private:
  /// PCL's UniformSampling numbers voxels with a 32-bit int over the bounding box and does not
  /// check it: a grid of more than 2^31 cells would silently merge distant voxels.
  Status checkGridSize(const keypoints::Extent& extent, double voxel) const {
    const Eigen::Array3d cells = (extent.max.cast<double>().array() / voxel).floor() -
                                 (extent.min.cast<double>().array() / voxel).floor() + 1.0;
    if (cells.prod() <= static_cast<double>(std::numeric_limits<std::int32_t>::max()))
      return Status::ok();
    const Eigen::Vector3f size = extent.max - extent.min;
    return invalidParameter(
        "parameter 'radius' = {} m (voxel edge{}) gives {:.3g} voxels over input 'cloud' "
        "({:.3g} x {:.3g} x {:.3g} m), more than PCL's UniformSampling can index (2^31); "
        "expected a larger radius",
        voxel, params_.radius > 0 ? "" : ", derived from the point spacing", cells.prod(), size.x(),
        size.y(), size.z());
  }

  /// Indices of the points PCL keeps: one per occupied voxel, the closest to its centre. PCL
  /// returns copies of the points; which ones it kept is the complement of the removed indices
  /// (every input point is either kept or removed once), so that their normals can be kept.
  static Result<std::vector<std::uint32_t>> sample(const PointCloud& cloud, double voxel) {
    try {
      pcl::UniformSampling<pcl::PointXYZ> sampler(/*extract_removed_indices=*/true);
      sampler.setInputCloud(toPcl(cloud));
      sampler.setRadiusSearch(voxel);
      pcl::PointCloud<pcl::PointXYZ> sampled;
      sampler.filter(sampled);
      std::vector<bool> removed(cloud.size(), false);
      for (const int index : *sampler.getRemovedIndices())
        removed[static_cast<std::size_t>(index)] = true;
      std::vector<std::uint32_t> kept;
      kept.reserve(sampled.size());
      for (std::size_t i = 0; i < cloud.size(); ++i)
        if (!removed[i]) kept.push_back(static_cast<std::uint32_t>(i));
      if (kept.size() != sampled.size())
        return Status(
            StatusCode::kInternal,
            fmt::format("PCL's UniformSampling kept {} points but removed {} of {}; "
                        "expected every point kept or removed once",
                        sampled.size(), sampler.getRemovedIndices()->size(), cloud.size()));
      return kept;
    } catch (const pcl::PCLException& e) {
      return Status(StatusCode::kInternal,
                    fmt::format("PCL's UniformSampling failed: {}", e.what()));
    } catch (const std::exception& e) {
      return Status(StatusCode::kInternal,
                    fmt::format("PCL's UniformSampling threw: {}", e.what()));
    }
  }
};

CDFF_REGISTER_DFI(KeypointExtraction3DUniformSampling);

}  // namespace cdff::dfn
