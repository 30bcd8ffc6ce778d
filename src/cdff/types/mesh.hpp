#pragma once
// Triangle meshes (target models, reconstructions).

#include <array>
#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "cdff/types/buffer.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

struct TriangleMesh {
  Timestamp stamp = 0;
  std::string frame_id;
  Buffer<Eigen::Vector3f> vertices;                // m
  Buffer<Eigen::Vector3f> vertex_normals;          // unit, or empty
  Buffer<std::array<std::uint32_t, 3>> triangles;  // counter-clockwise seen from outside

  std::size_t vertexCount() const { return vertices.size(); }
  std::size_t triangleCount() const { return triangles.size(); }
  /// Ok when there is at least one triangle, indices are in range and vertices finite.
  Status validate(const char* what = "mesh") const;
  /// Total area of the triangles, m^2.
  double surfaceArea() const;
};

/// Which normals surface samples get: the triangles' own (from their winding), the vertex
/// normals interpolated across each triangle (smooth surfaces), or vertex normals when the mesh
/// has them and face normals otherwise.
enum class SampleNormals { kFace, kVertex, kAuto };

/// `count` points on the surface of `mesh`, uniform by area, with unit normals, in the mesh's
/// frame. Every triangle gets its share of the points by area (systematic sampling along the
/// cumulative area, so the counts are proportional up to one point), at uniformly random
/// positions inside it. The same mesh, count and seed give the same cloud on every platform.
/// Degenerate (zero-area) triangles get no points; kVertex without vertex normals is an error.
/// With `sample_triangles`, it receives the index of each point's triangle (the cloud's order).
Result<PointCloud> sampleSurface(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed,
                                 SampleNormals normals = SampleNormals::kAuto,
                                 std::vector<std::uint32_t>* sample_triangles = nullptr);

}  // namespace cdff
