#pragma once
// Reading triangle meshes from files: Wavefront OBJ and PLY (ascii, binary little and big
// endian). Polygons are split into triangle fans. Vertex normals are read from PLY files that
// have nx, ny, nz; OBJ normals belong to face corners, not vertices, and are not used (samplers
// then take the faces' own normals). Errors name the file and the line (text) or byte offset
// (binary) of the problem.

#include <string>

#include "cdff/types/mesh.hpp"

namespace cdff {

/// Loads `path` (format chosen by its extension, .obj or .ply, any case), scaling every
/// coordinate by `scale` (e.g. 0.001 for a file in millimetres); the mesh gets `frame_id`.
Result<TriangleMesh> loadMesh(const std::string& path, const std::string& frame_id = "",
                              double scale = 1.0);

}  // namespace cdff
