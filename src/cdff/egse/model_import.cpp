// Loaders of user meshes: OBJ here, PLY, STL and glTF 2.0 in model_import_{ply,stl,gltf}.cpp,
// and the choice among them by file extension; what they share is in model_import_common.hpp.
#include <algorithm>
#include <cmath>
#include <map>

#include "cdff/egse/model_import_common.hpp"
#include "cdff/egse/model_io.hpp"

namespace cdff::egse {

using mesh_import::checkOptions;
using mesh_import::corrupt;
using mesh_import::finish;
using mesh_import::LineReader;
using mesh_import::lower;
using mesh_import::materialFromColour;
using mesh_import::MaterialTable;
using mesh_import::parseDouble;
using mesh_import::parseLong;
using mesh_import::readWholeFile;
using mesh_import::tokens;

TargetModel buildModelFromTriangles(std::string name, const std::vector<Eigen::Vector3f>& positions,
                                    const std::vector<std::array<std::uint32_t, 3>>& triangles,
                                    const std::vector<std::uint16_t>& triangle_material,
                                    std::vector<Material> materials, double smoothing_angle) {
  // Face normals, and for each position the faces around it.
  std::vector<Eigen::Vector3f> face_normal(triangles.size(), Eigen::Vector3f::Zero());
  std::vector<std::vector<std::uint32_t>> faces_at(positions.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const auto& tri = triangles[t];
    const Eigen::Vector3f n =
        (positions[tri[1]] - positions[tri[0]]).cross(positions[tri[2]] - positions[tri[0]]);
    face_normal[t] = n;  // area-weighted
    for (std::uint32_t v : tri) faces_at[v].push_back(static_cast<std::uint32_t>(t));
  }
  const float cos_limit = static_cast<float>(std::cos(smoothing_angle));
  std::vector<Eigen::Vector3f> vertices, normals;
  std::vector<std::array<std::uint32_t, 3>> out_triangles(triangles.size());
  // Corners with the same position and the same smoothed normal share one output vertex.
  std::vector<std::vector<std::pair<Eigen::Vector3f, std::uint32_t>>> emitted(positions.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const Eigen::Vector3f nt = face_normal[t].normalized();
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = triangles[t][k];
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      for (std::uint32_t other : faces_at[v]) {
        const Eigen::Vector3f no = face_normal[other].normalized();
        if (no.dot(nt) >= cos_limit) sum += face_normal[other];
      }
      Eigen::Vector3f n = sum.norm() > 0 ? sum.normalized() : nt;
      if (!n.allFinite()) n = Eigen::Vector3f::UnitZ();
      std::uint32_t index = UINT32_MAX;
      for (const auto& [normal, id] : emitted[v])
        if ((normal - n).norm() < 1e-5f) index = id;
      if (index == UINT32_MAX) {
        index = static_cast<std::uint32_t>(vertices.size());
        vertices.push_back(positions[v]);
        normals.push_back(n);
        emitted[v].emplace_back(n, index);
      }
      out_triangles[t][k] = index;
    }
  }
  TargetModel model;
  model.name = std::move(name);
  model.mesh.frame_id = "target";
  model.mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  model.mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
  model.mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(out_triangles));
  model.triangle_material = triangle_material;
  model.materials = std::move(materials);
  return model;
}

namespace {

// ----------------------------------------------------------------------------------- OBJ

Status readMtl(const std::filesystem::path& path, std::map<std::string, Material>& out) {
  auto text = readWholeFile(path);
  if (!text) return text.status();
  LineReader reader(*text);
  std::string_view line;
  Material* current = nullptr;
  while (reader.next(line)) {
    const auto t = tokens(line);
    if (t.empty() || t[0][0] == '#') continue;
    auto vec3 = [&](Eigen::Vector3f& v) -> Status {
      if (t.size() < 4)
        return corrupt(
            fmt::format("{}:{}: '{}' needs 3 numbers", path.string(), reader.line(), t[0]));
      for (int i = 0; i < 3; ++i) {
        double d;
        if (!parseDouble(t[1 + i], d))
          return corrupt(
              fmt::format("{}:{}: '{}' is not a number", path.string(), reader.line(), t[1 + i]));
        v[i] = static_cast<float>(d);
      }
      return Status::ok();
    };
    if (t[0] == "newmtl" && t.size() >= 2) {
      const std::string name(t[1]);
      out[name] =
          materialFromColour(name, Eigen::Vector3f::Constant(0.5f), Eigen::Vector3f::Zero(), 1.0f);
      current = &out[name];
    } else if (current && t[0] == "Kd") {
      CDFF_RETURN_IF_ERROR(vec3(current->diffuse));
      current->lidar_reflectivity = std::clamp(current->diffuse.mean() + 0.1f, 0.05f, 1.0f);
    } else if (current && t[0] == "Ks") {
      CDFF_RETURN_IF_ERROR(vec3(current->specular));
    } else if (current && t[0] == "Ns" && t.size() >= 2) {
      double d;
      if (!parseDouble(t[1], d))
        return corrupt(
            fmt::format("{}:{}: 'Ns {}' is not a number", path.string(), reader.line(), t[1]));
      current->shininess = static_cast<float>(std::max(1.0, d));
    }
  }
  return Status::ok();
}

}  // namespace

Result<TargetModel> loadObj(const std::filesystem::path& path, const MeshLoadOptions& options) {
  CDFF_RETURN_IF_ERROR(checkOptions(options, path));
  auto text = readWholeFile(path);
  if (!text) return text.status();
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint16_t> triangle_material;
  MaterialTable table(options.default_material);
  std::map<std::string, Material> described;
  std::uint16_t current = UINT16_MAX;
  LineReader reader(*text);
  std::string_view line;
  const std::string file = path.string();
  while (reader.next(line)) {
    const auto t = tokens(line);
    if (t.empty() || t[0][0] == '#') continue;
    const int ln = reader.line();
    if (t[0] == "v") {
      if (t.size() < 4)
        return corrupt(fmt::format("{}:{}: vertex has {} coordinates; expected 'v x y z'", file, ln,
                                   t.size() - 1));
      Eigen::Vector3f p;
      for (int i = 0; i < 3; ++i) {
        double d;
        if (!parseDouble(t[1 + i], d))
          return corrupt(fmt::format("{}:{}: vertex coordinate '{}' is not a finite number", file,
                                     ln, t[1 + i]));
        p[i] = static_cast<float>(d);
      }
      positions.push_back(p);
    } else if (t[0] == "f") {
      if (t.size() < 4)
        return corrupt(fmt::format("{}:{}: face has {} vertices; expected at least 3", file, ln,
                                   t.size() - 1));
      std::vector<std::uint32_t> face;
      for (std::size_t i = 1; i < t.size(); ++i) {
        const std::string_view first = t[i].substr(0, t[i].find('/'));
        long long index;
        if (!parseLong(first, index) || index == 0)
          return corrupt(
              fmt::format("{}:{}: face vertex '{}' is not a vertex index (1-based, or negative)",
                          file, ln, t[i]));
        const long long resolved =
            index > 0 ? index - 1 : static_cast<long long>(positions.size()) + index;
        if (resolved < 0 || resolved >= static_cast<long long>(positions.size()))
          return corrupt(
              fmt::format("{}:{}: face vertex {} refers to a vertex not defined yet ({} so far)",
                          file, ln, index, positions.size()));
        face.push_back(static_cast<std::uint32_t>(resolved));
      }
      if (current == UINT16_MAX) current = table.index("");
      for (std::size_t i = 1; i + 1 < face.size(); ++i) {
        triangles.push_back({face[0], face[i], face[i + 1]});
        triangle_material.push_back(current);
      }
    } else if (t[0] == "usemtl") {
      const std::string name = t.size() >= 2 ? std::string(t[1]) : std::string();
      auto it = described.find(name);
      current = table.index(name, it != described.end() ? &it->second : nullptr);
    } else if (t[0] == "mtllib" && t.size() >= 2) {
      const std::filesystem::path mtl = path.parent_path() / std::string(t[1]);
      // A missing material library is not fatal: the faces get the default material.
      if (std::filesystem::exists(mtl)) CDFF_RETURN_IF_ERROR(readMtl(mtl, described));
    }
    // vn, vt, o, g, s, l, p: not needed (normals are recomputed with creases).
  }
  return finish(path.stem().string(), std::move(positions), triangles, triangle_material,
                table.take(), options, path);
}

Result<TargetModel> loadModel(const std::filesystem::path& path, const MeshLoadOptions& options) {
  const std::string ext = lower(path.extension().string());
  if (!std::filesystem::exists(path))
    return notFound("mesh file '{}' does not exist", path.string());
  if (ext == ".obj") return loadObj(path, options);
  if (ext == ".ply") return loadPly(path, options);
  if (ext == ".stl") return loadStl(path, options);
  if (ext == ".gltf" || ext == ".glb") return loadGltf(path, options);
  return invalidInput("mesh file '{}' has extension '{}'; expected .obj, .ply, .stl, .gltf or .glb",
                      path.string(), ext);
}

}  // namespace cdff::egse
