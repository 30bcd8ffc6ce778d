#include "cdff/types/mesh.hpp"

namespace cdff {

Status TriangleMesh::validate(const char* what) const {
  if (triangles.empty()) return invalidInput("{} has no triangles; expected at least one", what);
  if (!vertex_normals.empty() && vertex_normals.size() != vertices.size())
    return invalidInput("{} has {} vertices but {} normals; expected one per vertex or none", what,
                        vertices.size(), vertex_normals.size());
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (!vertices[i].allFinite()) return invalidInput("{} vertex {} is not finite", what, i);
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (std::uint32_t index : triangles[t])
      if (index >= vertices.size())
        return invalidInput("{} triangle {} uses vertex {}; expected an index < {}", what, t,
                            index, vertices.size());
  return Status::ok();
}

}  // namespace cdff
