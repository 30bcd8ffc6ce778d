#pragma once
// Shared by the PointCloudFiltering DFIs: parameter and input checks, the crop box and its
// transform, and copying the kept points with all their fields.

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "PointCloudFiltering.gen.hpp"

namespace cdff::dfn::filtering {

template <typename Parameters>
Status checkParameters(const Parameters& p) {
  for (int i = 0; i < 3; ++i)
    if (!(p.crop_min[i] < p.crop_max[i]))
      return invalidParameter(
          "parameter 'crop_min'[{}] = {} is not below 'crop_max'[{}] = {}; expected a box "
          "with min < max on every axis",
          i, p.crop_min[i], i, p.crop_max[i]);
  return Status::ok();
}

/// Checks the cloud (finite coordinates not required) and returns box_T_cloud, the transform
/// that brings the cloud's points into the crop box's frame.
inline Result<Eigen::Isometry3f> checkInputs(const PointCloud& cloud, const Transform* box_pose) {
  CDFF_RETURN_IF_ERROR(cloud.validate("input 'cloud'", /*require_finite=*/false));
  if (box_pose == nullptr) return Eigen::Isometry3f::Identity();
  CDFF_RETURN_IF_ERROR(box_pose->validate().withContext("input 'box_pose'"));
  if (!box_pose->parent_frame.empty() && !cloud.frame_id.empty() &&
      box_pose->parent_frame != cloud.frame_id)
    return invalidInput(
        "input 'box_pose' is {}_T_{}; expected its parent frame to be the cloud's frame '{}'",
        box_pose->parent_frame, box_pose->child_frame, cloud.frame_id);
  return Eigen::Isometry3f(box_pose->isometry().inverse().cast<float>());
}

/// The crop box in its own frame: [crop_min, crop_max] or the bounding box of the extent's
/// points, grown by crop_margin and by crop_sigmas standard deviations of the box pose's
/// position and attitude (the latter times the box's radius). The extent's bounding box is
/// computed once per extent value.
class CropBox {
 public:
  template <typename Parameters>
  Status update(const Parameters& p, const std::shared_ptr<const PointCloud>& extent,
                const RigidBodyState* uncertainty) {
    if (extent != extent_) {
      CDFF_RETURN_IF_ERROR(extent ? boundsOf(*extent) : Status::ok());
      extent_ = extent;
    }
    Eigen::Vector3d lo(p.crop_min[0], p.crop_min[1], p.crop_min[2]);
    Eigen::Vector3d hi(p.crop_max[0], p.crop_max[1], p.crop_max[2]);
    if (extent_) {
      lo = extent_lo_;
      hi = extent_hi_;
    }
    double margin = p.crop_margin;
    if (uncertainty != nullptr) {
      const Eigen::Matrix3d position = uncertainty->covariance.topLeftCorner<3, 3>();
      const Eigen::Matrix3d attitude = uncertainty->covariance.block<3, 3>(3, 3);
      if (!position.allFinite() || !attitude.allFinite())
        return invalidInput(
            "input 'box_uncertainty' has a non-finite pose covariance; expected a finite "
            "covariance");
      const double radius = lo.cwiseAbs().cwiseMax(hi.cwiseAbs()).norm();
      margin += p.crop_sigmas * (std::sqrt(std::max(0.0, largestEigenvalue(position))) +
                                 std::sqrt(std::max(0.0, largestEigenvalue(attitude))) * radius);
    }
    lo_ = (lo.array() - margin).cast<float>();
    hi_ = (hi.array() + margin).cast<float>();
    return Status::ok();
  }
  const Eigen::Vector3f& min() const { return lo_; }
  const Eigen::Vector3f& max() const { return hi_; }

 private:
  static double largestEigenvalue(const Eigen::Matrix3d& m) {
    return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(0.5 * (m + m.transpose()),
                                                          Eigen::EigenvaluesOnly)
        .eigenvalues()
        .maxCoeff();
  }
  Status boundsOf(const PointCloud& extent) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (const Point4f& q : extent.points) {
      if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) continue;
      lo = lo.cwiseMin(Eigen::Vector3d(q.x, q.y, q.z));
      hi = hi.cwiseMax(Eigen::Vector3d(q.x, q.y, q.z));
    }
    if (!(lo.array() <= hi.array()).all())
      return invalidInput(
          "input 'box_extent' has no finite point ({} points); expected the points whose "
          "bounding box is the crop box",
          extent.size());
    extent_lo_ = lo;
    extent_hi_ = hi;
    return Status::ok();
  }

  std::shared_ptr<const PointCloud> extent_;
  Eigen::Vector3d extent_lo_, extent_hi_;
  Eigen::Vector3f lo_, hi_;
};

inline bool isFinite(const Point4f& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

template <typename T>
Buffer<T> gather(const Buffer<T>& values, const std::vector<std::uint32_t>& keep) {
  if (values.empty()) return {};
  std::vector<T> out;
  out.reserve(keep.size());
  for (std::uint32_t i : keep) out.push_back(values[i]);
  return Buffer<T>::fromVector(std::move(out));
}

/// The points of `cloud` at `keep` (in that order), with every optional field.
inline PointCloud subset(const PointCloud& cloud, const std::vector<std::uint32_t>& keep) {
  PointCloud out;
  out.stamp = cloud.stamp;
  out.frame_id = cloud.frame_id;
  if (keep.size() == cloud.size()) {
    out = cloud;  // nothing removed: share every buffer
    return out;
  }
  out.points = gather(cloud.points, keep);
  out.normals = gather(cloud.normals, keep);
  out.intensity = gather(cloud.intensity, keep);
  out.ring = gather(cloud.ring, keep);
  out.time_offset_us = gather(cloud.time_offset_us, keep);
  return out;
}

/// Sets both outputs, with a warning (through `warn`) when nothing is left.
template <typename Warn>
void publish(PointCloudFiltering::Outputs& out, const PointCloud& input, PointCloud filtered,
             Warn&& warn) {
  const double fraction =
      input.empty() ? 0.0
                    : static_cast<double>(filtered.size()) / static_cast<double>(input.size());
  if (filtered.empty())
    warn(fmt::format("no point of the {} in input 'cloud' (frame '{}') passed the filters",
                     input.size(), input.frame_id));
  out.filtered.set(std::move(filtered));
  out.kept_fraction.set(fraction);
}

}  // namespace cdff::dfn::filtering
