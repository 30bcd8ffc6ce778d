// FeaturesDescription3D/Shot: PCL's SHOT descriptor in BOARD local reference frames. PCL's
// feature headers are included here and in Fpfh.cpp only (slow to compile).
#include <pcl/features/board.h>
#include <pcl/features/shot.h>
#include <pcl/search/kdtree.h>

#include "FeaturesDescription3D.gen.hpp"
#include "description_common.hpp"
#include "description_pcl.hpp"

namespace cdff::dfn {

class FeaturesDescription3DShot final : public FeaturesDescription3DShotBase {
 public:
  /// SHOT's support radius is this many point spacings when not given: about 300 surface points
  /// (pi 10^2) for the statistics of its 352 bins.
  static constexpr double kRadiusPerSpacing = 10.0;
  static constexpr int kLength = 352;

 protected:
  Status onProcess() override {
    const Features3D& keypoints = *in.keypoints;
    CDFF_RETURN_IF_ERROR(description::checkKeypoints(keypoints));
    if (keypoints.size() == 0) {
      warn("input 'keypoints' is empty; no descriptor to compute");
      out.features.set(description::emptyFeatures(keypoints, kLength));
      return Status::ok();
    }
    Result<description::Support> support =
        description::prepare(keypoints, *in.surface, params_.radius, kRadiusPerSpacing);
    if (!support) return support.status();
    double lrf_radius = support->radius;
    if (params_.lrf_radius > 0) {
      CDFF_RETURN_IF_ERROR(
          description::checkRadius("lrf_radius", params_.lrf_radius, support->extent));
      lrf_radius = params_.lrf_radius;
    }
    std::vector<float> descriptors;
    CDFF_RETURN_IF_ERROR(description::guarded("PCL's SHOT estimation", [&]() -> Status {
      return describe(keypoints, *in.surface, support->radius, lrf_radius, descriptors);
    }));
    out.features.set(description::keepFinite(keypoints, *support, descriptors, kLength, "SHOT",
                                             [this](std::string m) { warn(std::move(m)); }));
    return Status::ok();
  }

 private:
  /// One row of kLength floats per keypoint (NaN where PCL found no frame or no support).
  static Status describe(const Features3D& keypoints, const PointCloud& surface, double radius,
                         double lrf_radius, std::vector<float>& descriptors) {
    const pcl::PointCloud<pcl::PointXYZ>::Ptr points = description::keypointsToPcl(keypoints);
    const pcl::PointCloud<pcl::PointXYZ>::Ptr surface_points = toPcl(surface);
    const pcl::PointCloud<pcl::Normal>::Ptr surface_normals = description::normalsToPcl(surface);
    // One KD-tree over the surface, shared by both estimators (each sets it to the surface).
    auto tree = std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();

    // BOARD: z from a plane fitted to the support, disambiguated by the normals; x from the
    // normal on the support's rim that deviates most from z. Repeatable under rotation.
    pcl::BOARDLocalReferenceFrameEstimation<pcl::PointXYZ, pcl::Normal, pcl::ReferenceFrame> board;
    board.setInputCloud(points);
    board.setSearchSurface(surface_points);
    board.setInputNormals(surface_normals);
    board.setSearchMethod(tree);
    board.setRadiusSearch(lrf_radius);
    board.setFindHoles(false);
    auto frames = std::make_shared<pcl::PointCloud<pcl::ReferenceFrame>>();
    board.compute(*frames);
    if (frames->size() != keypoints.size())
      return description::incomplete("PCL's BOARD frame estimation", frames->size(),
                                     keypoints.size());

    pcl::SHOTEstimation<pcl::PointXYZ, pcl::Normal, pcl::SHOT352, pcl::ReferenceFrame> shot;
    shot.setInputCloud(points);
    shot.setSearchSurface(surface_points);
    shot.setInputNormals(surface_normals);
    shot.setInputReferenceFrames(frames);
    shot.setSearchMethod(tree);
    shot.setRadiusSearch(radius);
    pcl::PointCloud<pcl::SHOT352> result;
    shot.compute(result);
    if (result.size() != keypoints.size())
      return description::incomplete("PCL's SHOT estimation", result.size(), keypoints.size());
    descriptors.resize(keypoints.size() * kLength);
    for (std::size_t i = 0; i < result.size(); ++i)
      std::copy_n(result[i].descriptor, kLength, descriptors.data() + i * kLength);
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(FeaturesDescription3DShot);

}  // namespace cdff::dfn
