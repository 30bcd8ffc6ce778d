#include "grouping_common.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "cdff/types/point_spacing.hpp"

namespace cdff::dfn::grouping {
namespace {

/// A normal is accepted as unit when its norm is within this of 1: float normals from any
/// estimator are unit to ~1e-6, one never normalised is off by far more.
constexpr float kUnitNormTolerance = 1e-3f;
/// Refits of a cluster's pose to its inliers; the inlier set is stable after 2 or 3.
constexpr int kRefits = 5;

Status checkSurface(const PointCloud& cloud, const char* port, bool need_normals, const char* why) {
  const std::string what = fmt::format("input '{}'", port);
  CDFF_RETURN_IF_ERROR(cloud.validate(what.c_str()));
  if (!need_normals) return Status::ok();
  if (!cloud.hasNormals())
    return invalidInput(
        "input '{}' ({} points) has no normals; expected unit normals ({}; NormalsEstimation or "
        "ModelPointCloud gives them)",
        port, cloud.size(), why);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f n = cloud.normals[i].vec();
    const float norm = n.norm();
    if (!std::isfinite(norm) || std::abs(norm - 1.0f) > kUnitNormTolerance)
      return invalidInput("input '{}' normal {} is ({}, {}, {}); expected a finite unit vector",
                          port, i, n.x(), n.y(), n.z());
  }
  return Status::ok();
}

Status checkFrames(const Features3D& features, const char* features_port, const PointCloud& surface,
                   const char* surface_port) {
  if (features.frame_id.empty() || surface.frame_id.empty() ||
      features.frame_id == surface.frame_id)
    return Status::ok();
  return invalidInput(
      "input '{}' is in frame '{}' but input '{}' in frame '{}'; expected the keypoints in "
      "their surface's frame",
      features_port, features.frame_id, surface_port, surface.frame_id);
}

/// The rigid transform (no scale) that best maps the pairs' model keypoints onto their scene
/// keypoints in the least-squares sense (Umeyama's closed form).
Eigen::Isometry3d fit(const std::vector<Pair>& pairs, const std::vector<Eigen::Vector3f>& model,
                      const std::vector<Eigen::Vector3f>& scene) {
  Eigen::Matrix3Xd from(3, pairs.size()), to(3, pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    from.col(i) = model[pairs[i].model].cast<double>();
    to.col(i) = scene[pairs[i].scene].cast<double>();
  }
  Eigen::Isometry3d pose;
  pose.matrix() = Eigen::umeyama(from, to, false);
  return pose;
}

std::vector<Pair> within(const Eigen::Isometry3d& scene_T_model, const std::vector<Pair>& pairs,
                         const std::vector<Eigen::Vector3f>& model,
                         const std::vector<Eigen::Vector3f>& scene, double tolerance) {
  std::vector<Pair> inliers;
  for (const Pair& p : pairs) {
    const Eigen::Vector3d predicted = scene_T_model * model[p.model].cast<double>();
    if ((scene[p.scene].cast<double>() - predicted).norm() <= tolerance) inliers.push_back(p);
  }
  return inliers;
}

/// True when the model keypoints of `pairs` spread across their best-fit line by more than
/// `tolerance` (RMS): otherwise the rotation about that line is not fixed by them. The squared
/// RMS distance to the best-fit line is the scatter's trace less its largest eigenvalue, found
/// by power iteration (Eigen's symmetric eigensolver would triple this file's compile time).
bool spreadsOffALine(const std::vector<Pair>& pairs, const std::vector<Eigen::Vector3f>& model,
                     double tolerance) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Pair& p : pairs) mean += model[p.model].cast<double>();
  mean /= static_cast<double>(pairs.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Pair& p : pairs) {
    const Eigen::Vector3d d = model[p.model].cast<double>() - mean;
    scatter += d * d.transpose();
  }
  scatter /= static_cast<double>(pairs.size());
  // The Rayleigh quotient never exceeds the largest eigenvalue and converges to it; 50 steps
  // from a generic start reach it to 1e-6 unless the two largest are within a few percent, when
  // the points spread in a plane and pass anyway.
  Eigen::Vector3d axis(0.57, 0.59, 0.571);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d next = scatter * axis;
    if (next.norm() == 0) break;
    axis = next.normalized();
  }
  const double largest = axis.dot(scatter * axis);
  return std::sqrt(std::max(0.0, scatter.trace() - largest)) > tolerance;
}

std::vector<Pair> uniqueSorted(std::vector<Pair> pairs) {
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

std::optional<Hypothesis> verifyOne(const Cluster& cluster, const std::vector<Pair>& all,
                                    const std::vector<Eigen::Vector3f>& model,
                                    const std::vector<Eigen::Vector3f>& scene, double tolerance,
                                    int threshold) {
  const std::vector<Pair> pairs = uniqueSorted(cluster.pairs);
  if (pairs.size() < 3) return std::nullopt;
  // Two starts: the DFI's RANSAC pose (robust to the cluster's outliers, but identity when its
  // RANSAC failed) and the least-squares fit to the whole cluster (right when the cluster is
  // clean); the one more matches agree with is refitted to them. All matches, not only the
  // cluster's: a DFI's cluster may be a part of the instance's correct matches (votes split over
  // neighbouring bins, reference frames that disagree), and the pose fits best to all of them.
  Eigen::Isometry3d pose(cluster.scene_T_model.cast<double>());
  std::vector<Pair> inliers = within(pose, all, model, scene, tolerance);
  const Eigen::Isometry3d whole = fit(pairs, model, scene);
  std::vector<Pair> whole_inliers = within(whole, all, model, scene, tolerance);
  if (whole_inliers.size() > inliers.size()) {
    pose = whole;
    inliers = std::move(whole_inliers);
  }
  for (int i = 0; i < kRefits && inliers.size() >= 3; ++i) {
    pose = fit(inliers, model, scene);
    std::vector<Pair> refitted = within(pose, all, model, scene, tolerance);
    if (refitted == inliers) break;
    inliers = std::move(refitted);
  }
  if (static_cast<int>(inliers.size()) < threshold) return std::nullopt;
  if (!spreadsOffALine(inliers, model, tolerance)) return std::nullopt;
  return Hypothesis{fit(inliers, model, scene), std::move(inliers)};
}

std::size_t shared(const std::vector<Pair>& a, const std::vector<Pair>& b) {
  std::size_t count = 0;
  auto i = a.begin();
  auto j = b.begin();
  while (i != a.end() && j != b.end()) {
    if (*i < *j) {
      ++i;
    } else if (*j < *i) {
      ++j;
    } else {
      ++count;
      ++i;
      ++j;
    }
  }
  return count;
}

}  // namespace

Status checkInputs(const CorrespondenceGrouping::Inputs& in, bool need_normals, const char* why) {
  const Features3D& scene_features = *in.scene_features;
  const Features3D& model_features = *in.model_features;
  CDFF_RETURN_IF_ERROR(scene_features.validate("input 'scene_features'"));
  CDFF_RETURN_IF_ERROR(model_features.validate("input 'model_features'"));
  CDFF_RETURN_IF_ERROR(checkSurface(*in.scene, "scene", need_normals, why));
  CDFF_RETURN_IF_ERROR(checkSurface(*in.model, "model", need_normals, why));
  CDFF_RETURN_IF_ERROR(checkFrames(scene_features, "scene_features", *in.scene, "scene"));
  CDFF_RETURN_IF_ERROR(checkFrames(model_features, "model_features", *in.model, "model"));
  const std::vector<Match>& matches = in.matches->matches;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    const Match& m = matches[i];
    const bool scene_ok = m.query >= 0 && static_cast<std::size_t>(m.query) < scene_features.size();
    const bool model_ok = m.train >= 0 && static_cast<std::size_t>(m.train) < model_features.size();
    if (!scene_ok || !model_ok)
      return invalidInput(
          "input 'matches' match {} pairs scene feature {} (query) with model feature {} "
          "(train); expected indices below the {} of 'scene_features' and the {} of "
          "'model_features'",
          i, m.query, m.train, scene_features.size(), model_features.size());
  }
  return Status::ok();
}

void ModelScale::update(const PointCloud& model) {
  if (!points_.empty() && model.points.sharesMemoryWith(points_)) return;
  const auto xyz = model.xyzMatrix();
  extent = static_cast<double>((xyz.rowwise().maxCoeff() - xyz.rowwise().minCoeff()).norm());
  spacing = pointSpacing(model);
  points_ = model.points;
}

Scale scaleOf(const PointCloud& scene, const ModelScale& model) {
  Scale scale;
  scale.model_extent = model.extent;
  scale.spacing = std::max(pointSpacing(scene), model.spacing);
  return scale;
}

Result<double> sizeParameter(const char* name, double given, double derived, const Scale& scale) {
  if (given > 0) {
    if (given > scale.model_extent)
      return invalidParameter(
          "parameter '{}' = {} m is larger than the extent of input 'model' (bounding-box "
          "diagonal {:.4g} m); expected a size at most that, or 0 to derive it from the point "
          "spacing",
          name, given, scale.model_extent);
    return given;
  }
  if (!(derived > 0))
    return invalidInput(
        "cannot derive parameter '{}': the surfaces' point spacing is {} m (their points "
        "coincide); expected surfaces with distinct points, or an explicit '{}'",
        name, scale.spacing, name);
  return derived;
}

std::vector<Pair> pairsOf(const Matches& matches) {
  std::vector<Pair> pairs;
  pairs.reserve(matches.size());
  for (const Match& m : matches.matches) pairs.push_back({m.train, m.query});
  return pairs;
}

std::vector<Eigen::Vector3f> positionsOf(const Features3D& features) {
  std::vector<Eigen::Vector3f> positions;
  positions.reserve(features.size());
  for (const Keypoint3D& k : features.keypoints) positions.push_back(k.position);
  return positions;
}

std::vector<Hypothesis> verify(const std::vector<Cluster>& clusters, const std::vector<Pair>& all,
                               const std::vector<Eigen::Vector3f>& model_keypoints,
                               const std::vector<Eigen::Vector3f>& scene_keypoints,
                               double tolerance, int threshold) {
  const std::vector<Pair> unique_pairs = uniqueSorted(all);
  std::vector<Hypothesis> candidates;
  for (const Cluster& cluster : clusters) {
    std::optional<Hypothesis> h =
        verifyOne(cluster, unique_pairs, model_keypoints, scene_keypoints, tolerance, threshold);
    if (h) candidates.push_back(std::move(*h));
  }
  std::stable_sort(
      candidates.begin(), candidates.end(),
      [](const Hypothesis& a, const Hypothesis& b) { return a.inliers.size() > b.inliers.size(); });
  // The same instance found twice (neighbouring Hough maxima, or two seeds of one consistent
  // set) would make the next stage verify one pose twice: a cluster sharing more than half its
  // pairs with a larger one is that larger one.
  std::vector<Hypothesis> kept;
  for (Hypothesis& h : candidates) {
    const bool duplicate = std::any_of(kept.begin(), kept.end(), [&](const Hypothesis& k) {
      return 2 * shared(h.inliers, k.inliers) > h.inliers.size();
    });
    if (!duplicate) kept.push_back(std::move(h));
  }
  return kept;
}

void publish(const std::vector<Hypothesis>& hypotheses, std::size_t match_count,
             const PointCloud& scene, const PointCloud& model,
             CorrespondenceGrouping::Outputs& out) {
  Detections detections;
  detections.stamp = scene.stamp;
  detections.frame_id = scene.frame_id;
  const std::string child = model.frame_id.empty() ? "model" : model.frame_id;
  for (std::size_t i = 0; i < hypotheses.size(); ++i) {
    const Hypothesis& h = hypotheses[i];
    Detection d;
    d.pose = Transform::fromIsometry(h.scene_T_model, scene.frame_id, child, scene.stamp);
    d.similarity = static_cast<double>(h.inliers.size()) / static_cast<double>(match_count);
    d.template_id = fmt::format("cluster {} ({} correspondences)", i, h.inliers.size());
    detections.detections.push_back(std::move(d));
  }
  out.clustered.set(hypotheses.empty() ? 0 : static_cast<int>(hypotheses.front().inliers.size()));
  out.hypotheses.set(std::move(detections));
}

}  // namespace cdff::dfn::grouping
