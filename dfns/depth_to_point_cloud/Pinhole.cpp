// DepthToPointCloud/Pinhole: the depth map's measured pixels back-projected through its camera
// model (cdff::pointsOfDepth), then kept within the stated ranges.
#include <limits>
#include <utility>
#include <vector>

#include "DepthToPointCloud.gen.hpp"
#include "cdff/types/depth_metres.hpp"

namespace cdff::dfn {

class DepthToPointCloudPinhole final : public DepthToPointCloudPinholeBase {
 protected:
  Status onConfigure() override {
    if (params_.max_range > 0 && params_.max_range <= params_.min_range)
      return invalidParameter(
          "max_range is {} m and min_range {} m; expected max_range above min_range (or 0: no "
          "limit)",
          params_.max_range, params_.min_range);
    return Status::ok();
  }

  Status onProcess() override {
    Result<PointCloud> points = pointsOfDepth(*in.depth, params_.stride);
    if (!points) return points.status().withContext("input 'depth'");
    if (params_.min_range <= 0 && params_.max_range <= 0) {
      out.cloud.set(std::move(points).value());
      return Status::ok();
    }
    const auto near = static_cast<float>(params_.min_range);
    const float far = params_.max_range > 0 ? static_cast<float>(params_.max_range)
                                            : std::numeric_limits<float>::infinity();
    std::vector<Eigen::Vector3f> kept;
    kept.reserve(points->points.size());
    for (const Point4f& p : points->points) {
      const float range = p.vec().norm();
      if (range >= near && range <= far) kept.push_back(p.vec());
    }
    out.cloud.set(PointCloud::fromXyz(kept, points->frame_id, points->stamp));
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(DepthToPointCloudPinhole);

}  // namespace cdff::dfn
