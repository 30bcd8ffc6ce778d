#pragma once
// The checks and outputs both Triangulation DFIs share; they differ in how a pair becomes a
// point (Triangulator::triangulate).

#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "Triangulation.gen.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn::triangulation {

/// Two views in the first camera's frame: the second camera's rotation and centre.
struct Views {
  Eigen::Matrix3d first_R_second;
  Eigen::Vector3d first_c_second;
  std::vector<Eigen::Vector2d> first, second;  // normalised coordinates
  double f1 = 1, f2 = 1;                       // mean focal lengths, px
};

/// The reason a pair's point is refused, "ok" when it is kept.
inline const char* check(const Views& v, std::size_t i, const Eigen::Vector3d& p,
                         double max_reprojection_error, double min_parallax) {
  const Eigen::Vector3d in_second = v.first_R_second.transpose() * (p - v.first_c_second);
  if (!p.allFinite()) return "low_parallax";  // parallel rays: a point at infinity
  if (!(p.z() > 0) || !(in_second.z() > 0)) return "behind_camera";
  const Eigen::Vector3d ray1 = p, ray2 = p - v.first_c_second;
  if (std::atan2(ray1.cross(ray2).norm(), ray1.dot(ray2)) < min_parallax) return "low_parallax";
  const double e1 = v.f1 * (p.head<2>() / p.z() - v.first[i]).norm();
  const double e2 = v.f2 * (in_second.head<2>() / in_second.z() - v.second[i]).norm();
  if (e1 > max_reprojection_error || e2 > max_reprojection_error) return "reprojection_error";
  return "ok";
}

/// The views of the inputs: undistorted pixels, the pose checked.
inline Result<Views> views(const Correspondences2D& c, const CameraModel& first,
                           const CameraModel& second, const Transform& first_T_second) {
  CDFF_RETURN_IF_ERROR(c.validate("input 'correspondences'"));
  if (c.size() == 0)
    return invalidInput("input 'correspondences' is empty; expected at least 1 pair");
  if (Status s = first_T_second.validate(); !s.isOk())
    return invalidInput("input 'pose': {}", s.message());
  const double baseline = first_T_second.translation.norm();
  if (!(baseline > 1e-12))
    return invalidInput(
        "input 'pose' ({}_T_{}) has a translation of {} m: no baseline, no point "
        "can be triangulated; expected two camera positions",
        first_T_second.parent_frame, first_T_second.child_frame, baseline);
  if (Status s = first.validate(); !s.isOk())
    return invalidInput("input 'camera': {}", s.message());
  if (Status s = second.validate(); !s.isOk())
    return invalidInput("input 'second_camera': {}", s.message());
  auto n1 = normalizedCoordinates(first, c.first, "input 'correspondences' (first)");
  if (!n1) return n1.status();
  auto n2 = normalizedCoordinates(second, c.second, "input 'correspondences' (second)");
  if (!n2) return n2.status();
  return Views{first_T_second.rotation.toRotationMatrix(),
               first_T_second.translation,
               std::move(n1).value(),
               std::move(n2).value(),
               0.5 * (first.fx + first.fy),
               0.5 * (second.fx + second.fy)};
}

/// The DFIs' shared process(): `Triangulate` maps (views) to one point per pair (in the first
/// camera's frame, non-finite where there is none) or an error.
template <typename Base, typename Triangulate>
Status run(Base& node, Triangulate&& triangulate) {
  const CameraModel& second =
      node.in.second_camera.hasValue() ? *node.in.second_camera : *node.in.camera;
  Result<Views> v = views(*node.in.correspondences, *node.in.camera, second, *node.in.pose);
  if (!v) return v.status();
  Result<std::vector<Eigen::Vector3d>> points = triangulate(v.value());
  if (!points) return points.status();
  const auto& p = node.parameters();
  std::vector<Eigen::Vector3f> kept;
  nlohmann::json status = nlohmann::json::array();
  int behind = 0, low = 0, far = 0;
  for (std::size_t i = 0; i < points.value().size(); ++i) {
    const std::string s =
        check(v.value(), i, points.value()[i], p.max_reprojection_error, p.min_parallax);
    behind += s == "behind_camera";
    low += s == "low_parallax";
    far += s == "reprojection_error";
    if (s == "ok") kept.push_back(points.value()[i].template cast<float>());
    status.push_back(s);
  }
  if (behind + low + far > 0)
    node.warnAbout(
        fmt::format("Triangulation: {} of {} pairs refused: {} behind a camera, {} "
                    "below min_parallax, {} beyond max_reprojection_error",
                    behind + low + far, status.size(), behind, low, far));
  const int accepted = static_cast<int>(kept.size());
  node.out.points.set(PointCloud::fromXyz(kept, node.in.pose->parent_frame, node.in.pose->stamp));
  node.out.status.set(std::move(status));
  node.out.accepted.set(accepted);
  return Status::ok();
}

}  // namespace cdff::dfn::triangulation
