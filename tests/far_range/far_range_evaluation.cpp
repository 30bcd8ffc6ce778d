#include "far_range_evaluation.hpp"

#include <cmath>
#include <map>

#include <Eigen/Dense>

#include "cdff/io/replay.hpp"
#include "cdff/types/bearing.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/image_region.hpp"

namespace cdff::far_range {
namespace {

constexpr const char* kPrefix = "/cdff/far_range_tracking/";

/// The truth sample nearest to `stamp` (the truth's rate divides the camera's).
template <typename T>
const T* nearest(const std::map<Timestamp, T>& m, Timestamp stamp) {
  auto it = m.lower_bound(stamp);
  if (it != m.end() && it->first - stamp < 1000) return &it->second;
  if (it != m.begin() && stamp - std::prev(it)->first < 1000) return &std::prev(it)->second;
  return nullptr;
}

}  // namespace

double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? std::nan("") : std::sqrt(s / static_cast<double>(v.size()));
}

Result<Evaluation> evaluateFarRange(const std::string& output, double focal_px) {
  io::Replay replay;
  CDFF_RETURN_IF_ERROR(replay.open({output}));
  std::map<Timestamp, Eigen::Vector3d> centre;         // servicer frame
  std::map<Timestamp, Eigen::Isometry3d> camera_pose;  // camera_T_target
  std::vector<Bearing> bearings;
  std::vector<ImageRegion> matches;
  std::optional<ImageRegion> designated;
  std::vector<Timestamp> scores;
  while (replay.next()) {
    const io::ReplayMessage& m = replay.message();
    const std::string& c = m.channel();
    if (c == "/truth/target_pose" || c == "/truth/camera_far/target_pose") {
      auto p = m.decode<PoseWithCovariance>();
      if (!p) return p.status();
      if (c == "/truth/target_pose")
        centre[(*p)->pose.stamp] = (*p)->pose.translation;
      else
        camera_pose[(*p)->pose.stamp] = (*p)->pose.isometry();
    } else if (c == std::string(kPrefix) + "bearing") {
      auto b = m.decode<Bearing>();
      if (!b) return b.status();
      bearings.push_back(**b);
    } else if (c == std::string(kPrefix) + "match" || c == std::string(kPrefix) + "designated") {
      auto r = m.decode<ImageRegion>();
      if (!r) return r.status();
      if (c.ends_with("match"))
        matches.push_back(**r);
      else if (!designated)
        designated = **r;
    } else if (c == std::string(kPrefix) + "score") {
      scores.push_back(m.logTime());
    }
  }
  CDFF_RETURN_IF_ERROR(replay.status());
  Evaluation e;
  if (!designated) return e;
  e.designated = designated->stamp;
  e.designation = designated->source;
  for (Timestamp t : scores) e.images += t > designated->stamp ? 1 : 0;
  for (const Bearing& b : bearings) {
    const Eigen::Vector3d* p = nearest(centre, b.stamp);
    if (!p) continue;
    Sample s;
    s.stamp = b.stamp;
    s.range = p->norm();
    const Eigen::Vector3d u = *p / s.range, err = b.direction - u;
    s.bearing_px = std::acos(std::clamp(b.direction.dot(u), -1.0, 1.0)) * focal_px;
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(b.covariance, Eigen::ComputeFullU);
    const Eigen::Matrix<double, 3, 2> across = svd.matrixU().leftCols<2>();
    const Eigen::Vector2d e2 = across.transpose() * err;
    s.bearing_nees = e2.dot((across.transpose() * b.covariance * across).inverse() * e2);
    s.range_error_pct = std::isnan(b.range) ? std::nan("") : 100 * (b.range - s.range) / s.range;
    e.bearings.push_back(s);
  }
  // The designated point: on the designation's ray, at the centre of mass's depth.
  const Eigen::Isometry3d* at = nearest(camera_pose, designated->stamp);
  if (!at) return e;
  const double cx = 511.5, cy = 511.5;  // the far camera's principal point (1024 x 1024)
  const Eigen::Vector2d d = designated->centre();
  const Eigen::Vector3d ray((d.x() - cx) / focal_px, (d.y() - cy) / focal_px, 1.0);
  const Eigen::Vector3d point_target = at->inverse() * (ray * at->translation().z());
  e.centre_offset_m = point_target.norm();
  for (const ImageRegion& r : matches) {
    const Eigen::Isometry3d* pose = nearest(camera_pose, r.stamp);
    if (!pose || r.stamp <= designated->stamp) continue;
    const Eigen::Vector3d q = *pose * point_target;
    const Eigen::Vector2d truth(focal_px * q.x() / q.z() + cx, focal_px * q.y() / q.z() + cy);
    e.tracked_point_px.push_back((r.centre() - truth).norm());
  }
  return e;
}

}  // namespace cdff::far_range
