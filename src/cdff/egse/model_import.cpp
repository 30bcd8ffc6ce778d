// Loaders of user meshes: OBJ, PLY (ascii, binary little and big endian), STL (ascii, binary),
// glTF 2.0 (.gltf with embedded or external buffers, .glb).
#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "cdff/egse/model_io.hpp"

namespace cdff::egse {

namespace {

Status corrupt(const std::string& message) {
  return {StatusCode::kCorruptData, message};
}

Result<std::string> readWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return ioError("cannot open '{}': {}", path.string(), std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Splits a line into whitespace-separated tokens.
std::vector<std::string_view> tokens(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const std::size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

bool parseDouble(std::string_view s, double& value) {
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(value);
}

bool parseLong(std::string_view s, long long& value) {
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  return ec == std::errc() && ptr == s.data() + s.size();
}

// Iterates over lines keeping the 1-based line number.
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t end = text_.find('\n', pos_);
    const std::size_t stop = end == std::string_view::npos ? text_.size() : end;
    line = text_.substr(pos_, stop - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = stop + 1;
    ++line_;
    return true;
  }
  int line() const { return line_; }
  std::size_t offset() const { return pos_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  int line_ = 0;
};

void applyOptions(std::vector<Eigen::Vector3f>& positions, const MeshLoadOptions& options) {
  for (auto& p : positions) p *= static_cast<float>(options.scale);
  if (options.recentre && !positions.empty()) {
    Eigen::AlignedBox3f box;
    for (const auto& p : positions) box.extend(p);
    const Eigen::Vector3f c = box.center();
    for (auto& p : positions) p -= c;
  }
}

Status checkOptions(const MeshLoadOptions& options, const std::filesystem::path& path) {
  if (!std::isfinite(options.scale) || options.scale <= 0)
    return invalidParameter("loading '{}': scale = {} is invalid; expected > 0", path.string(),
                            options.scale);
  return Status::ok();
}

Material materialFromColour(const std::string& name, const Eigen::Vector3f& diffuse,
                            const Eigen::Vector3f& specular, float shininess) {
  Material m = builtinMaterial(MaterialId::kStructure);
  m.name = name;
  m.diffuse = diffuse;
  m.specular = specular;
  m.shininess = std::max(1.0f, shininess);
  m.pattern = SurfacePattern::kNone;
  m.lidar_reflectivity = std::clamp(diffuse.mean() + 0.1f, 0.05f, 1.0f);
  return m;
}

// Finds or adds the material called `name`: a built-in one when the name matches, else the one
// described by the file (if any), else a copy of the default material under that name.
class MaterialTable {
 public:
  explicit MaterialTable(MaterialId fallback) : fallback_(fallback) {}
  std::uint16_t index(const std::string& name, const Material* described = nullptr) {
    auto it = by_name_.find(name);
    if (it != by_name_.end()) return it->second;
    Material m;
    if (auto builtin = builtinMaterialByName(name)) {
      m = builtinMaterial(*builtin);
    } else if (described) {
      m = *described;
    } else {
      m = builtinMaterial(fallback_);
      if (!name.empty()) m.name = name;
    }
    materials_.push_back(m);
    const auto i = static_cast<std::uint16_t>(materials_.size() - 1);
    by_name_[name] = i;
    return i;
  }
  std::vector<Material> take() {
    if (materials_.empty()) materials_.push_back(builtinMaterial(fallback_));
    return std::move(materials_);
  }

 private:
  MaterialId fallback_;
  std::map<std::string, std::uint16_t> by_name_;
  std::vector<Material> materials_;
};

}  // namespace

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

Result<TargetModel> finish(std::string name, std::vector<Eigen::Vector3f> positions,
                           const std::vector<std::array<std::uint32_t, 3>>& triangles,
                           const std::vector<std::uint16_t>& materials_of_triangles,
                           std::vector<Material> materials, const MeshLoadOptions& options,
                           const std::filesystem::path& path) {
  if (triangles.empty())
    return corrupt(fmt::format("'{}' holds no triangles; expected a mesh", path.string()));
  applyOptions(positions, options);
  TargetModel model =
      buildModelFromTriangles(std::move(name), positions, triangles, materials_of_triangles,
                              std::move(materials), options.smoothing_angle);
  CDFF_RETURN_IF_ERROR(model.validate().withContext(path.string()));
  return model;
}

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

// ----------------------------------------------------------------------------------- PLY

namespace {

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::optional<PlyType> plyType(std::string_view name) {
  static const std::map<std::string, PlyType, std::less<>> types = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  auto it = types.find(name);
  if (it == types.end()) return std::nullopt;
  return it->second;
}

int plySize(PlyType t) {
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
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  std::map<std::size_t, std::string> material_names;  // from "comment cdff_material i name"
  std::size_t body_offset = 0;
  int body_line = 0;
};

Result<PlyHeader> parsePlyHeader(const std::string& text, const std::string& file) {
  PlyHeader header;
  LineReader reader(text);
  std::string_view line;
  if (!reader.next(line) || line != "ply")
    return corrupt(fmt::format("{}:1: not a PLY file; expected the magic line 'ply'", file));
  bool have_format = false;
  while (true) {
    if (!reader.next(line))
      return corrupt(
          fmt::format("{}:{}: the header ends before 'end_header'", file, reader.line()));
    const int ln = reader.line();
    const auto t = tokens(line);
    if (t.empty()) continue;
    if (t[0] == "end_header") break;
    if (t[0] == "comment" || t[0] == "obj_info") {
      if (t.size() >= 4 && t[1] == "cdff_material") {
        long long index;
        if (parseLong(t[2], index) && index >= 0)
          header.material_names[static_cast<std::size_t>(index)] = std::string(t[3]);
      }
      continue;
    }
    if (t[0] == "format") {
      if (t.size() != 3)
        return corrupt(fmt::format("{}:{}: malformed format line '{}'", file, ln, line));
      if (t[1] == "ascii")
        header.format = PlyFormat::kAscii;
      else if (t[1] == "binary_little_endian")
        header.format = PlyFormat::kBinaryLittle;
      else if (t[1] == "binary_big_endian")
        header.format = PlyFormat::kBinaryBig;
      else
        return corrupt(
            fmt::format("{}:{}: unknown PLY format '{}'; expected ascii, "
                        "binary_little_endian or binary_big_endian",
                        file, ln, t[1]));
      have_format = true;
    } else if (t[0] == "element") {
      long long count;
      if (t.size() != 3 || !parseLong(t[2], count) || count < 0)
        return corrupt(fmt::format(
            "{}:{}: malformed element line '{}'; expected 'element NAME COUNT'", file, ln, line));
      header.elements.push_back({std::string(t[1]), static_cast<std::size_t>(count), {}});
    } else if (t[0] == "property") {
      if (header.elements.empty())
        return corrupt(fmt::format("{}:{}: property before any element", file, ln));
      PlyProperty p;
      if (t.size() == 5 && t[1] == "list") {
        auto ct = plyType(t[2]);
        auto it = plyType(t[3]);
        if (!ct || !it)
          return corrupt(fmt::format("{}:{}: unknown property type in '{}'", file, ln, line));
        p.is_list = true;
        p.count_type = *ct;
        p.type = *it;
        p.name = std::string(t[4]);
      } else if (t.size() == 3) {
        auto type = plyType(t[1]);
        if (!type) return corrupt(fmt::format("{}:{}: unknown property type '{}'", file, ln, t[1]));
        p.type = *type;
        p.name = std::string(t[2]);
      } else {
        return corrupt(fmt::format("{}:{}: malformed property line '{}'", file, ln, line));
      }
      header.elements.back().properties.push_back(p);
    } else {
      return corrupt(fmt::format("{}:{}: unexpected header line '{}'", file, ln, line));
    }
  }
  if (!have_format) return corrupt(fmt::format("{}: the PLY header has no 'format' line", file));
  header.body_offset = reader.offset();
  header.body_line = reader.line();
  return header;
}

// Reads numbers from a PLY body, ascii or binary, keeping the position for error messages.
class PlyBody {
 public:
  PlyBody(const std::string& text, const PlyHeader& header, std::string file)
      : text_(text),
        format_(header.format),
        pos_(header.body_offset),
        line_(header.body_line + 1),
        file_(std::move(file)) {}

  Status read(PlyType type, double& value) {
    if (format_ == PlyFormat::kAscii) return readAscii(value);
    const int size = plySize(type);
    if (pos_ + size > text_.size())
      return corrupt(fmt::format("{}: byte {}: the file ends inside {}; expected {} more bytes",
                                 file_, pos_, context_, pos_ + size - text_.size()));
    unsigned char bytes[8];
    std::memcpy(bytes, text_.data() + pos_, size);
    const bool big = format_ == PlyFormat::kBinaryBig;
    if (big != (std::endian::native == std::endian::big)) std::reverse(bytes, bytes + size);
    pos_ += size;
    switch (type) {
      case PlyType::kInt8: {
        std::int8_t v;
        std::memcpy(&v, bytes, 1);
        value = v;
        break;
      }
      case PlyType::kUint8: {
        std::uint8_t v;
        std::memcpy(&v, bytes, 1);
        value = v;
        break;
      }
      case PlyType::kInt16: {
        std::int16_t v;
        std::memcpy(&v, bytes, 2);
        value = v;
        break;
      }
      case PlyType::kUint16: {
        std::uint16_t v;
        std::memcpy(&v, bytes, 2);
        value = v;
        break;
      }
      case PlyType::kInt32: {
        std::int32_t v;
        std::memcpy(&v, bytes, 4);
        value = v;
        break;
      }
      case PlyType::kUint32: {
        std::uint32_t v;
        std::memcpy(&v, bytes, 4);
        value = v;
        break;
      }
      case PlyType::kFloat32: {
        float v;
        std::memcpy(&v, bytes, 4);
        value = v;
        break;
      }
      case PlyType::kFloat64: {
        double v;
        std::memcpy(&v, bytes, 8);
        value = v;
        break;
      }
    }
    return Status::ok();
  }
  // Ascii elements are one per line; the next element must start on a new line.
  Status endElement() {
    if (format_ != PlyFormat::kAscii) return Status::ok();
    while (pos_ < text_.size() && text_[pos_] != '\n') {
      if (!std::isspace(static_cast<unsigned char>(text_[pos_])))
        return corrupt(fmt::format("{}:{}: extra values after {}", file_, line_, context_));
      ++pos_;
    }
    if (pos_ < text_.size()) {
      ++pos_;
      ++line_;
    }
    return Status::ok();
  }
  void setContext(std::string context) { context_ = std::move(context); }
  std::string where() const {
    return format_ == PlyFormat::kAscii ? fmt::format("{}:{}", file_, line_)
                                        : fmt::format("{}: byte {}", file_, pos_);
  }

 private:
  Status readAscii(double& value) {
    while (pos_ < text_.size() &&
           (text_[pos_] == ' ' || text_[pos_] == '\t' || text_[pos_] == '\r'))
      ++pos_;
    if (pos_ >= text_.size() || text_[pos_] == '\n')
      return corrupt(fmt::format("{}:{}: {} has too few values", file_, line_, context_));
    std::size_t end = pos_;
    while (end < text_.size() && !std::isspace(static_cast<unsigned char>(text_[end]))) ++end;
    const std::string_view token(text_.data() + pos_, end - pos_);
    if (!parseDouble(token, value))
      return corrupt(
          fmt::format("{}:{}: '{}' in {} is not a number", file_, line_, token, context_));
    pos_ = end;
    return Status::ok();
  }

  const std::string& text_;
  PlyFormat format_;
  std::size_t pos_;
  int line_;
  std::string file_;
  std::string context_;
};

}  // namespace

Result<TargetModel> loadPly(const std::filesystem::path& path, const MeshLoadOptions& options) {
  CDFF_RETURN_IF_ERROR(checkOptions(options, path));
  auto text = readWholeFile(path);
  if (!text) return text.status();
  const std::string file = path.string();
  auto header = parsePlyHeader(*text, file);
  if (!header) return header.status();
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint16_t> triangle_material;
  std::vector<std::size_t> raw_material;  // per triangle, the file's material index
  PlyBody body(*text, *header, file);
  bool have_vertices = false;
  for (const PlyElement& element : header->elements) {
    const bool is_vertex = element.name == "vertex";
    const bool is_face = element.name == "face";
    int ix = -1, iy = -1, iz = -1, ifaces = -1, imaterial = -1;
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const auto& name = element.properties[p].name;
      if (name == "x") ix = static_cast<int>(p);
      if (name == "y") iy = static_cast<int>(p);
      if (name == "z") iz = static_cast<int>(p);
      if ((name == "vertex_indices" || name == "vertex_index") && element.properties[p].is_list)
        ifaces = static_cast<int>(p);
      if (name == "material" || name == "material_index") imaterial = static_cast<int>(p);
    }
    if (is_vertex && (ix < 0 || iy < 0 || iz < 0))
      return corrupt(fmt::format("{}: the vertex element lacks x, y or z properties", file));
    if (is_face && ifaces < 0)
      return corrupt(fmt::format("{}: the face element lacks a 'vertex_indices' list", file));
    if (is_face && !have_vertices)
      return corrupt(fmt::format("{}: the face element comes before the vertex element", file));
    for (std::size_t i = 0; i < element.count; ++i) {
      body.setContext(fmt::format("{} {}", element.name, i));
      Eigen::Vector3f p = Eigen::Vector3f::Zero();
      std::vector<std::uint32_t> face;
      std::size_t material = 0;
      for (std::size_t k = 0; k < element.properties.size(); ++k) {
        const PlyProperty& prop = element.properties[k];
        if (prop.is_list) {
          double count;
          CDFF_RETURN_IF_ERROR(body.read(prop.count_type, count));
          if (count < 0 || count > 1e6)
            return corrupt(fmt::format("{}: {} {} has a list of {} entries", body.where(),
                                       element.name, i, count));
          for (int j = 0; j < static_cast<int>(count); ++j) {
            double value;
            CDFF_RETURN_IF_ERROR(body.read(prop.type, value));
            if (is_face && static_cast<int>(k) == ifaces) {
              if (value < 0 || value >= static_cast<double>(positions.size()))
                return corrupt(fmt::format("{}: face {} uses vertex {}; expected an index < {}",
                                           body.where(), i, value, positions.size()));
              face.push_back(static_cast<std::uint32_t>(value));
            }
          }
        } else {
          double value;
          CDFF_RETURN_IF_ERROR(body.read(prop.type, value));
          if (is_vertex) {
            if (!std::isfinite(value))
              return corrupt(
                  fmt::format("{}: vertex {} has a non-finite coordinate", body.where(), i));
            if (static_cast<int>(k) == ix) p.x() = static_cast<float>(value);
            if (static_cast<int>(k) == iy) p.y() = static_cast<float>(value);
            if (static_cast<int>(k) == iz) p.z() = static_cast<float>(value);
          }
          if (is_face && static_cast<int>(k) == imaterial && value >= 0)
            material = static_cast<std::size_t>(value);
        }
      }
      CDFF_RETURN_IF_ERROR(body.endElement());
      if (is_vertex) positions.push_back(p);
      if (is_face) {
        if (face.size() < 3)
          return corrupt(fmt::format("{}: face {} has {} vertices; expected at least 3",
                                     body.where(), i, face.size()));
        for (std::size_t j = 1; j + 1 < face.size(); ++j) {
          triangles.push_back({face[0], face[j], face[j + 1]});
          raw_material.push_back(material);
        }
      }
    }
    if (is_vertex) have_vertices = true;
  }
  MaterialTable table(options.default_material);
  for (std::size_t m : raw_material) {
    auto it = header->material_names.find(m);
    triangle_material.push_back(table.index(it != header->material_names.end() ? it->second : ""));
  }
  return finish(path.stem().string(), std::move(positions), triangles, triangle_material,
                table.take(), options, path);
}

Result<PointCloud> readPointCloudPly(const std::filesystem::path& path) {
  auto text = readWholeFile(path);
  if (!text) return text.status();
  const std::string file = path.string();
  auto header = parsePlyHeader(*text, file);
  if (!header) return header.status();
  std::vector<Point4f> points, normals;
  std::vector<float> intensity;
  PlyBody body(*text, *header, file);
  for (const PlyElement& element : header->elements) {
    std::map<std::string, int> index;
    for (std::size_t p = 0; p < element.properties.size(); ++p)
      index[element.properties[p].name] = static_cast<int>(p);
    const bool is_vertex = element.name == "vertex";
    if (is_vertex && (!index.count("x") || !index.count("y") || !index.count("z")))
      return corrupt(fmt::format("{}: the vertex element lacks x, y or z properties", file));
    const bool has_normals = index.count("nx") && index.count("ny") && index.count("nz");
    const bool has_intensity = index.count("intensity");
    for (std::size_t i = 0; i < element.count; ++i) {
      body.setContext(fmt::format("{} {}", element.name, i));
      std::vector<double> values(element.properties.size(), 0.0);
      for (std::size_t k = 0; k < element.properties.size(); ++k) {
        const PlyProperty& prop = element.properties[k];
        if (prop.is_list) {
          double count;
          CDFF_RETURN_IF_ERROR(body.read(prop.count_type, count));
          for (int j = 0; j < static_cast<int>(count); ++j) {
            double ignored;
            CDFF_RETURN_IF_ERROR(body.read(prop.type, ignored));
          }
        } else {
          CDFF_RETURN_IF_ERROR(body.read(prop.type, values[k]));
        }
      }
      CDFF_RETURN_IF_ERROR(body.endElement());
      if (!is_vertex) continue;
      points.emplace_back(static_cast<float>(values[index["x"]]),
                          static_cast<float>(values[index["y"]]),
                          static_cast<float>(values[index["z"]]));
      if (has_normals) {
        Point4f n(static_cast<float>(values[index["nx"]]), static_cast<float>(values[index["ny"]]),
                  static_cast<float>(values[index["nz"]]));
        n.pad = 0;
        normals.push_back(n);
      }
      if (has_intensity) intensity.push_back(static_cast<float>(values[index["intensity"]]));
    }
  }
  PointCloud cloud;
  cloud.frame_id = "target";
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  cloud.normals = Buffer<Point4f>::fromVector(std::move(normals));
  cloud.intensity = Buffer<float>::fromVector(std::move(intensity));
  return cloud;
}

// ----------------------------------------------------------------------------------- STL

namespace {

// Welds identical positions so that the mesh is connected (STL stores each triangle alone).
std::uint32_t weld(std::unordered_map<std::string, std::uint32_t>& index,
                   std::vector<Eigen::Vector3f>& positions, const Eigen::Vector3f& p) {
  std::string key(reinterpret_cast<const char*>(p.data()), sizeof(float) * 3);
  auto [it, inserted] = index.emplace(std::move(key), static_cast<std::uint32_t>(positions.size()));
  if (inserted) positions.push_back(p);
  return it->second;
}

}  // namespace

Result<TargetModel> loadStl(const std::filesystem::path& path, const MeshLoadOptions& options) {
  CDFF_RETURN_IF_ERROR(checkOptions(options, path));
  auto text = readWholeFile(path);
  if (!text) return text.status();
  const std::string file = path.string();
  const std::string& data = *text;
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::unordered_map<std::string, std::uint32_t> index;
  // Binary STL: an 80-byte header, a uint32 count, 50 bytes per triangle. Some binary files
  // start with "solid" too, so the size decides.
  bool binary = false;
  std::uint32_t count = 0;
  if (data.size() >= 84) {
    std::memcpy(&count, data.data() + 80, 4);
    binary = data.size() == 84 + 50ull * count;
  }
  const bool starts_solid = data.compare(0, 5, "solid") == 0;
  if (binary) {
    for (std::uint32_t t = 0; t < count; ++t) {
      const std::size_t offset = 84 + 50ull * t;
      float values[12];
      std::memcpy(values, data.data() + offset, sizeof(values));
      std::array<std::uint32_t, 3> tri;
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3f p(values[3 + 3 * k], values[4 + 3 * k], values[5 + 3 * k]);
        if (!p.allFinite())
          return corrupt(fmt::format("{}: byte {}: triangle {} has a non-finite vertex", file,
                                     offset + 12 + 12 * k, t));
        tri[k] = weld(index, positions, p);
      }
      if (tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2]) triangles.push_back(tri);
    }
  } else if (starts_solid) {
    LineReader reader(data);
    std::string_view line;
    std::vector<std::uint32_t> loop;
    bool in_loop = false;
    while (reader.next(line)) {
      const auto t = tokens(line);
      if (t.empty()) continue;
      const int ln = reader.line();
      if (t[0] == "vertex") {
        if (!in_loop) return corrupt(fmt::format("{}:{}: 'vertex' outside 'outer loop'", file, ln));
        if (t.size() != 4)
          return corrupt(
              fmt::format("{}:{}: vertex has {} coordinates; expected 3", file, ln, t.size() - 1));
        Eigen::Vector3f p;
        for (int i = 0; i < 3; ++i) {
          double d;
          if (!parseDouble(t[1 + i], d))
            return corrupt(fmt::format("{}:{}: vertex coordinate '{}' is not a finite number", file,
                                       ln, t[1 + i]));
          p[i] = static_cast<float>(d);
        }
        loop.push_back(weld(index, positions, p));
      } else if (t[0] == "outer") {
        in_loop = true;
        loop.clear();
      } else if (t[0] == "endloop") {
        if (loop.size() != 3)
          return corrupt(
              fmt::format("{}:{}: a facet has {} vertices; expected 3", file, ln, loop.size()));
        if (loop[0] != loop[1] && loop[1] != loop[2] && loop[0] != loop[2])
          triangles.push_back({loop[0], loop[1], loop[2]});
        in_loop = false;
      } else if (t[0] == "solid" || t[0] == "facet" || t[0] == "endfacet" || t[0] == "endsolid") {
        continue;
      } else {
        return corrupt(fmt::format("{}:{}: unexpected '{}' in an ascii STL", file, ln, t[0]));
      }
    }
    if (in_loop) return corrupt(fmt::format("{}: the file ends inside a facet", file));
  } else {
    return corrupt(fmt::format(
        "{}: not an STL file: {} bytes, neither 'solid ...' (ascii) nor 84 + 50 x {} bytes "
        "(binary)",
        file, data.size(), count));
  }
  MaterialTable table(options.default_material);
  const std::uint16_t m = table.index("");
  return finish(path.stem().string(), std::move(positions), triangles,
                std::vector<std::uint16_t>(triangles.size(), m), table.take(), options, path);
}

// ---------------------------------------------------------------------------------- glTF

namespace {

Result<std::string> decodeBase64(std::string_view in, const std::string& where) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+' || c == '-') return 62;
    if (c == '/' || c == '_') return 63;
    return -1;
  };
  std::string out;
  out.reserve(in.size() * 3 / 4);
  int bits = 0, buffer = 0;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const char c = in[i];
    if (c == '=') break;
    if (std::isspace(static_cast<unsigned char>(c))) continue;
    const int v = value(c);
    if (v < 0)
      return corrupt(fmt::format("{}: invalid base64 character '{}' at offset {}", where, c, i));
    buffer = (buffer << 6) | v;
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((buffer >> bits) & 0xff));
    }
  }
  return out;
}

class Gltf {
 public:
  Gltf(nlohmann::json doc, std::vector<std::string> buffers, std::string file)
      : doc_(std::move(doc)), buffers_(std::move(buffers)), file_(std::move(file)) {}

  // Reads accessor `index` as `components` doubles per element.
  Status accessor(std::size_t index, int components, std::vector<double>& out, std::size_t& count) {
    const auto& accessors = doc_.value("accessors", nlohmann::json::array());
    if (index >= accessors.size())
      return corrupt(fmt::format("{}: accessor {} does not exist ({} accessors)", file_, index,
                                 accessors.size()));
    const auto& a = accessors[index];
    const std::string where = fmt::format("{}: accessors[{}]", file_, index);
    if (a.contains("sparse"))
      return corrupt(fmt::format("{}: sparse accessors are not supported", where));
    if (!a.contains("bufferView")) return corrupt(fmt::format("{}: has no bufferView", where));
    const int component_type = a.value("componentType", 0);
    count = a.value("count", std::size_t{0});
    const std::string type = a.value("type", std::string());
    const int expected = type == "SCALAR" ? 1
                         : type == "VEC2" ? 2
                         : type == "VEC3" ? 3
                         : type == "VEC4" ? 4
                                          : 0;
    if (expected != components)
      return corrupt(fmt::format("{}: type '{}'; expected {} components", where, type, components));
    int size = 0;
    switch (component_type) {
      case 5120:
      case 5121:
        size = 1;
        break;
      case 5122:
      case 5123:
        size = 2;
        break;
      case 5125:
      case 5126:
        size = 4;
        break;
      default:
        return corrupt(
            fmt::format("{}: componentType {} is not one of 5120-5126", where, component_type));
    }
    const auto& views = doc_.value("bufferViews", nlohmann::json::array());
    const std::size_t view_index = a["bufferView"].get<std::size_t>();
    if (view_index >= views.size())
      return corrupt(fmt::format("{}: bufferView {} does not exist", where, view_index));
    const auto& view = views[view_index];
    const std::size_t buffer = view.value("buffer", std::size_t{0});
    if (buffer >= buffers_.size())
      return corrupt(fmt::format("{}: bufferViews[{}] uses buffer {}, which does not exist", file_,
                                 view_index, buffer));
    const std::size_t view_offset = view.value("byteOffset", std::size_t{0});
    const std::size_t view_length = view.value("byteLength", std::size_t{0});
    const std::size_t stride =
        view.value("byteStride", static_cast<std::size_t>(size * components));
    const std::size_t offset = view_offset + a.value("byteOffset", std::size_t{0});
    const std::string& data = buffers_[buffer];
    if (view_offset + view_length > data.size())
      return corrupt(fmt::format(
          "{}: bufferViews[{}] spans bytes {}..{} of buffer {}, which has {} bytes", file_,
          view_index, view_offset, view_offset + view_length, buffer, data.size()));
    if (count > 0 && offset + (count - 1) * stride + size * components > view_offset + view_length)
      return corrupt(fmt::format("{}: {} elements of stride {} overrun bufferViews[{}] ({} bytes)",
                                 where, count, stride, view_index, view_length));
    out.resize(count * components);
    for (std::size_t e = 0; e < count; ++e)
      for (int c = 0; c < components; ++c) {
        const char* p = data.data() + offset + e * stride + c * size;
        double v = 0;
        switch (component_type) {
          case 5120: {
            std::int8_t x;
            std::memcpy(&x, p, 1);
            v = x;
            break;
          }
          case 5121: {
            std::uint8_t x;
            std::memcpy(&x, p, 1);
            v = x;
            break;
          }
          case 5122: {
            std::int16_t x;
            std::memcpy(&x, p, 2);
            v = x;
            break;
          }
          case 5123: {
            std::uint16_t x;
            std::memcpy(&x, p, 2);
            v = x;
            break;
          }
          case 5125: {
            std::uint32_t x;
            std::memcpy(&x, p, 4);
            v = x;
            break;
          }
          case 5126: {
            float x;
            std::memcpy(&x, p, 4);
            v = x;
            break;
          }
        }
        out[e * components + c] = v;
      }
    return Status::ok();
  }

  const nlohmann::json& doc() const { return doc_; }
  const std::string& file() const { return file_; }

 private:
  nlohmann::json doc_;
  std::vector<std::string> buffers_;
  std::string file_;
};

Eigen::Matrix4d nodeMatrix(const nlohmann::json& node) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (node.contains("matrix")) {
    const auto& v = node["matrix"];
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m(r, c) = v.at(c * 4 + r).get<double>();  // column-major
    return m;
  }
  Eigen::Vector3d t = Eigen::Vector3d::Zero(), s = Eigen::Vector3d::Ones();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  if (node.contains("translation"))
    t = {node["translation"][0].get<double>(), node["translation"][1].get<double>(),
         node["translation"][2].get<double>()};
  if (node.contains("rotation"))  // x, y, z, w
    q = Eigen::Quaterniond(node["rotation"][3].get<double>(), node["rotation"][0].get<double>(),
                           node["rotation"][1].get<double>(), node["rotation"][2].get<double>())
            .normalized();
  if (node.contains("scale"))
    s = {node["scale"][0].get<double>(), node["scale"][1].get<double>(),
         node["scale"][2].get<double>()};
  m.topLeftCorner<3, 3>() = q.toRotationMatrix() * s.asDiagonal();
  m.topRightCorner<3, 1>() = t;
  return m;
}

struct GltfMeshes {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint16_t> triangle_material;
};

Status addGltfMesh(Gltf& gltf, std::size_t mesh_index, const Eigen::Matrix4d& transform,
                   MaterialTable& table, GltfMeshes& out) {
  const auto& meshes = gltf.doc().value("meshes", nlohmann::json::array());
  if (mesh_index >= meshes.size())
    return corrupt(fmt::format("{}: mesh {} does not exist ({} meshes)", gltf.file(), mesh_index,
                               meshes.size()));
  const auto& primitives = meshes[mesh_index].value("primitives", nlohmann::json::array());
  const auto& materials = gltf.doc().value("materials", nlohmann::json::array());
  for (std::size_t p = 0; p < primitives.size(); ++p) {
    const auto& prim = primitives[p];
    const int mode = prim.value("mode", 4);
    if (mode != 4)
      return corrupt(
          fmt::format("{}: meshes[{}].primitives[{}] has mode {}; only triangles (4) are supported",
                      gltf.file(), mesh_index, p, mode));
    if (!prim.contains("attributes") || !prim["attributes"].contains("POSITION"))
      return corrupt(fmt::format("{}: meshes[{}].primitives[{}] has no POSITION attribute",
                                 gltf.file(), mesh_index, p));
    std::vector<double> pos;
    std::size_t count = 0;
    CDFF_RETURN_IF_ERROR(
        gltf.accessor(prim["attributes"]["POSITION"].get<std::size_t>(), 3, pos, count));
    const std::uint32_t base = static_cast<std::uint32_t>(out.positions.size());
    for (std::size_t i = 0; i < count; ++i) {
      const Eigen::Vector4d h =
          transform * Eigen::Vector4d(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2], 1.0);
      out.positions.push_back(h.head<3>().cast<float>());
    }
    std::vector<std::uint32_t> indices;
    if (prim.contains("indices")) {
      std::vector<double> raw;
      std::size_t n = 0;
      CDFF_RETURN_IF_ERROR(gltf.accessor(prim["indices"].get<std::size_t>(), 1, raw, n));
      for (double v : raw) {
        if (v < 0 || v >= static_cast<double>(count))
          return corrupt(
              fmt::format("{}: meshes[{}].primitives[{}] index {} is out of range; expected < {}",
                          gltf.file(), mesh_index, p, v, count));
        indices.push_back(static_cast<std::uint32_t>(v));
      }
    } else {
      for (std::size_t i = 0; i < count; ++i) indices.push_back(static_cast<std::uint32_t>(i));
    }
    if (indices.size() % 3 != 0)
      return corrupt(
          fmt::format("{}: meshes[{}].primitives[{}] has {} indices; expected a multiple of 3",
                      gltf.file(), mesh_index, p, indices.size()));
    std::uint16_t material = 0;
    if (!prim.contains("material")) {
      material = table.index("");
    } else {
      const std::size_t m = prim["material"].get<std::size_t>();
      if (m >= materials.size())
        return corrupt(
            fmt::format("{}: meshes[{}].primitives[{}] uses material {}, which does not exist",
                        gltf.file(), mesh_index, p, m));
      const auto& mat = materials[m];
      const std::string name = mat.value("name", fmt::format("material_{}", m));
      Eigen::Vector3f colour = Eigen::Vector3f::Constant(0.8f);
      float metallic = 1.0f, roughness = 1.0f;
      if (mat.contains("pbrMetallicRoughness")) {
        const auto& pbr = mat["pbrMetallicRoughness"];
        if (pbr.contains("baseColorFactor"))
          for (int c = 0; c < 3; ++c) colour[c] = pbr["baseColorFactor"][c].get<float>();
        metallic = pbr.value("metallicFactor", 1.0f);
        roughness = pbr.value("roughnessFactor", 1.0f);
      }
      // Metal-roughness to Blinn-Phong: metals reflect their colour specularly, dielectrics 4 %.
      const Eigen::Vector3f diffuse = colour * (1.0f - metallic);
      const Eigen::Vector3f specular =
          Eigen::Vector3f::Constant(0.04f) * (1 - metallic) + colour * metallic;
      const float alpha = std::max(roughness * roughness, 1e-3f);
      const float shininess = std::clamp(2.0f / (alpha * alpha) - 2.0f, 1.0f, 2000.0f);
      const Material described = materialFromColour(name, diffuse, specular, shininess);
      material = table.index(name, &described);
    }
    const bool flips = transform.topLeftCorner<3, 3>().determinant() < 0;
    for (std::size_t i = 0; i + 2 < indices.size(); i += 3) {
      std::array<std::uint32_t, 3> tri = {base + indices[i], base + indices[i + 1],
                                          base + indices[i + 2]};
      if (flips) std::swap(tri[1], tri[2]);
      if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
      out.triangles.push_back(tri);
      out.triangle_material.push_back(material);
    }
  }
  return Status::ok();
}

Status addGltfNode(Gltf& gltf, std::size_t node_index, const Eigen::Matrix4d& parent,
                   MaterialTable& table, GltfMeshes& out, int depth) {
  const auto& nodes = gltf.doc().value("nodes", nlohmann::json::array());
  if (node_index >= nodes.size())
    return corrupt(fmt::format("{}: node {} does not exist ({} nodes)", gltf.file(), node_index,
                               nodes.size()));
  if (depth > 64)
    return corrupt(fmt::format("{}: the node hierarchy is deeper than 64 (a cycle?)", gltf.file()));
  const auto& node = nodes[node_index];
  const Eigen::Matrix4d m = parent * nodeMatrix(node);
  if (node.contains("mesh"))
    CDFF_RETURN_IF_ERROR(addGltfMesh(gltf, node["mesh"].get<std::size_t>(), m, table, out));
  for (const auto& child : node.value("children", nlohmann::json::array()))
    CDFF_RETURN_IF_ERROR(addGltfNode(gltf, child.get<std::size_t>(), m, table, out, depth + 1));
  return Status::ok();
}

}  // namespace

Result<TargetModel> loadGltf(const std::filesystem::path& path, const MeshLoadOptions& options) {
  CDFF_RETURN_IF_ERROR(checkOptions(options, path));
  auto text = readWholeFile(path);
  if (!text) return text.status();
  const std::string file = path.string();
  const std::string& data = *text;
  std::string json_text;
  std::string glb_bin;
  bool have_glb_bin = false;
  if (data.size() >= 4 && data.compare(0, 4, "glTF") == 0) {
    // GLB: 12-byte header (magic, version, length), then chunks (length, type, data).
    if (data.size() < 20)
      return corrupt(fmt::format("{}: byte {}: truncated GLB header", file, data.size()));
    std::uint32_t version, length;
    std::memcpy(&version, data.data() + 4, 4);
    std::memcpy(&length, data.data() + 8, 4);
    if (version != 2)
      return corrupt(fmt::format("{}: byte 4: GLB version {}; expected 2", file, version));
    if (length > data.size())
      return corrupt(fmt::format("{}: byte 8: GLB length {} exceeds the file size {}", file, length,
                                 data.size()));
    std::size_t offset = 12;
    while (offset + 8 <= length) {
      std::uint32_t chunk_length, chunk_type;
      std::memcpy(&chunk_length, data.data() + offset, 4);
      std::memcpy(&chunk_type, data.data() + offset + 4, 4);
      if (offset + 8 + chunk_length > length)
        return corrupt(fmt::format("{}: byte {}: chunk of {} bytes runs past the end ({} bytes)",
                                   file, offset, chunk_length, length));
      const std::string chunk = data.substr(offset + 8, chunk_length);
      if (chunk_type == 0x4E4F534Au)
        json_text = chunk;  // "JSON"
      else if (chunk_type == 0x004E4942u) {
        glb_bin = chunk;
        have_glb_bin = true;
      }  // "BIN\0"
      offset += 8 + ((chunk_length + 3) & ~3u);
    }
    if (json_text.empty()) return corrupt(fmt::format("{}: the GLB has no JSON chunk", file));
  } else {
    json_text = data;
  }
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::parse_error& e) {
    // nlohmann counts bytes from 1; offsets here count from 0 like the binary formats.
    return corrupt(
        fmt::format("{}: byte {}: invalid JSON: {}", file, e.byte > 0 ? e.byte - 1 : 0, e.what()));
  }
  try {
    const std::string version =
        doc.contains("asset") ? doc["asset"].value("version", std::string()) : std::string();
    if (version.empty() || version[0] != '2')
      return corrupt(fmt::format("{}: asset.version is '{}'; expected glTF 2.x", file, version));
    std::vector<std::string> buffers;
    const auto& buffer_list = doc.value("buffers", nlohmann::json::array());
    for (std::size_t b = 0; b < buffer_list.size(); ++b) {
      const auto& buffer = buffer_list[b];
      const std::size_t length = buffer.value("byteLength", std::size_t{0});
      std::string bytes;
      if (!buffer.contains("uri")) {
        if (b != 0 || !have_glb_bin)
          return corrupt(
              fmt::format("{}: buffers[{}] has no uri and there is no GLB binary chunk", file, b));
        bytes = glb_bin;
      } else {
        const std::string uri = buffer["uri"].get<std::string>();
        if (uri.rfind("data:", 0) == 0) {
          const std::size_t comma = uri.find(',');
          if (comma == std::string::npos ||
              uri.substr(0, comma).find(";base64") == std::string::npos)
            return corrupt(
                fmt::format("{}: buffers[{}] has a data URI that is not base64", file, b));
          auto decoded = decodeBase64(std::string_view(uri).substr(comma + 1),
                                      fmt::format("{}: buffers[{}]", file, b));
          if (!decoded) return decoded.status();
          bytes = std::move(*decoded);
        } else {
          auto external = readWholeFile(path.parent_path() / uri);
          if (!external)
            return Status(external.status().code(),
                          fmt::format("{}: buffers[{}]: {}", file, b, external.status().message()));
          bytes = std::move(*external);
        }
      }
      if (bytes.size() < length)
        return corrupt(fmt::format("{}: buffers[{}] holds {} bytes; byteLength says {}", file, b,
                                   bytes.size(), length));
      buffers.push_back(std::move(bytes));
    }
    Gltf gltf(doc, std::move(buffers), file);
    MaterialTable table(options.default_material);
    GltfMeshes meshes;
    const auto& scenes = doc.value("scenes", nlohmann::json::array());
    if (!scenes.empty()) {
      const std::size_t scene = doc.value("scene", std::size_t{0});
      if (scene >= scenes.size())
        return corrupt(
            fmt::format("{}: scene {} does not exist ({} scenes)", file, scene, scenes.size()));
      for (const auto& node : scenes[scene].value("nodes", nlohmann::json::array()))
        CDFF_RETURN_IF_ERROR(addGltfNode(gltf, node.get<std::size_t>(), Eigen::Matrix4d::Identity(),
                                         table, meshes, 0));
    } else {
      const auto& mesh_list = doc.value("meshes", nlohmann::json::array());
      for (std::size_t m = 0; m < mesh_list.size(); ++m)
        CDFF_RETURN_IF_ERROR(addGltfMesh(gltf, m, Eigen::Matrix4d::Identity(), table, meshes));
    }
    return finish(path.stem().string(), std::move(meshes.positions), meshes.triangles,
                  meshes.triangle_material, table.take(), options, path);
  } catch (const nlohmann::json::exception& e) {
    return corrupt(fmt::format("{}: malformed glTF: {}", file, e.what()));
  }
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
