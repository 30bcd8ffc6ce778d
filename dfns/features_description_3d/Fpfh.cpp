// FeaturesDescription3D/Fpfh: PCL's Fast Point Feature Histograms. PCL's feature headers are
// included here and in Shot.cpp only (slow to compile).
#include <pcl/features/fpfh.h>
#include <pcl/search/kdtree.h>

#include "FeaturesDescription3D.gen.hpp"
#include "description_common.hpp"
#include "description_pcl.hpp"

namespace cdff::dfn {

class FeaturesDescription3DFpfh final : public FeaturesDescription3DFpfhBase {
 public:
  /// FPFH's support radius is this many point spacings when not given: about five, the usual
  /// choice, and over twice the normals' own neighbourhood.
  static constexpr double kRadiusPerSpacing = 5.0;
  static constexpr int kLength = 33;

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
    std::vector<float> descriptors;
    CDFF_RETURN_IF_ERROR(description::guarded("PCL's FPFH estimation", [&]() -> Status {
      return describe(keypoints, *in.surface, support->radius, descriptors);
    }));
    out.features.set(description::keepFinite(keypoints, *support, descriptors, kLength, "FPFH",
                                             [this](std::string m) { warn(std::move(m)); }));
    return Status::ok();
  }

 private:
  /// One row of kLength floats per keypoint (NaN where the support is empty).
  static Status describe(const Features3D& keypoints, const PointCloud& surface, double radius,
                         std::vector<float>& descriptors) {
    // With a search surface other than the keypoints, PCL computes the simplified histogram
    // (SPFH) of every surface point in some keypoint's support, over its own support, then each
    // keypoint's FPFH as its SPFH plus its neighbours' weighted by inverse distance.
    pcl::FPFHEstimation<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> fpfh;
    fpfh.setInputCloud(description::keypointsToPcl(keypoints));
    fpfh.setSearchSurface(toPcl(surface));
    fpfh.setInputNormals(description::normalsToPcl(surface));
    fpfh.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    fpfh.setRadiusSearch(radius);
    pcl::PointCloud<pcl::FPFHSignature33> result;
    fpfh.compute(result);
    if (result.size() != keypoints.size())
      return description::incomplete("PCL's FPFH estimation", result.size(), keypoints.size());
    descriptors.resize(keypoints.size() * kLength);
    for (std::size_t i = 0; i < result.size(); ++i)
      std::copy_n(result[i].histogram, kLength, descriptors.data() + i * kLength);
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(FeaturesDescription3DFpfh);

}  // namespace cdff::dfn
