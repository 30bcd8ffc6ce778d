// Writers of the model files (OBJ + MTL, PLY, point cloud PLY, ViSP .cao, edge list).
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>

#include "cdff/egse/model_io.hpp"

namespace cdff::egse {

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

Result<File> openForWriting(const std::filesystem::path& path) {
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  File f(std::fopen(path.c_str(), "wb"));
  if (!f) return ioError("cannot open '{}' for writing: {}", path.string(), std::strerror(errno));
  return f;
}

Status closeChecked(File& f, const std::filesystem::path& path) {
  std::FILE* raw = f.release();
  const bool failed = std::ferror(raw) != 0;
  if (std::fclose(raw) != 0 || failed)
    return ioError("writing '{}' failed: {}", path.string(), std::strerror(errno));
  return Status::ok();
}

std::string sanitise(const std::string& name) {
  std::string out = name.empty() ? std::string("material") : name;
  for (char& c : out)
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') c = '_';
  return out;
}

}  // namespace

Status writeObj(const TargetModel& model, const std::filesystem::path& path) {
  CDFF_RETURN_IF_ERROR(model.validate());
  std::filesystem::path mtl_path = path;
  mtl_path.replace_extension(".mtl");
  {
    auto mtl = openForWriting(mtl_path);
    if (!mtl) return mtl.status();
    std::FILE* f = mtl->get();
    std::fprintf(f, "# CDFF simulator materials of '%s' (linear RGB)\n", model.name.c_str());
    for (const Material& m : model.materials) {
      std::fprintf(f, "newmtl %s\n", sanitise(m.name).c_str());
      std::fprintf(f, "Kd %.6g %.6g %.6g\n", m.diffuse.x(), m.diffuse.y(), m.diffuse.z());
      std::fprintf(f, "Ks %.6g %.6g %.6g\n", m.specular.x(), m.specular.y(), m.specular.z());
      std::fprintf(f, "Ns %.6g\nillum 2\n\n", m.shininess);
    }
    CDFF_RETURN_IF_ERROR(closeChecked(*mtl, mtl_path));
  }
  auto obj = openForWriting(path);
  if (!obj) return obj.status();
  std::FILE* f = obj->get();
  std::fprintf(f, "# CDFF simulator model '%s' in frame '%s', metres\n", model.name.c_str(),
               model.mesh.frame_id.c_str());
  std::fprintf(f, "mtllib %s\no %s\n", mtl_path.filename().c_str(), sanitise(model.name).c_str());
  for (const auto& v : model.mesh.vertices)
    std::fprintf(f, "v %.9g %.9g %.9g\n", v.x(), v.y(), v.z());
  for (const auto& n : model.mesh.vertex_normals)
    std::fprintf(f, "vn %.7g %.7g %.7g\n", n.x(), n.y(), n.z());
  // Faces grouped by material, in material order, so that each material has one usemtl.
  for (std::size_t m = 0; m < model.materials.size(); ++m) {
    bool any = false;
    for (std::size_t t = 0; t < model.mesh.triangles.size(); ++t) {
      if (model.triangle_material[t] != m) continue;
      if (!any) std::fprintf(f, "usemtl %s\n", sanitise(model.materials[m].name).c_str());
      any = true;
      const auto& tri = model.mesh.triangles[t];
      std::fprintf(f, "f %u//%u %u//%u %u//%u\n", tri[0] + 1, tri[0] + 1, tri[1] + 1, tri[1] + 1,
                   tri[2] + 1, tri[2] + 1);
    }
  }
  return closeChecked(*obj, path);
}

Status writePly(const TargetModel& model, const std::filesystem::path& path, bool binary) {
  CDFF_RETURN_IF_ERROR(model.validate());
  auto file = openForWriting(path);
  if (!file) return file.status();
  std::FILE* f = file->get();
  std::fprintf(f, "ply\nformat %s 1.0\n", binary ? "binary_little_endian" : "ascii");
  std::fprintf(f, "comment CDFF simulator model '%s' in frame '%s', metres\n", model.name.c_str(),
               model.mesh.frame_id.c_str());
  for (std::size_t m = 0; m < model.materials.size(); ++m)
    std::fprintf(f, "comment cdff_material %zu %s\n", m, sanitise(model.materials[m].name).c_str());
  const bool parts = !model.parts.empty();
  for (std::size_t p = 0; p < model.parts.size(); ++p)
    std::fprintf(f, "comment cdff_part %zu %s\n", p, sanitise(model.parts[p]).c_str());
  std::fprintf(f, "element vertex %zu\n", model.mesh.vertices.size());
  std::fprintf(f, "property float x\nproperty float y\nproperty float z\n");
  std::fprintf(f, "property float nx\nproperty float ny\nproperty float nz\n");
  std::fprintf(f, "element face %zu\nproperty list uchar uint vertex_indices\n",
               model.mesh.triangles.size());
  std::fprintf(f, "property ushort material\n");
  if (parts) std::fprintf(f, "property ushort part\n");
  std::fprintf(f, "end_header\n");
  for (std::size_t i = 0; i < model.mesh.vertices.size(); ++i) {
    const auto& v = model.mesh.vertices[i];
    const auto& n = model.mesh.vertex_normals[i];
    if (binary) {
      const float values[6] = {v.x(), v.y(), v.z(), n.x(), n.y(), n.z()};
      std::fwrite(values, sizeof(float), 6, f);
    } else {
      std::fprintf(f, "%.9g %.9g %.9g %.7g %.7g %.7g\n", v.x(), v.y(), v.z(), n.x(), n.y(), n.z());
    }
  }
  for (std::size_t t = 0; t < model.mesh.triangles.size(); ++t) {
    const auto& tri = model.mesh.triangles[t];
    const std::uint16_t material = model.triangle_material[t];
    if (binary) {
      const std::uint8_t count = 3;
      std::fwrite(&count, 1, 1, f);
      std::fwrite(tri.data(), sizeof(std::uint32_t), 3, f);
      std::fwrite(&material, sizeof(material), 1, f);
      if (parts) std::fwrite(&model.triangle_part[t], sizeof(std::uint16_t), 1, f);
    } else if (parts) {
      std::fprintf(f, "3 %u %u %u %u %u\n", tri[0], tri[1], tri[2], material,
                   model.triangle_part[t]);
    } else {
      std::fprintf(f, "3 %u %u %u %u\n", tri[0], tri[1], tri[2], material);
    }
  }
  return closeChecked(*file, path);
}

Status writePointCloudPly(const PointCloud& cloud, const std::filesystem::path& path) {
  CDFF_RETURN_IF_ERROR(cloud.validate("point cloud", false));
  auto file = openForWriting(path);
  if (!file) return file.status();
  std::FILE* f = file->get();
  std::fprintf(f, "ply\nformat binary_little_endian 1.0\n");
  std::fprintf(f, "comment CDFF point cloud in frame '%s', metres\n", cloud.frame_id.c_str());
  std::fprintf(f, "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n",
               cloud.size());
  if (cloud.hasNormals())
    std::fprintf(f, "property float nx\nproperty float ny\nproperty float nz\n");
  if (!cloud.intensity.empty()) std::fprintf(f, "property float intensity\n");
  std::fprintf(f, "end_header\n");
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    float values[7];
    int n = 0;
    values[n++] = cloud.points[i].x;
    values[n++] = cloud.points[i].y;
    values[n++] = cloud.points[i].z;
    if (cloud.hasNormals()) {
      values[n++] = cloud.normals[i].x;
      values[n++] = cloud.normals[i].y;
      values[n++] = cloud.normals[i].z;
    }
    if (!cloud.intensity.empty()) values[n++] = cloud.intensity[i];
    std::fwrite(values, sizeof(float), static_cast<std::size_t>(n), f);
  }
  return closeChecked(*file, path);
}

Status writeCao(const TargetModel& model, const std::filesystem::path& path) {
  CDFF_RETURN_IF_ERROR(model.validate());
  std::vector<Eigen::Vector3f> points;
  const std::vector<std::uint32_t> remap = weldVertices(model.mesh, 1e-5, &points);
  std::vector<std::vector<std::uint32_t>> faces;
  if (!model.polygons.empty()) {
    for (const ModelPolygon& polygon : model.polygons) {
      std::vector<std::uint32_t> face;
      for (std::uint32_t v : polygon.vertices) {
        const std::uint32_t w = remap[v];
        if (face.empty() || face.back() != w) face.push_back(w);
      }
      if (face.size() > 1 && face.front() == face.back()) face.pop_back();
      if (face.size() >= 3) faces.push_back(std::move(face));
    }
  } else {
    for (const auto& t : model.mesh.triangles) {
      const std::uint32_t a = remap[t[0]], b = remap[t[1]], c = remap[t[2]];
      if (a != b && b != c && a != c) faces.push_back({a, b, c});
    }
  }
  auto file = openForWriting(path);
  if (!file) return file.status();
  std::FILE* f = file->get();
  std::fprintf(f, "V1\n# CDFF simulator model '%s' in frame '%s', metres\n", model.name.c_str(),
               model.mesh.frame_id.c_str());
  std::fprintf(f, "# 3D points\n%zu\n", points.size());
  for (const auto& p : points) std::fprintf(f, "%.9g %.9g %.9g\n", p.x(), p.y(), p.z());
  std::fprintf(f, "# 3D lines\n0\n# Faces from 3D lines\n0\n");
  std::fprintf(f, "# Faces from 3D points (counter-clockwise seen from outside)\n%zu\n",
               faces.size());
  for (const auto& face : faces) {
    std::fprintf(f, "%zu", face.size());
    for (std::uint32_t v : face) std::fprintf(f, " %u", v);
    std::fprintf(f, "\n");
  }
  std::fprintf(f, "# 3D cylinders\n0\n# 3D circles\n0\n");
  return closeChecked(*file, path);
}

Status writeEdges(const std::vector<ModelEdge>& edges, const std::filesystem::path& path) {
  auto file = openForWriting(path);
  if (!file) return file.status();
  std::FILE* f = file->get();
  std::fprintf(f, "# CDFF edge model v1: one edge per line, metres, model frame\n");
  std::fprintf(f, "# ax ay az bx by bz  nlx nly nlz  nrx nry nrz  dihedral_rad boundary crease\n");
  std::fprintf(f, "%zu\n", edges.size());
  for (const ModelEdge& e : edges)
    std::fprintf(f, "%.9g %.9g %.9g %.9g %.9g %.9g %.7g %.7g %.7g %.7g %.7g %.7g %.7g %d %d\n",
                 e.a.x(), e.a.y(), e.a.z(), e.b.x(), e.b.y(), e.b.z(), e.normal_left.x(),
                 e.normal_left.y(), e.normal_left.z(), e.normal_right.x(), e.normal_right.y(),
                 e.normal_right.z(), e.dihedral_angle, e.boundary ? 1 : 0, e.crease ? 1 : 0);
  return closeChecked(*file, path);
}

Result<std::vector<ModelEdge>> readEdges(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) return ioError("cannot open edge file '{}'", path.string());
  std::string line;
  int line_number = 0;
  long expected = -1;
  std::vector<ModelEdge> edges;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty() || line[0] == '#') continue;
    if (expected < 0) {
      char* end = nullptr;
      expected = std::strtol(line.c_str(), &end, 10);
      if (end == line.c_str() || expected < 0)
        return Status(StatusCode::kCorruptData,
                      fmt::format("{}:{}: expected the edge count, got '{}'", path.string(),
                                  line_number, line));
      continue;
    }
    ModelEdge e;
    int boundary = 0, crease = 0;
    const int read = std::sscanf(line.c_str(), "%f %f %f %f %f %f %f %f %f %f %f %f %f %d %d",
                                 &e.a.x(), &e.a.y(), &e.a.z(), &e.b.x(), &e.b.y(), &e.b.z(),
                                 &e.normal_left.x(), &e.normal_left.y(), &e.normal_left.z(),
                                 &e.normal_right.x(), &e.normal_right.y(), &e.normal_right.z(),
                                 &e.dihedral_angle, &boundary, &crease);
    if (read != 15)
      return Status(StatusCode::kCorruptData,
                    fmt::format("{}:{}: expected 15 fields (13 numbers and 2 flags), read {}",
                                path.string(), line_number, read));
    e.boundary = boundary != 0;
    e.crease = crease != 0;
    edges.push_back(e);
  }
  if (expected < 0 || static_cast<long>(edges.size()) != expected)
    return Status(StatusCode::kCorruptData,
                  fmt::format("{}: the header announces {} edges but the file holds {}",
                              path.string(), expected, edges.size()));
  return edges;
}

Result<ModelExport> exportModel(const TargetModel& model, const std::filesystem::path& directory,
                                const std::string& basename, std::size_t point_count,
                                std::uint64_t seed) {
  ModelExport out;
  out.obj = directory / (basename + ".obj");
  out.mtl = directory / (basename + ".mtl");
  out.ply = directory / (basename + ".ply");
  out.points_ply = directory / (basename + "_points.ply");
  out.cao = directory / (basename + ".cao");
  out.edges = directory / (basename + "_edges.txt");
  CDFF_RETURN_IF_ERROR(writeObj(model, out.obj));
  CDFF_RETURN_IF_ERROR(writePly(model, out.ply, true));
  CDFF_RETURN_IF_ERROR(
      writePointCloudPly(samplePointCloud(model, point_count, seed), out.points_ply));
  CDFF_RETURN_IF_ERROR(writeCao(model, out.cao));
  CDFF_RETURN_IF_ERROR(writeEdges(extractEdges(model), out.edges));
  return out;
}

}  // namespace cdff::egse
