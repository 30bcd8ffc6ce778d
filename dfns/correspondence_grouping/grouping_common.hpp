#pragma once
// Shared by the CorrespondenceGrouping DFIs, without PCL (grouping_common.cpp, compiled once):
// the input checks, the sizes derived from the surfaces' point spacing, and the verification
// and publishing of the clusters a DFI found.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "CorrespondenceGrouping.gen.hpp"

namespace cdff::dfn::grouping {

/// A correspondence as the grouping sees it: a model keypoint and a scene keypoint.
struct Pair {
  int model = -1;
  int scene = -1;
  bool operator==(const Pair&) const = default;
  auto operator<=>(const Pair&) const = default;
};

/// What a DFI found: a pose (scene_T_model, from its RANSAC; any start is fine, it is refitted)
/// and the correspondences it grouped.
struct Cluster {
  Eigen::Matrix4f scene_T_model = Eigen::Matrix4f::Identity();
  std::vector<Pair> pairs;
};

/// Checks the five inputs: finite keypoints and surfaces, unit normals on the surfaces when
/// `need_normals` (`why` says who needs them), one frame per side, match indices in range.
Status checkInputs(const CorrespondenceGrouping::Inputs& in, bool need_normals, const char* why);

/// The scale of the inputs: the coarser of the two surfaces' point spacing s and the model's
/// extent (its bounding-box diagonal), m.
struct Scale {
  double spacing = 0;
  double model_extent = 0;
};
/// The model's part of a Scale, computed once per model cloud (its point buffer): a model
/// comes once and is grouped against every scene.
class ModelScale {
 public:
  /// The extent and point spacing of `model`, again only when it is another cloud.
  void update(const PointCloud& model);
  double extent = 0, spacing = 0;

 private:
  Buffer<Point4f> points_;  // the cloud they were computed for (kept alive: its address is unique)
};
Scale scaleOf(const PointCloud& scene, const ModelScale& model);

/// A size parameter: `given` when positive (an error when larger than the model's extent), else
/// `derived`.
Result<double> sizeParameter(const char* name, double given, double derived, const Scale& scale);

/// The matches as pairs (model = train, scene = query).
std::vector<Pair> pairsOf(const Matches& matches);

/// The keypoint positions of a feature set.
std::vector<Eigen::Vector3f> positionsOf(const Features3D& features);

/// A verified cluster: its pose fitted to all the correspondences within the tolerance of it.
struct Hypothesis {
  Eigen::Isometry3d scene_T_model = Eigen::Isometry3d::Identity();
  std::vector<Pair> inliers;
};

/// Verifies each cluster: its pose (the DFI's, or the least-squares fit to the cluster, whichever
/// more of `all` agree with) is refitted to the pairs of `all` within `tolerance` of it until
/// they no longer change; it needs at least `threshold` of them, not on a line. A cluster that
/// shares more than half its pairs with a larger one is dropped. The survivors, most pairs first.
std::vector<Hypothesis> verify(const std::vector<Cluster>& clusters, const std::vector<Pair>& all,
                               const std::vector<Eigen::Vector3f>& model_keypoints,
                               const std::vector<Eigen::Vector3f>& scene_keypoints,
                               double tolerance, int threshold);

/// Sets `hypotheses` and `clustered` from the verified clusters.
void publish(const std::vector<Hypothesis>& hypotheses, std::size_t match_count,
             const PointCloud& scene, const PointCloud& model,
             CorrespondenceGrouping::Outputs& out);

}  // namespace cdff::dfn::grouping
