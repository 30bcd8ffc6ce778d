#pragma once
// Spacecraft models: a triangle mesh with per-triangle materials, the planar polygons it was
// built from (the face model of model-based trackers), and what can be derived from it (dense
// point clouds, crease and silhouette-candidate edges).

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/egse/material.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff::egse {

/// A planar polygon of the face model: indices into the mesh vertices, counter-clockwise seen
/// from outside (the right-hand normal points out, as ViSP's .cao expects).
struct ModelPolygon {
  std::vector<std::uint32_t> vertices;
  std::uint16_t material = 0;
  std::uint16_t part = 0;  // index into TargetModel::parts (0 when the model has no parts)
};

struct TargetModel {
  std::string name;
  TriangleMesh mesh;                             // in the model (body) frame, metres
  std::vector<std::uint16_t> triangle_material;  // index into `materials`, one per triangle
  std::vector<Material> materials;
  std::vector<ModelPolygon> polygons;  // the face model; empty for loaded meshes (triangles serve)
  /// Named parts ("bus", "antenna", ...), so that a model error can drop one; empty when the
  /// model has none (then `triangle_part` is empty too).
  std::vector<std::string> parts;
  std::vector<std::uint16_t> triangle_part;  // index into `parts`, one per triangle

  /// Ok when the mesh is valid, has vertex normals, one material per triangle in range,
  /// polygons with at least 3 vertices in range, and (with parts) one part per triangle in
  /// range.
  Status validate() const;
  Eigen::AlignedBox3d bounds() const;
  /// Centre of the bounding box and the radius of the sphere around it that holds every vertex.
  Eigen::Vector3d boundingCentre() const;
  double boundingRadius() const;
  double surfaceArea() const;
  const Material& triangleMaterial(std::size_t triangle) const {
    return materials[triangle_material[triangle]];
  }
};

/// Builds a TargetModel out of primitives. Flat polygons get their own vertices (face normals);
/// curved surfaces share vertices with smooth normals. Every primitive also adds its planar
/// polygons to the face model.
class ModelBuilder {
 public:
  explicit ModelBuilder(std::string name);

  /// Uses the built-in material table; returns the index to pass to the add functions.
  std::uint16_t material(MaterialId id);
  std::uint16_t addMaterial(const Material& material);
  /// Everything added from now on belongs to the part `name` (a new part, or an earlier one of
  /// that name); a model built without a call has no parts.
  void beginPart(const std::string& name);

  /// A planar convex polygon (counter-clockwise seen from outside), flat-shaded.
  void addPolygon(const std::vector<Eigen::Vector3d>& points, std::uint16_t material);
  /// A box centred at `pose * 0` with half extents along the pose's axes; `face_materials` in
  /// the order -x, +x, -y, +y, -z, +z.
  void addBox(const Eigen::Isometry3d& pose, const Eigen::Vector3d& half_extents,
              const std::array<std::uint16_t, 6>& face_materials);
  void addBox(const Eigen::Isometry3d& pose, const Eigen::Vector3d& half_extents,
              std::uint16_t material);
  /// A surface of revolution about the pose's z axis through the profile points (radius, z),
  /// smooth-shaded around the axis. `outward` picks the side the normals face (away from the
  /// axis for a solid of revolution; towards it for an inner wall). Closed profiles of a solid
  /// go from one end to the other; caps are added with addDisc.
  void addRevolution(const Eigen::Isometry3d& pose, const std::vector<Eigen::Vector2d>& profile,
                     int segments, std::uint16_t material, bool outward = true);
  /// A flat annulus (inner_radius may be 0: a disc) in the pose's z = 0 plane, facing +z when
  /// `facing_positive_z`.
  void addAnnulus(const Eigen::Isometry3d& pose, double inner_radius, double outer_radius,
                  int segments, std::uint16_t material, bool facing_positive_z);

  TargetModel build();

 private:
  std::uint32_t addVertex(const Eigen::Vector3d& p, const Eigen::Vector3d& n);

  std::string name_;
  std::vector<Eigen::Vector3f> vertices_;
  std::vector<Eigen::Vector3f> normals_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;
  std::vector<std::uint16_t> triangle_material_;
  std::vector<Material> materials_;
  std::vector<int> builtin_index_;  // MaterialId -> index in materials_, or -1
  std::vector<ModelPolygon> polygons_;
  std::vector<std::string> parts_;
  // Where each part starts: (first triangle, first polygon, part index), in order.
  struct PartStart {
    std::size_t triangle, polygon;
    std::uint16_t part;
  };
  std::vector<PartStart> part_starts_;
};

/// An edge of the mesh with the normals of the faces on either side, for edge-based trackers:
/// crease edges are always visible as contours; the others may become silhouette edges when one
/// adjacent face turns away from the camera.
struct ModelEdge {
  Eigen::Vector3f a, b;
  Eigen::Vector3f normal_left, normal_right;  // equal for a boundary edge
  float dihedral_angle = 0;                   // rad between the normals
  bool boundary = false;                      // only one adjacent face
  bool crease = false;                        // dihedral_angle >= the crease threshold
};

/// Edges of the welded mesh (vertices closer than 1e-5 m merged) whose dihedral angle is at
/// least `min_dihedral` (rad); flat interior edges are left out.
std::vector<ModelEdge> extractEdges(const TargetModel& model, double min_dihedral = 1e-3,
                                    double crease_threshold = 0.5235987755982988);

/// `count` points sampled uniformly by area over the surface, with the surface normals and
/// (as intensity) the material's LIDAR reflectivity; reproducible from `seed`.
PointCloud samplePointCloud(const TargetModel& model, std::size_t count, std::uint64_t seed);

/// Merges vertices closer than `tolerance` (on a quantised grid): the welded index of every
/// vertex, and the welded positions when asked for.
std::vector<std::uint32_t> weldVertices(const TriangleMesh& mesh, double tolerance,
                                        std::vector<Eigen::Vector3f>* welded_positions = nullptr);

/// The model with its vertices mapped by `scale` then `transform` (normals follow).
TargetModel transformModel(const TargetModel& model, const Eigen::Isometry3d& transform,
                           double scale = 1.0);

}  // namespace cdff::egse
