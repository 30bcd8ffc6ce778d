// The glTF 2.0 loader: .gltf with embedded (base64) or external buffers, and .glb.
#include <algorithm>
#include <cstring>

#include <nlohmann/json.hpp>

#include "cdff/egse/model_import_common.hpp"
#include "cdff/egse/model_io.hpp"

namespace cdff::egse {

using mesh_import::checkOptions;
using mesh_import::corrupt;
using mesh_import::finish;
using mesh_import::materialFromColour;
using mesh_import::MaterialTable;
using mesh_import::readWholeFile;

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

// The size in bytes of a component of glTF type `component_type` (5120-5126), or 0 for an
// unknown type.
int componentSize(int component_type) {
  switch (component_type) {
    case 5120:
    case 5121:
      return 1;
    case 5122:
    case 5123:
      return 2;
    case 5125:
    case 5126:
      return 4;
    default:
      return 0;
  }
}

// The component of glTF type `component_type` at p (unaligned, little-endian like the host).
double component(int component_type, const char* p) {
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
  return v;
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
    const int size = componentSize(component_type);
    if (size == 0)
      return corrupt(
          fmt::format("{}: componentType {} is not one of 5120-5126", where, component_type));
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
        const double v = component(component_type, p);
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

// The vertex indices of primitive p of mesh `mesh_index` (0, 1, 2... without an index
// accessor), checked against the primitive's `count` vertices.
Status primitiveIndices(Gltf& gltf, const nlohmann::json& prim, std::size_t count,
                        std::size_t mesh_index, std::size_t p,
                        std::vector<std::uint32_t>& indices) {
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
  return Status::ok();
}

// The material of primitive p of mesh `mesh_index`, in `table`: the default one without a
// material, else the glTF material's metal-roughness parameters turned into Blinn-Phong.
Result<std::uint16_t> primitiveMaterial(Gltf& gltf, const nlohmann::json& prim,
                                        std::size_t mesh_index, std::size_t p,
                                        MaterialTable& table) {
  if (!prim.contains("material")) return table.index("");
  const auto& materials = gltf.doc().value("materials", nlohmann::json::array());
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
  return table.index(name, &described);
}

Status addGltfMesh(Gltf& gltf, std::size_t mesh_index, const Eigen::Matrix4d& transform,
                   MaterialTable& table, GltfMeshes& out) {
  const auto& meshes = gltf.doc().value("meshes", nlohmann::json::array());
  if (mesh_index >= meshes.size())
    return corrupt(fmt::format("{}: mesh {} does not exist ({} meshes)", gltf.file(), mesh_index,
                               meshes.size()));
  const auto& primitives = meshes[mesh_index].value("primitives", nlohmann::json::array());
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
    CDFF_RETURN_IF_ERROR(primitiveIndices(gltf, prim, count, mesh_index, p, indices));
    auto material = primitiveMaterial(gltf, prim, mesh_index, p, table);
    if (!material) return material.status();
    const bool flips = transform.topLeftCorner<3, 3>().determinant() < 0;
    for (std::size_t i = 0; i + 2 < indices.size(); i += 3) {
      std::array<std::uint32_t, 3> tri = {base + indices[i], base + indices[i + 1],
                                          base + indices[i + 2]};
      if (flips) std::swap(tri[1], tri[2]);
      if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
      out.triangles.push_back(tri);
      out.triangle_material.push_back(*material);
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

// A .gltf or .glb file's JSON text and, in a .glb, its binary chunk.
struct GltfContainer {
  std::string json_text;
  std::string glb_bin;
  bool have_glb_bin = false;
};

// Splits a GLB: 12-byte header (magic, version, length), then chunks (length, type, data).
Status splitGlb(const std::string& data, const std::string& file, GltfContainer& out) {
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
      out.json_text = chunk;  // "JSON"
    else if (chunk_type == 0x004E4942u) {
      out.glb_bin = chunk;
      out.have_glb_bin = true;
    }  // "BIN\0"
    offset += 8 + ((chunk_length + 3) & ~3u);
  }
  if (out.json_text.empty()) return corrupt(fmt::format("{}: the GLB has no JSON chunk", file));
  return Status::ok();
}

// The bytes of buffer b: the GLB binary chunk, a base64 data URI or a file beside `path`.
Result<std::string> readGltfBuffer(const nlohmann::json& buffer, std::size_t b,
                                   const std::filesystem::path& path, const std::string& file,
                                   const GltfContainer& container) {
  if (!buffer.contains("uri")) {
    if (b != 0 || !container.have_glb_bin)
      return corrupt(
          fmt::format("{}: buffers[{}] has no uri and there is no GLB binary chunk", file, b));
    return container.glb_bin;
  }
  const std::string uri = buffer["uri"].get<std::string>();
  if (uri.rfind("data:", 0) == 0) {
    const std::size_t comma = uri.find(',');
    if (comma == std::string::npos || uri.substr(0, comma).find(";base64") == std::string::npos)
      return corrupt(fmt::format("{}: buffers[{}] has a data URI that is not base64", file, b));
    auto decoded = decodeBase64(std::string_view(uri).substr(comma + 1),
                                fmt::format("{}: buffers[{}]", file, b));
    if (!decoded) return decoded.status();
    return std::move(*decoded);
  }
  auto external = readWholeFile(path.parent_path() / uri);
  if (!external)
    return Status(external.status().code(),
                  fmt::format("{}: buffers[{}]: {}", file, b, external.status().message()));
  return std::move(*external);
}

// The triangles of the default scene's node trees, or of every mesh in a file without scenes.
Status addGltfScene(Gltf& gltf, MaterialTable& table, GltfMeshes& meshes) {
  const nlohmann::json& doc = gltf.doc();
  const auto& scenes = doc.value("scenes", nlohmann::json::array());
  if (!scenes.empty()) {
    const std::size_t scene = doc.value("scene", std::size_t{0});
    if (scene >= scenes.size())
      return corrupt(fmt::format("{}: scene {} does not exist ({} scenes)", gltf.file(), scene,
                                 scenes.size()));
    for (const auto& node : scenes[scene].value("nodes", nlohmann::json::array()))
      CDFF_RETURN_IF_ERROR(addGltfNode(gltf, node.get<std::size_t>(), Eigen::Matrix4d::Identity(),
                                       table, meshes, 0));
  } else {
    const auto& mesh_list = doc.value("meshes", nlohmann::json::array());
    for (std::size_t m = 0; m < mesh_list.size(); ++m)
      CDFF_RETURN_IF_ERROR(addGltfMesh(gltf, m, Eigen::Matrix4d::Identity(), table, meshes));
  }
  return Status::ok();
}

}  // namespace

Result<TargetModel> loadGltf(const std::filesystem::path& path, const MeshLoadOptions& options) {
  CDFF_RETURN_IF_ERROR(checkOptions(options, path));
  auto text = readWholeFile(path);
  if (!text) return text.status();
  const std::string file = path.string();
  const std::string& data = *text;
  GltfContainer container;
  if (data.size() >= 4 && data.compare(0, 4, "glTF") == 0) {
    CDFF_RETURN_IF_ERROR(splitGlb(data, file, container));
  } else {
    container.json_text = data;
  }
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(container.json_text);
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
      auto bytes = readGltfBuffer(buffer, b, path, file, container);
      if (!bytes) return bytes.status();
      if (bytes->size() < length)
        return corrupt(fmt::format("{}: buffers[{}] holds {} bytes; byteLength says {}", file, b,
                                   bytes->size(), length));
      buffers.push_back(std::move(*bytes));
    }
    Gltf gltf(doc, std::move(buffers), file);
    MaterialTable table(options.default_material);
    GltfMeshes meshes;
    CDFF_RETURN_IF_ERROR(addGltfScene(gltf, table, meshes));
    return finish(path.stem().string(), std::move(meshes.positions), meshes.triangles,
                  meshes.triangle_material, table.take(), options, path);
  } catch (const nlohmann::json::exception& e) {
    return corrupt(fmt::format("{}: malformed glTF: {}", file, e.what()));
  }
}

}  // namespace cdff::egse
