#include "registration_common.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace cdff::dfn::global_registration {
namespace {

/// A normal is accepted as unit when its norm is within this of 1: float normals from any
/// estimator are unit to ~1e-6, one never normalised is off by far more.
constexpr float kUnitNormTolerance = 1e-3f;
/// Samples of one voxel whose normals are within this angle (30 deg) are averaged into one
/// point (downsampleWithNormals).
const float kMergeNormalsCos = static_cast<float>(std::cos(30.0 * M_PI / 180.0));

/// The voxel of a point on a grid of `inverse_step` cells per metre, packed in 64 bits (21 bits
/// per axis: 2 million cells, more than any scene of a 25-step model spans).
std::uint64_t voxelKey(const Eigen::Vector3f& p, float inverse_step) {
  constexpr std::int64_t kOffset = 1 << 20;
  auto cell = [&](float v) {
    const auto c = static_cast<std::int64_t>(std::floor(v * inverse_step)) + kOffset;
    return static_cast<std::uint64_t>(std::clamp<std::int64_t>(c, 0, (1 << 21) - 1));
  };
  return (cell(p.x()) << 42) | (cell(p.y()) << 21) | cell(p.z());
}

}  // namespace

void VoxelRuns::build(const PointCloud& cloud, float step) {
  const float inverse_step = 1.0f / step;
  keyed.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    keyed[i] = {voxelKey(cloud.points[i].vec(), inverse_step), static_cast<std::uint32_t>(i)};
  std::sort(keyed.begin(), keyed.end());
  starts.clear();
  for (std::size_t i = 0; i < keyed.size(); ++i)
    if (i == 0 || keyed[i].first != keyed[i - 1].first)
      starts.push_back(static_cast<std::uint32_t>(i));
  starts.push_back(static_cast<std::uint32_t>(keyed.size()));
}

void downsampleWithNormals(const PointCloud& cloud, float step, VoxelRuns& runs,
                           std::vector<Oriented>& out) {
  struct Group {
    Eigen::Vector3f sum_p = Eigen::Vector3f::Zero();
    Eigen::Vector3f sum_n = Eigen::Vector3f::Zero();
    int count = 0;
  };
  runs.build(cloud, step);
  out.clear();
  std::vector<Group> groups;
  for (std::size_t r = 0; r + 1 < runs.starts.size(); ++r) {
    groups.clear();
    for (std::uint32_t k = runs.starts[r]; k < runs.starts[r + 1]; ++k) {
      const std::uint32_t i = runs.keyed[k].second;
      const Eigen::Vector3f p = cloud.points[i].vec();
      const Eigen::Vector3f n = cloud.normals[i].vec().normalized();
      Group* joined = nullptr;
      for (Group& g : groups)
        if (g.sum_n.normalized().dot(n) >= kMergeNormalsCos) {
          joined = &g;
          break;
        }
      if (joined == nullptr) joined = &groups.emplace_back();
      joined->sum_p += p;
      joined->sum_n += n;
      ++joined->count;
    }
    for (const Group& g : groups) {
      const float norm = g.sum_n.norm();
      if (norm < 1e-6f) continue;
      out.push_back({g.sum_p / static_cast<float>(g.count), g.sum_n / norm});
    }
  }
}

Status checkModel(const PointCloud& model) {
  CDFF_RETURN_IF_ERROR(model.validate("input 'model'"));
  if (!model.hasNormals())
    return invalidInput(
        "input 'model' ({} points) has no normals; expected unit outward normals "
        "(ModelPointCloud gives them)",
        model.size());
  for (std::size_t i = 0; i < model.size(); ++i) {
    const Eigen::Vector3f n = model.normals[i].vec();
    const float norm = n.norm();
    if (!std::isfinite(norm) || std::abs(norm - 1.0f) > kUnitNormTolerance)
      return invalidInput("input 'model' normal {} is ({}, {}, {}); expected a finite unit vector",
                          i, n.x(), n.y(), n.z());
  }
  if (extentOf(model).diameter() <= 0)
    return invalidInput(
        "input 'model' has its {} points at one place; expected a surface with an extent",
        model.size());
  return Status::ok();
}

Status checkScene(const PointCloud& scene) {
  CDFF_RETURN_IF_ERROR(scene.validate("input 'scene'"));
  for (std::size_t i = 0; i < scene.normals.size(); ++i) {
    const Eigen::Vector3f n = scene.normals[i].vec();
    const float norm = n.norm();
    if (!std::isfinite(norm) || norm < 1e-6f)
      return invalidInput(
          "input 'scene' normal {} is ({}, {}, {}); expected a finite non-zero vector (or no "
          "normals: they are then estimated)",
          i, n.x(), n.y(), n.z());
  }
  return Status::ok();
}

Status checkSampling(double sampling) {
  if (sampling > 0 && sampling < 1) return Status::ok();
  return invalidParameter(
      "parameter 'sampling' = {}; expected a fraction of the model's diameter strictly between "
      "0 and 1 (0.04: 25 steps across the model)",
      sampling);
}

Status checkDownsampledModel(std::size_t count, std::size_t fewest, const Sizes& sizes,
                             double sampling) {
  if (count >= fewest) return Status::ok();
  return invalidInput(
      "input 'model' has {} points after downsampling to {:.4g} m (parameter 'sampling' = {} of "
      "its {:.4g} m diameter); expected at least {}: lower 'sampling' or give a denser model",
      count, sizes.step, sampling, sizes.diameter, fewest);
}

ModelExtent extentOf(const PointCloud& cloud) {
  ModelExtent extent;
  if (cloud.empty()) return extent;
  extent.min = extent.max = cloud.points[0].vec();
  for (const Point4f& p : cloud.points) {
    extent.min = extent.min.cwiseMin(p.vec());
    extent.max = extent.max.cwiseMax(p.vec());
  }
  return extent;
}

Sizes sizesOf(double sampling, double cluster_distance, double normal_radius,
              const ModelExtent& extent) {
  Sizes s;
  s.diameter = extent.diameter();
  s.step = sampling * s.diameter;
  s.cluster_distance = cluster_distance > 0 ? cluster_distance : 0.1 * s.diameter;
  s.normal_radius = normal_radius > 0 ? normal_radius : 2.0 * s.step;
  return s;
}

void publish(std::vector<Cluster> clusters, int max_hypotheses, std::size_t scene_points,
             const PointCloud& scene, const PointCloud& model, GlobalRegistration3D::Outputs& out) {
  std::stable_sort(clusters.begin(), clusters.end(),
                   [](const Cluster& a, const Cluster& b) { return a.votes > b.votes; });
  if (clusters.size() > static_cast<std::size_t>(max_hypotheses))
    clusters.resize(static_cast<std::size_t>(max_hypotheses));
  Detections detections;
  detections.stamp = scene.stamp;
  detections.frame_id = scene.frame_id;
  const std::string child = model.frame_id.empty() ? "model" : model.frame_id;
  for (std::size_t rank = 0; rank < clusters.size(); ++rank) {
    const Cluster& c = clusters[rank];
    Eigen::Isometry3d pose = c.scene_T_model;
    pose.linear() = Eigen::Quaterniond(pose.linear()).normalized().toRotationMatrix();
    Detection d;
    d.pose = Transform::fromIsometry(pose, scene.frame_id, child, scene.stamp);
    d.pose.rotation.normalize();
    d.similarity =
        clusters.front().votes > 0 ? std::clamp(c.votes / clusters.front().votes, 0.0, 1.0) : 0.0;
    d.template_id = fmt::format("cluster {} ({:.0f} votes)", rank + 1, c.votes);
    detections.detections.push_back(std::move(d));
  }
  out.hypotheses.set(std::move(detections));
  out.scene_points.set(static_cast<int>(scene_points));
}

}  // namespace cdff::dfn::global_registration
