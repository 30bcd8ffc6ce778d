#include "cdff/serve/scene.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <numbers>

#include "cdff/eval/requirements.hpp"
#include "cdff/serve/replay_stream.hpp"

namespace cdff::serve {

using nlohmann::json;

// The browser reads the payloads as little-endian typed arrays (DataView / Float32Array).
static_assert(
    std::endian::native == std::endian::little,
    "the binary frames are written in the host's byte order, which must be little endian");

namespace {

template <typename T>
void append(std::vector<std::uint8_t>& out, const T* data, std::size_t count) {
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(data);
  out.insert(out.end(), bytes, bytes + count * sizeof(T));
}

bool finite(const Point4f& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

}  // namespace

DecimatedCloud decimateCloud(const PointCloud& cloud, std::size_t max_points) {
  DecimatedCloud out;
  max_points = std::max<std::size_t>(1, max_points);
  out.source_points = cloud.size();
  for (const Point4f& p : cloud.points) out.finite_points += finite(p) ? 1 : 0;
  out.stride = std::max<std::size_t>(1, (out.finite_points + max_points - 1) / max_points);
  out.xyz.reserve(3 * std::min(out.finite_points, max_points));
  std::size_t k = 0;
  for (const Point4f& p : cloud.points) {
    if (!finite(p)) continue;
    if (k++ % out.stride != 0) continue;
    out.xyz.insert(out.xyz.end(), {p.x, p.y, p.z});
  }
  return out;
}

std::string pointsFrame(json header, const PointCloud& cloud, const DecimatedCloud& points) {
  header["type"] = "points";
  header["count"] = points.xyz.size() / 3;
  header["source_count"] = points.source_points;
  header["finite_count"] = points.finite_points;
  header["stride"] = points.stride;
  header["frame"] = cloud.frame_id;
  std::vector<std::uint8_t> payload;
  append(payload, points.xyz.data(), points.xyz.size());
  return binaryFrame(header, payload);
}

Result<std::string> meshBody(const TriangleMesh& mesh, json header) {
  CDFF_RETURN_IF_ERROR(mesh.validate());
  header["type"] = "mesh";
  header["vertices"] = mesh.vertexCount();
  header["triangles"] = mesh.triangleCount();
  header["frame"] = mesh.frame_id;
  std::vector<std::uint8_t> payload;
  payload.reserve(mesh.vertexCount() * 12 + mesh.triangleCount() * 12);
  for (const Eigen::Vector3f& v : mesh.vertices) append(payload, v.data(), 3);
  for (const std::array<std::uint32_t, 3>& t : mesh.triangles) append(payload, t.data(), 3);
  return binaryFrame(header, payload);
}

PoseError poseError(const Transform& estimate, const Transform& truth) {
  PoseError e;
  e.range_m = truth.translation.norm();
  e.position_error_m = (estimate.translation - truth.translation).norm();
  e.angle_error_deg = angularDistance(estimate.rotation, truth.rotation) * 180.0 / std::numbers::pi;
  applyThresholds(e);
  return e;
}

void applyThresholds(PoseError& e) {
  using Q = eval::RequirementSpec::Quantity;
  const eval::RequirementSpec* position = eval::poseRequirementAt(Q::kPositionError, e.range_m);
  const eval::RequirementSpec* angle = eval::poseRequirementAt(Q::kAngleError, e.range_m);
  e.position_threshold_m = position ? std::optional<double>(position->threshold) : std::nullopt;
  e.angle_threshold_deg = angle ? std::optional<double>(angle->threshold) : std::nullopt;
  e.requirement = angle ? angle->id : position ? position->id : "";
}

json poseThresholdsJson() {
  using Q = eval::RequirementSpec::Quantity;
  json out = json::array();
  for (const eval::RequirementSpec& r : eval::poseRequirements()) {
    if (r.quantity != Q::kPositionError && r.quantity != Q::kAngleError) continue;
    out.push_back(
        {{"id", r.id},
         {"title", r.title},
         {"quantity", r.quantity == Q::kPositionError ? "position_error_m" : "angle_error_deg"},
         {"threshold", r.threshold},
         {"min_range_m", r.min_range_m},
         {"max_range_m", r.max_range_m}});
  }
  return out;
}

}  // namespace cdff::serve
