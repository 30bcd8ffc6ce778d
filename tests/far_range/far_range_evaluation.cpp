#include "far_range_evaluation.hpp"

#include <cmath>
#include <map>

#include <Eigen/Dense>

#include "cdff/eval/recording_evaluation.hpp"
#include "cdff/io/replay.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
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

Result<Evaluation> evaluateFarRange(const std::string& output) {
  io::Replay replay;
  CDFF_RETURN_IF_ERROR(replay.open({output}));
  std::map<Timestamp, Eigen::Isometry3d> camera_pose;  // camera_T_target
  std::vector<ImageRegion> matches;
  std::optional<ImageRegion> designated;
  std::optional<CameraModel> camera;
  std::vector<Timestamp> scores;
  while (replay.next()) {
    const io::ReplayMessage& m = replay.message();
    const std::string& c = m.channel();
    if (c == "/truth/camera_far/target_pose") {
      auto p = m.decode<PoseWithCovariance>();
      if (!p) return p.status();
      camera_pose[(*p)->pose.stamp] = (*p)->pose.isometry();
    } else if (c == "/chaser/camera/far/calibration" && !camera) {
      auto k = m.decode<CameraModel>();
      if (!k) return k.status();
      camera = **k;
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
  if (!camera) return notFound("{}: no far camera calibration passed through", output);
  Evaluation e;
  if (!designated) return e;
  e.designated = designated->stamp;
  e.designation = designated->source;
  for (Timestamp t : scores) e.images += t > designated->stamp ? 1 : 0;
  // The bearing against the centre of mass as `cdff eval` measures it.
  eval::RecordingEvaluationOptions options;
  options.products = {std::string(kPrefix) + "bearing"};
  Result<eval::EvaluationReport> report = eval::evaluateRecording({output}, options);
  if (!report) return report.status();
  if (report->bearings.size() != 1) return notFound("{}: the bearing was not evaluated", output);
  e.bearing = report->bearings.front();
  // The designated point: on the designation's ray, at the centre of mass's depth.
  const Eigen::Isometry3d* at = nearest(camera_pose, designated->stamp);
  if (!at) return e;
  const Eigen::Vector2d d = designated->centre();
  const Eigen::Vector3d ray((d.x() - camera->cx) / camera->fx, (d.y() - camera->cy) / camera->fy,
                            1.0);
  const Eigen::Vector3d point_target = at->inverse() * (ray * at->translation().z());
  e.centre_offset_m = point_target.norm();
  for (const ImageRegion& r : matches) {
    const Eigen::Isometry3d* pose = nearest(camera_pose, r.stamp);
    if (!pose || r.stamp <= designated->stamp) continue;
    e.tracked_point_px.push_back((r.centre() - camera->project(*pose * point_target)).norm());
  }
  return e;
}

}  // namespace cdff::far_range
