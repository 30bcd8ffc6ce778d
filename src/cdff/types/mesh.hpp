#pragma once
// Triangle meshes (target models, reconstructions).

#include <array>
#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "cdff/types/buffer.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

struct TriangleMesh {
  Timestamp stamp = 0;
  std::string frame_id;
  Buffer<Eigen::Vector3f> vertices;                  // m
  Buffer<Eigen::Vector3f> vertex_normals;            // unit, or empty
  Buffer<std::array<std::uint32_t, 3>> triangles;    // counter-clockwise seen from outside

  std::size_t vertexCount() const { return vertices.size(); }
  std::size_t triangleCount() const { return triangles.size(); }
  /// Ok when there is at least one triangle, indices are in range and vertices finite.
  Status validate(const char* what = "mesh") const;
};

}  // namespace cdff
