#pragma once
// The tracked model's contour over a camera image
// (docs/web-ui.md#the-contour-over-the-camera-image): the outline of the model's mesh seen from a
// pose, projected with the camera model of the image (its distortion included), as pixel segments
// of the recorded image.
//
// The outline is what a model-based tracker follows: the silhouette edges (between a triangle
// that faces the camera and one that faces away, or on the mesh's border beside one that faces
// it) and the creases between two facing triangles that bend by more than `crease_deg`. Edges
// are not tested for occlusion by other parts of the model.

#include <array>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/status.hpp"

namespace cdff::serve {

/// The outline edges of a mesh, welded (vertices closer than 0.1 mm merged) once so that a pose
/// only classifies them.
class MeshOutline {
 public:
  /// An error when the mesh is not valid.
  static Result<MeshOutline> of(const TriangleMesh& mesh);

  /// The outline seen by `camera` at camera_T_model (the camera's optical frame: z forward, x
  /// right, y down), as segments {u0, v0, u1, v1} in pixels of the camera's image. Edges with an
  /// end less than 1 cm in front of the camera are left out. An error for a camera model that
  /// does not validate.
  Result<std::vector<std::array<float, 4>>> project(const Transform& camera_T_model,
                                                    const CameraModel& camera,
                                                    double crease_deg = 30) const;

  std::size_t edges() const { return edges_.size(); }

 private:
  struct Edge {
    std::uint32_t a = 0, b = 0;          // welded vertices
    std::int32_t left = -1, right = -1;  // triangles on either side (-1: border)
  };
  std::vector<Eigen::Vector3d> vertices_;  // welded
  std::vector<Eigen::Vector3d> normals_;   // per triangle, unit
  std::vector<Eigen::Vector3d> centres_;   // per triangle
  std::vector<Edge> edges_;
};

/// {"count", "segments": [u0, v0, u1, v1, ...]} (flat, pixels of the recorded image).
nlohmann::json contourJson(const std::vector<std::array<float, 4>>& segments);

}  // namespace cdff::serve
