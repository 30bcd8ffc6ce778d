// The only translation unit of this area that includes PCL's Hough grouping and BOARD reference
// frames (both precompiled in libpcl_recognition / libpcl_features for pcl::PointXYZ).
#include <cmath>

#include <pcl/features/board.h>
#include <pcl/recognition/cg/hough_3d.h>

#include "grouping_pcl.hpp"

namespace cdff::dfn {
namespace {

/// The Hough grid PCL allocates spans the votes' bounding box; more bins than this (a double
/// each, 128 MiB) means a bin far smaller than the scene, a configuration mistake.
constexpr double kMaxHoughBins = 16.0 * 1024 * 1024;

/// Three correspondences fix a pose.
constexpr double kFewestVotes = 3;

using ReferenceFrames = pcl::PointCloud<pcl::ReferenceFrame>;

/// BOARD reference frames at `keypoints`, fitted to the points and normals of `surface` within
/// `radius`; a keypoint with too few surface points around it gets NaN axes.
ReferenceFrames::Ptr referenceFrames(const std::vector<Eigen::Vector3f>& keypoints,
                                     const PointCloud& surface, double radius) {
  auto points = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  auto normals = std::make_shared<pcl::PointCloud<pcl::Normal>>();
  points->reserve(surface.size());
  normals->reserve(surface.size());
  for (std::size_t i = 0; i < surface.size(); ++i) {
    const Point4f& p = surface.points[i];
    const Point4f& n = surface.normals[i];
    points->push_back({p.x, p.y, p.z});
    normals->push_back(pcl::Normal(n.x, n.y, n.z));
  }
  pcl::BOARDLocalReferenceFrameEstimation<pcl::PointXYZ, pcl::Normal, pcl::ReferenceFrame> board;
  board.setInputCloud(grouping::pclCloudOf(keypoints));
  board.setSearchSurface(points);
  board.setInputNormals(normals);
  board.setRadiusSearch(radius);
  // Keypoints at a surface's border (a panel's edge, the limit of a scan) see a half disc:
  // BOARD then takes the x axis from the border itself, which repeats between scene and model.
  board.setFindHoles(true);
  auto frames = std::make_shared<ReferenceFrames>();
  board.compute(*frames);
  return frames;
}

bool isFinite(const pcl::ReferenceFrame& frame) {
  for (const float v : frame.rf)
    if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace

class CorrespondenceGroupingHough3D final : public CorrespondenceGroupingHough3DBase {
 public:
  CorrespondenceGroupingHough3D() { grouping::quietPcl(); }

 protected:
  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(grouping::checkInputs(
        in, true, "Hough3D fits its BOARD local reference frames to the surfaces' normals"));
    const Matches& matches = *in.matches;
    const int threshold = params_.threshold;
    if (matches.size() < static_cast<std::size_t>(threshold)) {
      grouping::publish({}, matches.size(), *in.scene, *in.model, out);
      return Status::ok();
    }
    model_scale_.update(*in.model);
    const grouping::Scale scale = grouping::scaleOf(*in.scene, model_scale_);
    const Result<double> bin_size =
        grouping::sizeParameter("bin_size", params_.bin_size,
                                std::max(4.0 * scale.spacing, scale.model_extent / 30.0), scale);
    if (!bin_size) return bin_size.status();
    const Result<double> lrf_radius =
        grouping::sizeParameter("lrf_radius", params_.lrf_radius, 10.0 * scale.spacing, scale);
    if (!lrf_radius) return lrf_radius.status();
    const Result<double> inlier_distance = grouping::sizeParameter(
        "inlier_distance", params_.inlier_distance, 4.0 * scale.spacing, scale);
    if (!inlier_distance) return inlier_distance.status();
    const std::vector<Eigen::Vector3f> model_keypoints = grouping::positionsOf(*in.model_features);
    const std::vector<Eigen::Vector3f> scene_keypoints = grouping::positionsOf(*in.scene_features);

    std::vector<grouping::Cluster> clusters;
    CDFF_RETURN_IF_ERROR(grouping::catchingPcl("Hough grouping", [&]() -> Status {
      const ReferenceFrames::Ptr model_frames =
          modelFrames(model_keypoints, *in.model, *lrf_radius);
      const ReferenceFrames::Ptr scene_frames =
          referenceFrames(scene_keypoints, *in.scene, *lrf_radius);
      // A correspondence votes through both keypoints' frames: without one it cannot vote.
      std::vector<bool> usable(matches.size());
      std::size_t unusable = 0;
      for (std::size_t i = 0; i < matches.size(); ++i) {
        const Match& m = matches.matches[i];
        usable[i] = isFinite((*model_frames)[m.train]) && isFinite((*scene_frames)[m.query]);
        if (!usable[i]) ++unusable;
      }
      if (unusable > 0)
        warn(fmt::format(
            "{} of {} matches have a keypoint without a reference frame (fewer than BOARD "
            "needs within lrf_radius {:.4g} m) and do not vote",
            unusable, matches.size(), *lrf_radius));
      if (matches.size() - unusable < kFewestVotes) return Status::ok();
      CDFF_RETURN_IF_ERROR(
          checkGridSize(matches, usable, model_keypoints, scene_keypoints, *bin_size));

      pcl::Hough3DGrouping<pcl::PointXYZ, pcl::PointXYZ, pcl::ReferenceFrame, pcl::ReferenceFrame>
          hough;
      hough.setInputCloud(grouping::pclCloudOf(model_keypoints));
      hough.setInputRf(model_frames);
      hough.setSceneCloud(grouping::pclCloudOf(scene_keypoints));
      hough.setSceneRf(scene_frames);
      hough.setModelSceneCorrespondences(grouping::pclCorrespondencesOf(matches, usable));
      hough.setHoughBinSize(*bin_size);
      // Whole votes, one bin each: a bin's value is its number of voters, and every local maximum
      // of at least 3 (the fewest that fix a pose, and that PCL's RANSAC can sample) is a
      // candidate. A cluster split over neighbouring bins is not lost: verification gathers
      // every match that agrees with the pose of any of its parts.
      hough.setUseInterpolation(false);
      hough.setUseDistanceWeight(false);
      hough.setHoughThreshold(kFewestVotes);
      grouping::PclTransforms transforms;
      std::vector<pcl::Correspondences> grouped;
      hough.recognize(transforms, grouped);
      clusters = grouping::clustersOf(transforms, grouped);
      return Status::ok();
    }));
    grouping::publish(grouping::verify(clusters, grouping::pairsOf(matches), model_keypoints,
                                       scene_keypoints, *inlier_distance, threshold),
                      matches.size(), *in.scene, *in.model, out);
    return Status::ok();
  }

 private:
  /// The model keypoints' frames, fitted again only for other keypoints, another model cloud or
  /// another radius: the model comes once and is grouped against every scene.
  ReferenceFrames::Ptr modelFrames(const std::vector<Eigen::Vector3f>& keypoints,
                                   const PointCloud& model, double radius) {
    if (!model_frames_ || !model.points.sharesMemoryWith(frames_surface_) ||
        keypoints != frames_keypoints_ || radius != frames_radius_) {
      model_frames_ = referenceFrames(keypoints, model, radius);
      frames_surface_ = model.points;
      frames_keypoints_ = keypoints;
      frames_radius_ = radius;
    }
    return model_frames_;
  }

  grouping::ModelScale model_scale_;
  ReferenceFrames::Ptr model_frames_;
  Buffer<Point4f> frames_surface_;  // the model cloud they were fitted on (kept alive)
  std::vector<Eigen::Vector3f> frames_keypoints_;
  double frames_radius_ = 0;

  /// Ok when PCL's Hough grid for these votes holds at most kMaxHoughBins bins. A vote lies in
  /// the scene keypoints' bounding box grown by the model keypoints' largest distance to their
  /// centroid (the length of a vote), whatever the reference frames.
  static Status checkGridSize(const Matches& matches, const std::vector<bool>& usable,
                              const std::vector<Eigen::Vector3f>& model_keypoints,
                              const std::vector<Eigen::Vector3f>& scene_keypoints,
                              double bin_size) {
    Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
    for (const Eigen::Vector3f& p : model_keypoints) centroid += p;
    centroid /= static_cast<float>(model_keypoints.size());
    float reach = 0;
    for (const Eigen::Vector3f& p : model_keypoints) reach = std::max(reach, (p - centroid).norm());
    Eigen::Vector3f low = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
    Eigen::Vector3f high = -low;
    for (std::size_t i = 0; i < matches.size(); ++i) {
      if (!usable[i]) continue;
      low = low.cwiseMin(scene_keypoints[matches.matches[i].query]);
      high = high.cwiseMax(scene_keypoints[matches.matches[i].query]);
    }
    const Eigen::Vector3d span = (high - low).cast<double>().array() + 2.0 * reach;
    double bins = 1;
    for (int axis = 0; axis < 3; ++axis) bins *= std::ceil(span[axis] / bin_size) + 1;
    if (bins <= kMaxHoughBins) return Status::ok();
    const double smallest = std::cbrt(span.prod() / kMaxHoughBins);
    return invalidParameter(
        "parameter 'bin_size' = {:.4g} m gives a Hough grid of {:.3g} bins over the votes' "
        "{:.3g} x {:.3g} x {:.3g} m; expected at most {:.3g} bins: a bin_size of at least about "
        "{:.3g} m, or 0 to derive it",
        bin_size, bins, span.x(), span.y(), span.z(), kMaxHoughBins, smallest);
  }
};

CDFF_REGISTER_DFI(CorrespondenceGroupingHough3D);

}  // namespace cdff::dfn
