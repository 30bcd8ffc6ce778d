#include "cdff/types/mesh_io.hpp"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace cdff {

namespace {

Status corrupt(const std::string& where, const std::string& what) {
  return {StatusCode::kCorruptData, where + ": " + what};
}

struct Builder {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3f> normals;
  std::vector<std::array<std::uint32_t, 3>> triangles;

  /// Adds the polygon `corners` as a triangle fan; false on an out-of-range index.
  bool addPolygon(const std::vector<std::int64_t>& corners) {
    for (std::int64_t c : corners)
      if (c < 0 || c >= static_cast<std::int64_t>(vertices.size())) return false;
    for (std::size_t k = 1; k + 1 < corners.size(); ++k)
      triangles.push_back({static_cast<std::uint32_t>(corners[0]),
                           static_cast<std::uint32_t>(corners[k]),
                           static_cast<std::uint32_t>(corners[k + 1])});
    return true;
  }

  TriangleMesh finish(const std::string& frame_id) {
    TriangleMesh mesh;
    mesh.frame_id = frame_id;
    if (normals.size() == vertices.size()) {
      for (Eigen::Vector3f& n : normals)
        if (n.norm() > 0) n.normalize();
      mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
    }
    mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
    mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
    return mesh;
  }
};

Result<TriangleMesh> loadObj(std::istream& file, const std::string& path,
                             const std::string& frame_id, double scale) {
  Builder b;
  std::string line;
  int line_number = 0;
  std::vector<std::int64_t> corners;
  while (std::getline(file, line)) {
    ++line_number;
    const std::string where = path + ":" + std::to_string(line_number);
    std::istringstream in(line);
    std::string tag;
    if (!(in >> tag) || tag[0] == '#') continue;
    if (tag == "v") {
      double x, y, z;
      if (!(in >> x >> y >> z) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        return corrupt(where, "vertex '" + line + "' lacks three finite coordinates");
      b.vertices.emplace_back(static_cast<float>(x * scale), static_cast<float>(y * scale),
                              static_cast<float>(z * scale));
    } else if (tag == "f") {
      corners.clear();
      std::string corner;
      while (in >> corner) {
        // "v", "v/vt", "v//vn" or "v/vt/vn": the vertex index comes first; negative counts back.
        char* end = nullptr;
        const long long index = std::strtoll(corner.c_str(), &end, 10);
        if (end == corner.c_str() || index == 0 || (*end != '\0' && *end != '/'))
          return corrupt(where, "face corner '" + corner + "' is not a vertex index");
        corners.push_back(index > 0 ? index - 1
                                    : static_cast<std::int64_t>(b.vertices.size()) + index);
      }
      if (corners.size() < 3)
        return corrupt(
            where, "face has " + std::to_string(corners.size()) + " corners; expected at least 3");
      if (!b.addPolygon(corners))
        return corrupt(where, "face uses a vertex that is not defined before it (" +
                                  std::to_string(b.vertices.size()) + " vertices so far)");
    }
    // vt, vn, g, o, s, usemtl, mtllib...: not needed for the geometry.
  }
  return b.finish(frame_id);
}

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool parsePlyType(const std::string& name, PlyType& type) {
  static const std::pair<const char*, PlyType> kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [n, t] : kNames)
    if (name == n) {
      type = t;
      return true;
    }
  return false;
}

std::size_t plySize(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;
  bool list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

// Reads one scalar of a PLY body, ascii or binary.
class PlyReader {
 public:
  PlyReader(std::istream& in, bool ascii, bool big_endian, std::string path)
      : in_(in),
        ascii_(ascii),
        swap_(big_endian != (std::endian::native == std::endian::big)),
        path_(std::move(path)) {}

  bool read(PlyType type, double& value) {
    if (ascii_) return static_cast<bool>(in_ >> value);
    unsigned char bytes[8];
    const std::size_t n = plySize(type);
    if (!in_.read(reinterpret_cast<char*>(bytes), static_cast<std::streamsize>(n))) return false;
    if (swap_) std::reverse(bytes, bytes + n);
    switch (type) {
      case PlyType::kInt8:
        value = static_cast<std::int8_t>(bytes[0]);
        break;
      case PlyType::kUint8:
        value = bytes[0];
        break;
      case PlyType::kInt16:
        value = load<std::int16_t>(bytes);
        break;
      case PlyType::kUint16:
        value = load<std::uint16_t>(bytes);
        break;
      case PlyType::kInt32:
        value = load<std::int32_t>(bytes);
        break;
      case PlyType::kUint32:
        value = load<std::uint32_t>(bytes);
        break;
      case PlyType::kFloat32:
        value = load<float>(bytes);
        break;
      case PlyType::kFloat64:
        value = load<double>(bytes);
        break;
    }
    return true;
  }

  std::string where() {
    if (ascii_) return path_ + ": element data";
    return path_ + ": byte " + std::to_string(static_cast<long long>(in_.tellg()));
  }

 private:
  template <typename T>
  static T load(const unsigned char* bytes) {
    T v;
    std::memcpy(&v, bytes, sizeof(T));
    return v;
  }

  std::istream& in_;
  bool ascii_;
  bool swap_;
  std::string path_;
};

Result<TriangleMesh> loadPly(std::istream& file, const std::string& path,
                             const std::string& frame_id, double scale) {
  std::string line;
  int line_number = 0;
  auto where = [&] { return path + ":" + std::to_string(line_number); };
  if (!std::getline(file, line) || (++line_number, line.rfind("ply", 0) != 0))
    return corrupt(path + ":1", "does not start with 'ply'; expected a PLY file");
  std::string format;
  std::vector<PlyElement> elements;
  while (true) {
    if (!std::getline(file, line)) return corrupt(where(), "the header ends without 'end_header'");
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream in(line);
    std::string word;
    in >> word;
    if (word == "end_header") break;
    if (word == "comment" || word == "obj_info" || word.empty()) continue;
    if (word == "format") {
      in >> format;
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
        return corrupt(where(), "format '" + format +
                                    "'; expected ascii, binary_little_endian or binary_big_endian");
    } else if (word == "element") {
      PlyElement e;
      long long count = -1;
      if (!(in >> e.name >> count) || count < 0)
        return corrupt(where(), "'" + line + "' is not 'element <name> <count>'");
      e.count = static_cast<std::size_t>(count);
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) return corrupt(where(), "a property before any element");
      PlyProperty p;
      std::string type;
      in >> type;
      if (type == "list") {
        std::string count_type, item_type;
        in >> count_type >> item_type >> p.name;
        p.list = true;
        if (!parsePlyType(count_type, p.count_type) || !parsePlyType(item_type, p.type))
          return corrupt(where(), "unknown list types in '" + line + "'");
      } else {
        in >> p.name;
        if (!parsePlyType(type, p.type)) return corrupt(where(), "unknown type '" + type + "'");
      }
      elements.back().properties.push_back(p);
    } else {
      return corrupt(where(), "unexpected header line '" + line + "'");
    }
  }
  if (format.empty()) return corrupt(where(), "the header has no 'format' line");
  PlyReader reader(file, format == "ascii", format == "binary_big_endian", path);
  Builder b;
  std::vector<std::int64_t> corners;
  for (const PlyElement& e : elements) {
    const bool is_vertex = e.name == "vertex";
    const bool is_face = e.name == "face";
    int xyz[3] = {-1, -1, -1}, nxyz[3] = {-1, -1, -1}, indices = -1;
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const std::string& n = e.properties[k].name;
      for (int a = 0; a < 3; ++a) {
        if (n == std::string(1, "xyz"[a])) xyz[a] = static_cast<int>(k);
        if (n == std::string("n") + "xyz"[a]) nxyz[a] = static_cast<int>(k);
      }
      if (e.properties[k].list && (n == "vertex_indices" || n == "vertex_index"))
        indices = static_cast<int>(k);
    }
    if (is_vertex && (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0))
      return corrupt(path, "element 'vertex' lacks one of the properties x, y, z");
    if (is_face && indices < 0)
      return corrupt(path, "element 'face' lacks a 'vertex_indices' list");
    const bool has_normals = is_vertex && nxyz[0] >= 0 && nxyz[1] >= 0 && nxyz[2] >= 0;
    std::vector<double> values(e.properties.size());
    for (std::size_t item = 0; item < e.count; ++item) {
      corners.clear();
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& p = e.properties[k];
        if (!p.list) {
          if (!reader.read(p.type, values[k]))
            return corrupt(reader.where(), "the file ends inside element '" + e.name + "' " +
                                               std::to_string(item) + " of " +
                                               std::to_string(e.count));
          continue;
        }
        double count = 0;
        if (!reader.read(p.count_type, count) || count < 0 || count > 1e6)
          return corrupt(reader.where(),
                         "bad list length in element '" + e.name + "' " + std::to_string(item));
        for (int c = 0; c < static_cast<int>(count); ++c) {
          double index = 0;
          if (!reader.read(p.type, index))
            return corrupt(reader.where(),
                           "the file ends inside element '" + e.name + "' " + std::to_string(item));
          if (static_cast<int>(k) == indices) corners.push_back(static_cast<std::int64_t>(index));
        }
      }
      if (is_vertex) {
        const Eigen::Vector3d p(values[xyz[0]], values[xyz[1]], values[xyz[2]]);
        if (!p.allFinite())
          return corrupt(reader.where(), "vertex " + std::to_string(item) + " is not finite");
        b.vertices.push_back((p * scale).cast<float>());
        if (has_normals)
          b.normals.emplace_back(static_cast<float>(values[nxyz[0]]),
                                 static_cast<float>(values[nxyz[1]]),
                                 static_cast<float>(values[nxyz[2]]));
      } else if (is_face) {
        if (corners.size() < 3)
          return corrupt(reader.where(), "face " + std::to_string(item) + " has " +
                                             std::to_string(corners.size()) +
                                             " corners; expected at least 3");
        if (!b.addPolygon(corners))
          return corrupt(reader.where(), "face " + std::to_string(item) +
                                             " uses a vertex index outside [0, " +
                                             std::to_string(b.vertices.size()) + ")");
      }
    }
  }
  return b.finish(frame_id);
}

}  // namespace

Result<TriangleMesh> loadMesh(const std::string& path, const std::string& frame_id, double scale) {
  std::error_code error;
  if (!std::filesystem::exists(path, error))
    return notFound("mesh file '{}' does not exist; expected a .obj or .ply file", path);
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension != ".obj" && extension != ".ply")
    return invalidInput("mesh file '{}' has the extension '{}'; expected .obj or .ply", path,
                        extension);
  if (!(scale > 0) || !std::isfinite(scale))
    return invalidInput("mesh scale {} for '{}'; expected a positive finite factor", scale, path);
  std::ifstream file(path, std::ios::binary);
  if (!file) return ioError("cannot open mesh file '{}': {}", path, std::strerror(errno));
  Result<TriangleMesh> mesh = extension == ".obj" ? loadObj(file, path, frame_id, scale)
                                                  : loadPly(file, path, frame_id, scale);
  if (!mesh) return mesh;
  CDFF_RETURN_IF_ERROR(mesh->validate(("mesh file '" + path + "'").c_str()));
  return mesh;
}

}  // namespace cdff
