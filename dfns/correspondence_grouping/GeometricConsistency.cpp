// The only translation unit of this area that includes PCL's geometric consistency grouping
// (precompiled in libpcl_recognition for pcl::PointXYZ).
#include <pcl/recognition/cg/geometric_consistency.h>

#include "grouping_pcl.hpp"

namespace cdff::dfn {

class CorrespondenceGroupingGeometricConsistency final
    : public CorrespondenceGroupingGeometricConsistencyBase {
 public:
  CorrespondenceGroupingGeometricConsistency() { grouping::quietPcl(); }

 protected:
  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(grouping::checkInputs(in, false, ""));
    const Matches& matches = *in.matches;
    const int threshold = params_.threshold;
    if (matches.size() < static_cast<std::size_t>(threshold)) {
      grouping::publish({}, matches.size(), *in.scene, *in.model, out);
      return Status::ok();
    }
    model_scale_.update(*in.model);
    const grouping::Scale scale = grouping::scaleOf(*in.scene, model_scale_);
    const Result<double> consensus_size = grouping::sizeParameter(
        "consensus_size", params_.consensus_size, 4.0 * scale.spacing, scale);
    if (!consensus_size) return consensus_size.status();
    const Result<double> inlier_distance = grouping::sizeParameter(
        "inlier_distance", params_.inlier_distance, 4.0 * scale.spacing, scale);
    if (!inlier_distance) return inlier_distance.status();
    const std::vector<Eigen::Vector3f> model_keypoints = grouping::positionsOf(*in.model_features);
    const std::vector<Eigen::Vector3f> scene_keypoints = grouping::positionsOf(*in.scene_features);

    std::vector<grouping::Cluster> clusters;
    CDFF_RETURN_IF_ERROR(grouping::catchingPcl("geometric consistency grouping", [&] {
      pcl::GeometricConsistencyGrouping<pcl::PointXYZ, pcl::PointXYZ> grouper;
      grouper.setInputCloud(grouping::pclCloudOf(model_keypoints));
      grouper.setSceneCloud(grouping::pclCloudOf(scene_keypoints));
      grouper.setModelSceneCorrespondences(grouping::pclCorrespondencesOf(matches));
      grouper.setGCSize(*consensus_size);
      // PCL keeps a consensus set larger than its threshold; ours counts the set itself.
      grouper.setGCThreshold(threshold - 1);
      grouping::PclTransforms transforms;
      std::vector<pcl::Correspondences> grouped;
      grouper.recognize(transforms, grouped);
      clusters = grouping::clustersOf(transforms, grouped);
      return Status::ok();
    }));
    grouping::publish(grouping::verify(clusters, grouping::pairsOf(matches), model_keypoints,
                                       scene_keypoints, *inlier_distance, threshold),
                      matches.size(), *in.scene, *in.model, out);
    return Status::ok();
  }

 private:
  grouping::ModelScale model_scale_;
};

CDFF_REGISTER_DFI(CorrespondenceGroupingGeometricConsistency);

}  // namespace cdff::dfn
