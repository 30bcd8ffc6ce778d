// The PLY mesh and point-cloud loaders: ascii, binary little and big endian.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <map>
#include <optional>

#include "cdff/egse/model_import_common.hpp"
#include "cdff/egse/model_io.hpp"

namespace cdff::egse {

using mesh_import::checkOptions;
using mesh_import::corrupt;
using mesh_import::finish;
using mesh_import::LineReader;
using mesh_import::MaterialTable;
using mesh_import::parseDouble;
using mesh_import::parseLong;
using mesh_import::readWholeFile;
using mesh_import::tokens;

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
  std::map<std::size_t, std::string> part_names;      // from "comment cdff_part i name"
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
      if (t.size() >= 4 && t[1] == "cdff_part") {
        long long index;
        if (parseLong(t[2], index) && index >= 0 && index < 65536)
          header.part_names[static_cast<std::size_t>(index)] = std::string(t[3]);
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

// Where a mesh's element keeps what the loader reads: the vertex coordinates, the face's vertex
// list and its material (-1 where the element has no such property).
struct PlyMeshProperties {
  int x = -1, y = -1, z = -1, face = -1, material = -1, part = -1;

  explicit PlyMeshProperties(const PlyElement& element) {
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const auto& name = element.properties[p].name;
      if (name == "x") x = static_cast<int>(p);
      if (name == "y") y = static_cast<int>(p);
      if (name == "z") z = static_cast<int>(p);
      if ((name == "vertex_indices" || name == "vertex_index") && element.properties[p].is_list)
        face = static_cast<int>(p);
      if (name == "material" || name == "material_index") material = static_cast<int>(p);
      if (name == "part") part = static_cast<int>(p);
    }
  }
};

// The mesh read so far.
struct PlyMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::size_t> raw_material;  // per triangle, the file's material index
  std::vector<std::size_t> raw_part;      // per triangle, the file's part index (0 without)
};

// Reads instance i of `element` (a vertex, a face, or anything else, skipped) into `mesh`.
Status readPlyMeshElement(PlyBody& body, const PlyElement& element, std::size_t i,
                          const PlyMeshProperties& at, PlyMesh& mesh) {
  const bool is_vertex = element.name == "vertex";
  const bool is_face = element.name == "face";
  body.setContext(fmt::format("{} {}", element.name, i));
  Eigen::Vector3f p = Eigen::Vector3f::Zero();
  std::vector<std::uint32_t> face;
  std::size_t material = 0, part = 0;
  for (std::size_t k = 0; k < element.properties.size(); ++k) {
    const PlyProperty& prop = element.properties[k];
    if (prop.is_list) {
      double count;
      CDFF_RETURN_IF_ERROR(body.read(prop.count_type, count));
      if (count < 0 || count > 1e6)
        return corrupt(fmt::format("{}: {} {} has a list of {} entries", body.where(), element.name,
                                   i, count));
      for (int j = 0; j < static_cast<int>(count); ++j) {
        double value;
        CDFF_RETURN_IF_ERROR(body.read(prop.type, value));
        if (is_face && static_cast<int>(k) == at.face) {
          if (value < 0 || value >= static_cast<double>(mesh.positions.size()))
            return corrupt(fmt::format("{}: face {} uses vertex {}; expected an index < {}",
                                       body.where(), i, value, mesh.positions.size()));
          face.push_back(static_cast<std::uint32_t>(value));
        }
      }
    } else {
      double value;
      CDFF_RETURN_IF_ERROR(body.read(prop.type, value));
      if (is_vertex) {
        if (!std::isfinite(value))
          return corrupt(fmt::format("{}: vertex {} has a non-finite coordinate", body.where(), i));
        if (static_cast<int>(k) == at.x) p.x() = static_cast<float>(value);
        if (static_cast<int>(k) == at.y) p.y() = static_cast<float>(value);
        if (static_cast<int>(k) == at.z) p.z() = static_cast<float>(value);
      }
      if (is_face && static_cast<int>(k) == at.material && value >= 0)
        material = static_cast<std::size_t>(value);
      if (is_face && static_cast<int>(k) == at.part && value >= 0)
        part = static_cast<std::size_t>(value);
    }
  }
  CDFF_RETURN_IF_ERROR(body.endElement());
  if (is_vertex) mesh.positions.push_back(p);
  if (is_face) {
    if (face.size() < 3)
      return corrupt(fmt::format("{}: face {} has {} vertices; expected at least 3", body.where(),
                                 i, face.size()));
    for (std::size_t j = 1; j + 1 < face.size(); ++j) {
      mesh.triangles.push_back({face[0], face[j], face[j + 1]});
      mesh.raw_material.push_back(material);
      mesh.raw_part.push_back(part);
    }
  }
  return Status::ok();
}

}  // namespace

Result<TargetModel> loadPly(const std::filesystem::path& path, const MeshLoadOptions& options) {
  CDFF_RETURN_IF_ERROR(checkOptions(options, path));
  auto text = readWholeFile(path);
  if (!text) return text.status();
  const std::string file = path.string();
  auto header = parsePlyHeader(*text, file);
  if (!header) return header.status();
  PlyMesh mesh;
  std::vector<std::uint16_t> triangle_material;
  PlyBody body(*text, *header, file);
  bool have_vertices = false;
  for (const PlyElement& element : header->elements) {
    const bool is_vertex = element.name == "vertex";
    const bool is_face = element.name == "face";
    const PlyMeshProperties at(element);
    if (is_vertex && (at.x < 0 || at.y < 0 || at.z < 0))
      return corrupt(fmt::format("{}: the vertex element lacks x, y or z properties", file));
    if (is_face && at.face < 0)
      return corrupt(fmt::format("{}: the face element lacks a 'vertex_indices' list", file));
    if (is_face && !have_vertices)
      return corrupt(fmt::format("{}: the face element comes before the vertex element", file));
    for (std::size_t i = 0; i < element.count; ++i)
      CDFF_RETURN_IF_ERROR(readPlyMeshElement(body, element, i, at, mesh));
    if (is_vertex) have_vertices = true;
  }
  MaterialTable table(options.default_material);
  for (std::size_t m : mesh.raw_material) {
    auto it = header->material_names.find(m);
    triangle_material.push_back(table.index(it != header->material_names.end() ? it->second : ""));
  }
  auto model = finish(path.stem().string(), std::move(mesh.positions), mesh.triangles,
                      triangle_material, table.take(), options, path);
  if (!model || header->part_names.empty()) return model;
  // The named parts of a PLY written by cdff (writePly): a part without a name comment gets
  // part_<index>.
  for (std::size_t p : mesh.raw_part)
    if (!header->part_names.contains(p)) header->part_names[p] = fmt::format("part_{}", p);
  std::map<std::size_t, std::uint16_t> index;
  for (const auto& [p, name] : header->part_names) {
    index[p] = static_cast<std::uint16_t>(model->parts.size());
    model->parts.push_back(name);
  }
  for (std::size_t p : mesh.raw_part) model->triangle_part.push_back(index[p]);
  CDFF_RETURN_IF_ERROR(model->validate().withContext(file));
  return model;
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

}  // namespace cdff::egse
