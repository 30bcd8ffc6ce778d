#pragma once
// What the 3D view and the error plots of `cdff serve` get (docs/web-ui.md#the-3d-view): a LIDAR
// point cloud thinned to a bounded number of points, sent as Float32 x, y, z; a triangle mesh as
// Float32 vertices and Uint32 triangles; and the error of an estimated pose against the truth
// with the thresholds of the requirement that applies at the truth's range (cdff::eval's table,
// the one `cdff eval` checks).
//
// Binary bodies and frames share the replay stream's layout (binaryFrame): 4 bytes of JSON header
// length N (little endian), N bytes of JSON header, then the payload, little endian:
//   points: {"type": "points", "count", "source_count", "stride", "frame", ...}, count x 3 float32
//   mesh:   {"type": "mesh", "vertices", "triangles", "frame", ...}, vertices x 3 float32, then
//           triangles x 3 uint32 (counter-clockwise seen from outside)

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/types/geometry.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff::serve {

/// The most points a browser gets of one cloud, whatever it asks for.
constexpr std::size_t kMaxCloudPoints = 200'000;

struct DecimatedCloud {
  std::vector<float> xyz;         // x, y, z of each kept point (m, the cloud's frame)
  std::size_t source_points = 0;  // in the cloud
  std::size_t finite_points = 0;  // of which finite (the others are never sent)
  std::size_t stride = 1;         // every stride-th finite point is kept
};

/// Every stride-th finite point of `cloud`, stride = ceil(finite points / max_points): at most
/// `max_points` (>= 1) points, spread over the whole scan.
DecimatedCloud decimateCloud(const PointCloud& cloud, std::size_t max_points);

/// The points frame of `cloud`: `header` with type, count, source_count, stride and frame added,
/// then the points.
std::string pointsFrame(nlohmann::json header, const PointCloud& cloud,
                        const DecimatedCloud& points);

/// The mesh body: `header` with type, vertices, triangles and frame added, then the vertices and
/// the triangles. An error when the mesh is not valid (TriangleMesh::validate).
Result<std::string> meshBody(const TriangleMesh& mesh, nlohmann::json header);

/// The error of an estimate against the truth of the same transform, as `cdff eval` measures
/// it, and the pose accuracy requirement (eval::poseRequirements) whose band holds the truth's
/// range, when one does.
struct PoseError {
  double range_m = 0;           // |truth translation|
  double position_error_m = 0;  // |t_est - t_true|
  double angle_error_deg = 0;   // angle of R_est R_true^T
  std::optional<double> position_threshold_m, angle_threshold_deg;
  std::string requirement;  // its id ("SR_DFPC_0100"), "" when none applies
};
PoseError poseError(const Transform& estimate, const Transform& truth);
/// Sets the thresholds and the requirement of `error` from its range_m.
void applyThresholds(PoseError& error);

/// The requirements the error plots draw: eval::poseRequirements() with a position or angle
/// threshold, as [{id, title, quantity: "position_error_m" | "angle_error_deg", threshold,
/// min_range_m, max_range_m}].
nlohmann::json poseThresholdsJson();

}  // namespace cdff::serve
