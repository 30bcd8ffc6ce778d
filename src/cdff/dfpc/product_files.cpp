// Saving and restoring the Data Product Manager: products.json (the index, with small values
// inline) and one binary PLY file per point cloud or mesh sample. The format is in docs/dfpc.md.
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "cdff/dfpc/data_product_manager.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/point_cloud.hpp"

namespace cdff::dfpc {

namespace {

static_assert(std::endian::native == std::endian::little,
              "PLY files are written little-endian by copying memory");

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kFormatVersion = 1;

json vec(const Eigen::Vector3d& v) {
  return {v.x(), v.y(), v.z()};
}

template <typename Matrix>
json matrix(const Matrix& m) {
  json out = json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) out.push_back(m(r, c));
  return out;
}

// JSON numbers cannot be NaN: nlohmann writes null, read back as NaN.
double number(const json& j) {
  return j.is_null() ? std::nan("") : j.get<double>();
}

Eigen::Vector3d readVec(const json& j) {
  if (!j.is_array() || j.size() != 3) throw std::runtime_error("expected [x, y, z]");
  return {number(j[0]), number(j[1]), number(j[2])};
}

template <typename Matrix>
void readMatrix(const json& j, Matrix& m) {
  if (!j.is_array() || j.size() != static_cast<std::size_t>(m.size()))
    throw std::runtime_error(
        fmt::format("expected {} numbers (row-major {}x{})", m.size(), m.rows(), m.cols()));
  std::size_t i = 0;
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) m(r, c) = number(j[i++]);
}

json transformJson(const Transform& t) {
  return {{"stamp_us", t.stamp},
          {"parent_frame", t.parent_frame},
          {"child_frame", t.child_frame},
          {"translation", vec(t.translation)},
          {"rotation_wxyz", {t.rotation.w(), t.rotation.x(), t.rotation.y(), t.rotation.z()}}};
}

Transform readTransform(const json& j) {
  Transform t;
  t.stamp = j.at("stamp_us").get<Timestamp>();
  t.parent_frame = j.at("parent_frame").get<std::string>();
  t.child_frame = j.at("child_frame").get<std::string>();
  t.translation = readVec(j.at("translation"));
  const json& q = j.at("rotation_wxyz");
  if (!q.is_array() || q.size() != 4)
    throw std::runtime_error("expected rotation_wxyz [w, x, y, z]");
  t.rotation = Eigen::Quaterniond(number(q[0]), number(q[1]), number(q[2]), number(q[3]));
  return t;
}

// ---- PLY (binary little endian), for the layouts this file writes -----------------------------

struct PlyProperty {
  std::string type, name;
};

std::string plyHeader(const std::string& element, std::size_t count,
                      const std::vector<PlyProperty>& properties) {
  std::string h = fmt::format("element {} {}\n", element, count);
  for (const auto& p : properties) h += fmt::format("property {} {}\n", p.type, p.name);
  return h;
}

template <typename T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

template <typename T>
T get(const std::string& data, std::size_t& pos) {
  if (pos + sizeof(T) > data.size()) throw std::runtime_error("truncated PLY body");
  T v;
  std::memcpy(&v, data.data() + pos, sizeof(T));
  pos += sizeof(T);
  return v;
}

std::vector<PlyProperty> cloudProperties(bool normals, bool intensity, bool ring, bool time) {
  std::vector<PlyProperty> p{{"float", "x"}, {"float", "y"}, {"float", "z"}};
  if (normals) p.insert(p.end(), {{"float", "nx"}, {"float", "ny"}, {"float", "nz"}});
  if (intensity) p.push_back({"float", "intensity"});
  if (ring) p.push_back({"ushort", "ring"});
  if (time) p.push_back({"int", "time_offset_us"});
  return p;
}

std::vector<PlyProperty> cloudProperties(const PointCloud& c) {
  return cloudProperties(c.hasNormals(), !c.intensity.empty(), !c.ring.empty(),
                         !c.time_offset_us.empty());
}

std::string plyPrologue() {
  return "ply\nformat binary_little_endian 1.0\ncomment written by CDFF\n";
}

std::string writeCloud(const PointCloud& c) {
  std::string out =
      plyPrologue() + plyHeader("vertex", c.size(), cloudProperties(c)) + "end_header\n";
  for (std::size_t i = 0; i < c.size(); ++i) {
    put(out, c.points[i].x);
    put(out, c.points[i].y);
    put(out, c.points[i].z);
    if (c.hasNormals()) {
      put(out, c.normals[i].x);
      put(out, c.normals[i].y);
      put(out, c.normals[i].z);
    }
    if (!c.intensity.empty()) put(out, c.intensity[i]);
    if (!c.ring.empty()) put(out, c.ring[i]);
    if (!c.time_offset_us.empty()) put(out, c.time_offset_us[i]);
  }
  return out;
}

std::string writeMesh(const TriangleMesh& m) {
  std::vector<PlyProperty> vp{{"float", "x"}, {"float", "y"}, {"float", "z"}};
  const bool normals = !m.vertex_normals.empty();
  if (normals) vp.insert(vp.end(), {{"float", "nx"}, {"float", "ny"}, {"float", "nz"}});
  std::string out = plyPrologue() + plyHeader("vertex", m.vertexCount(), vp) +
                    plyHeader("face", m.triangleCount(), {{"list uchar uint", "vertex_indices"}}) +
                    "end_header\n";
  for (std::size_t i = 0; i < m.vertexCount(); ++i) {
    for (int k = 0; k < 3; ++k) put(out, m.vertices[i][k]);
    if (normals)
      for (int k = 0; k < 3; ++k) put(out, m.vertex_normals[i][k]);
  }
  for (std::size_t i = 0; i < m.triangleCount(); ++i) {
    put(out, static_cast<std::uint8_t>(3));
    for (std::uint32_t index : m.triangles[i]) put(out, index);
  }
  return out;
}

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
  bool has(const std::string& property) const {
    for (const auto& p : properties)
      if (p.name == property) return true;
    return false;
  }
};

// Parses the header of a PLY written by writeCloud/writeMesh; `pos` ends at the body.
std::vector<PlyElement> readHeader(const std::string& data, std::size_t& pos) {
  std::vector<PlyElement> elements;
  std::istringstream in(data);
  std::string line;
  std::getline(in, line);
  if (line != "ply") throw std::runtime_error("not a PLY file (no 'ply' magic line)");
  bool format_ok = false;
  while (std::getline(in, line)) {
    if (line == "end_header") break;
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "format") {
      std::string kind;
      words >> kind;
      format_ok = kind == "binary_little_endian";
    } else if (word == "element") {
      PlyElement e;
      words >> e.name >> e.count;
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) throw std::runtime_error("PLY property before any element");
      std::string type, name, rest;
      words >> type;
      if (type == "list") {
        std::string count_type, index_type;
        words >> count_type >> index_type >> name;
        type = "list " + count_type + " " + index_type;
      } else {
        words >> name;
      }
      elements.back().properties.push_back({type, name});
    } else if (word != "comment" && word != "obj_info") {
      throw std::runtime_error(fmt::format("unexpected PLY header line '{}'", line));
    }
  }
  if (line != "end_header") throw std::runtime_error("PLY header has no end_header");
  if (!format_ok) throw std::runtime_error("expected 'format binary_little_endian 1.0'");
  pos = static_cast<std::size_t>(in.tellg());
  return elements;
}

void expectProperties(const PlyElement& e, const std::vector<PlyProperty>& expected) {
  bool same = e.properties.size() == expected.size();
  for (std::size_t i = 0; same && i < expected.size(); ++i)
    same = e.properties[i].type == expected[i].type && e.properties[i].name == expected[i].name;
  if (!same) {
    std::vector<std::string> got;
    for (const auto& p : e.properties) got.push_back(p.type + " " + p.name);
    throw std::runtime_error(
        fmt::format("PLY element '{}' has properties [{}]; expected the "
                    "layout CDFF writes",
                    e.name, fmt::join(got, ", ")));
  }
}

PointCloud readCloud(const std::string& data) {
  std::size_t pos = 0;
  const auto elements = readHeader(data, pos);
  if (elements.size() != 1 || elements[0].name != "vertex")
    throw std::runtime_error("a point cloud PLY has one 'vertex' element");
  const PlyElement& v = elements[0];
  // The layout follows from which optional fields are present, in the order writeCloud uses.
  const bool normals = v.has("nx"), intensity = v.has("intensity"), ring = v.has("ring"),
             time = v.has("time_offset_us");
  expectProperties(v, cloudProperties(normals, intensity, ring, time));
  std::vector<Point4f> points(v.count), normal_values(normals ? v.count : 0);
  std::vector<float> intensities(intensity ? v.count : 0);
  std::vector<std::uint16_t> rings(ring ? v.count : 0);
  std::vector<std::int32_t> times(time ? v.count : 0);
  for (std::size_t i = 0; i < v.count; ++i) {
    points[i].x = get<float>(data, pos);
    points[i].y = get<float>(data, pos);
    points[i].z = get<float>(data, pos);
    if (normals) {
      normal_values[i].x = get<float>(data, pos);
      normal_values[i].y = get<float>(data, pos);
      normal_values[i].z = get<float>(data, pos);
      normal_values[i].pad = 0;
    }
    if (intensity) intensities[i] = get<float>(data, pos);
    if (ring) rings[i] = get<std::uint16_t>(data, pos);
    if (time) times[i] = get<std::int32_t>(data, pos);
  }
  PointCloud c;
  c.points = Buffer<Point4f>::fromVector(std::move(points));
  c.normals = Buffer<Point4f>::fromVector(std::move(normal_values));
  c.intensity = Buffer<float>::fromVector(std::move(intensities));
  c.ring = Buffer<std::uint16_t>::fromVector(std::move(rings));
  c.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(times));
  if (pos != data.size()) throw std::runtime_error("PLY body is longer than its header says");
  return c;
}

TriangleMesh readMesh(const std::string& data) {
  std::size_t pos = 0;
  const auto elements = readHeader(data, pos);
  if (elements.size() != 2 || elements[0].name != "vertex" || elements[1].name != "face")
    throw std::runtime_error("a mesh PLY has a 'vertex' and a 'face' element");
  const bool normals = elements[0].has("nx");
  std::vector<PlyProperty> vp{{"float", "x"}, {"float", "y"}, {"float", "z"}};
  if (normals) vp.insert(vp.end(), {{"float", "nx"}, {"float", "ny"}, {"float", "nz"}});
  expectProperties(elements[0], vp);
  expectProperties(elements[1], {{"list uchar uint", "vertex_indices"}});
  std::vector<Eigen::Vector3f> vertices(elements[0].count), vertex_normals;
  if (normals) vertex_normals.resize(elements[0].count);
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    for (int k = 0; k < 3; ++k) vertices[i][k] = get<float>(data, pos);
    if (normals)
      for (int k = 0; k < 3; ++k) vertex_normals[i][k] = get<float>(data, pos);
  }
  std::vector<std::array<std::uint32_t, 3>> triangles(elements[1].count);
  for (auto& t : triangles) {
    if (get<std::uint8_t>(data, pos) != 3) throw std::runtime_error("a face is not a triangle");
    for (auto& index : t) index = get<std::uint32_t>(data, pos);
  }
  if (pos != data.size()) throw std::runtime_error("PLY body is longer than its header says");
  TriangleMesh m;
  m.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  m.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(vertex_normals));
  m.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
  return m;
}

// ---- codecs -----------------------------------------------------------------------------------

// A sample's value: inline JSON (`value`) or a file next to the index (`file`, plus metadata).
struct Codec {
  std::function<json(const void*)> to_json;  // inline types
  std::function<std::shared_ptr<const void>(const json&)> from_json;
  std::function<std::string(const void*, json& meta)> to_file;  // file types
  std::function<std::shared_ptr<const void>(const std::string&, const json& meta)> from_file;
};

Codec inlineCodec(decltype(Codec::to_json) to, decltype(Codec::from_json) from) {
  Codec c;
  c.to_json = std::move(to);
  c.from_json = std::move(from);
  return c;
}

Codec fileCodec(decltype(Codec::to_file) to, decltype(Codec::from_file) from) {
  Codec c;
  c.to_file = std::move(to);
  c.from_file = std::move(from);
  return c;
}

template <typename T>
std::shared_ptr<const void> share(T value) {
  return std::make_shared<const T>(std::move(value));
}

const std::map<std::string, Codec>& codecs() {
  static const std::map<std::string, Codec> table = [] {
    std::map<std::string, Codec> t;
    t["Transform"] =
        inlineCodec([](const void* v) { return transformJson(*static_cast<const Transform*>(v)); },
                    [](const json& j) { return share(readTransform(j)); });
    t["PoseWithCovariance"] = inlineCodec(
        [](const void* v) {
          const auto& p = *static_cast<const PoseWithCovariance*>(v);
          return json{{"pose", transformJson(p.pose)}, {"covariance", matrix(p.covariance)}};
        },
        [](const json& j) {
          PoseWithCovariance p;
          p.pose = readTransform(j.at("pose"));
          readMatrix(j.at("covariance"), p.covariance);
          return share(p);
        });
    t["RigidBodyState"] = inlineCodec(
        [](const void* v) {
          const auto& s = *static_cast<const RigidBodyState*>(v);
          return json{
              {"pose", transformJson(s.pose)},
              {"twist", {{"linear", vec(s.twist.linear)}, {"angular", vec(s.twist.angular)}}},
              {"covariance", matrix(s.covariance)}};
        },
        [](const json& j) {
          RigidBodyState s;
          s.pose = readTransform(j.at("pose"));
          s.twist.linear = readVec(j.at("twist").at("linear"));
          s.twist.angular = readVec(j.at("twist").at("angular"));
          readMatrix(j.at("covariance"), s.covariance);
          return share(s);
        });
    t["Double"] = inlineCodec([](const void* v) { return json(*static_cast<const double*>(v)); },
                              [](const json& j) { return share(number(j)); });
    t["Bool"] = inlineCodec([](const void* v) { return json(*static_cast<const bool*>(v)); },
                            [](const json& j) { return share(j.get<bool>()); });
    t["Int"] = inlineCodec([](const void* v) { return json(*static_cast<const int*>(v)); },
                           [](const json& j) { return share(j.get<int>()); });
    t["Timestamp"] =
        inlineCodec([](const void* v) { return json(*static_cast<const Timestamp*>(v)); },
                    [](const json& j) { return share(j.get<Timestamp>()); });
    t["String"] =
        inlineCodec([](const void* v) { return json(*static_cast<const std::string*>(v)); },
                    [](const json& j) { return share(j.get<std::string>()); });
    t["PointCloud"] = fileCodec(
        [](const void* v, json& meta) {
          const auto& c = *static_cast<const PointCloud*>(v);
          meta["frame_id"] = c.frame_id;
          meta["data_stamp_us"] = c.stamp;
          return writeCloud(c);
        },
        [](const std::string& data, const json& meta) {
          PointCloud c = readCloud(data);
          c.frame_id = meta.at("frame_id").get<std::string>();
          c.stamp = meta.at("data_stamp_us").get<Timestamp>();
          return share(std::move(c));
        });
    t["TriangleMesh"] = fileCodec(
        [](const void* v, json& meta) {
          const auto& m = *static_cast<const TriangleMesh*>(v);
          meta["frame_id"] = m.frame_id;
          meta["data_stamp_us"] = m.stamp;
          return writeMesh(m);
        },
        [](const std::string& data, const json& meta) {
          TriangleMesh m = readMesh(data);
          m.frame_id = meta.at("frame_id").get<std::string>();
          m.stamp = meta.at("data_stamp_us").get<Timestamp>();
          return share(std::move(m));
        });
    return t;
  }();
  return table;
}

std::string folderName(std::size_t index, const std::string& product) {
  std::string safe;
  for (char c : product) safe += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return fmt::format("{:03}_{}", index, safe);
}

Status writeFile(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out || !out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())))
    return ioError("{}: cannot write ({} bytes); expected a writable directory", path.string(),
                   bytes.size());
  return Status::ok();
}

Result<std::string> readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return notFound("{}: cannot open; expected the file that save() wrote", path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

Status DataProductManager::save(const std::string& directory) const {
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec) return ioError("{}: cannot create the product directory: {}", directory, ec.message());
  json index = {{"format", "cdff-data-products"}, {"version", kFormatVersion}};
  index["products"] = json::array();
  std::vector<std::string> problems;
  const std::vector<std::string> product_names = names();
  for (std::size_t i = 0; i < product_names.size(); ++i) {
    const std::string& name = product_names[i];
    std::shared_ptr<Series> s = find(name);
    if (!s) continue;
    std::shared_lock lock(s->mutex);
    json entry = {{"name", name}, {"type", std::string(s->type.name)}, {"history", s->limit}};
    entry["samples"] = json::array();
    auto codec = codecs().find(std::string(s->type.name));
    if (codec == codecs().end()) {
      problems.push_back(
          fmt::format("product '{}' ({} samples of type {}): no file encoding for "
                      "{}",
                      name, s->samples.size(), s->type.name, s->type.name));
      continue;
    }
    const std::string folder = folderName(i, name);
    for (std::size_t k = 0; k < s->samples.size(); ++k) {
      const Product& p = s->samples[k];
      json sample = {{"stamp_us", p.stamp}};
      if (codec->second.to_json) {
        sample["value"] = codec->second.to_json(p.value.get());
      } else {
        fs::create_directories(fs::path(directory) / folder, ec);
        const std::string file = fmt::format("{}/{:06}.ply", folder, k);
        Status written =
            writeFile(fs::path(directory) / file, codec->second.to_file(p.value.get(), sample));
        if (!written) {
          problems.push_back(written.message());
          continue;
        }
        sample["file"] = file;
      }
      entry["samples"].push_back(std::move(sample));
    }
    index["products"].push_back(std::move(entry));
  }
  // The index last, through a rename: a reader never sees an index naming files not yet written.
  const fs::path tmp = fs::path(directory) / "products.json.tmp";
  CDFF_RETURN_IF_ERROR(writeFile(tmp, index.dump(1)));
  fs::rename(tmp, fs::path(directory) / "products.json", ec);
  if (ec) return ioError("{}: cannot write products.json: {}", directory, ec.message());
  if (!problems.empty())
    return ioError("{}: saved all but: {}", directory, fmt::join(problems, "; "));
  return Status::ok();
}

Status DataProductManager::restore(const std::string& directory) {
  const fs::path index_path = fs::path(directory) / "products.json";
  Result<std::string> text = readFile(index_path);
  if (!text) return text.status();
  json index;
  try {
    index = json::parse(*text);
  } catch (const json::exception& e) {
    return Status(StatusCode::kCorruptData,
                  fmt::format("{}: not valid JSON: {}", index_path.string(), e.what()));
  }
  if (index.value("format", "") != "cdff-data-products" || index.value("version", 0) != 1)
    return Status(
        StatusCode::kCorruptData,
        fmt::format("{}: expected format 'cdff-data-products' version 1", index_path.string()));
  // Decode everything first: a failed restore leaves the manager as it was.
  struct Decoded {
    std::string name;
    dfn::PortType type;
    std::size_t limit;
    std::vector<std::pair<Timestamp, std::shared_ptr<const void>>> samples;
  };
  std::vector<Decoded> decoded;
  try {
    for (const json& entry : index.at("products")) {
      Decoded d;
      d.name = entry.at("name").get<std::string>();
      const std::string type = entry.at("type").get<std::string>();
      const dfn::PortType* port_type = dfn::findPortType(type);
      auto codec = codecs().find(type);
      if (!port_type || codec == codecs().end())
        return Status(StatusCode::kCorruptData,
                      fmt::format("{}: product '{}' has type '{}', which has no file encoding",
                                  index_path.string(), d.name, type));
      d.type = *port_type;
      d.limit = entry.at("history").get<std::size_t>();
      for (const json& sample : entry.at("samples")) {
        const Timestamp stamp = sample.at("stamp_us").get<Timestamp>();
        if (codec->second.from_json) {
          d.samples.emplace_back(stamp, codec->second.from_json(sample.at("value")));
        } else {
          const fs::path file = fs::path(directory) / sample.at("file").get<std::string>();
          Result<std::string> bytes = readFile(file);
          if (!bytes) return bytes.status();
          try {
            d.samples.emplace_back(stamp, codec->second.from_file(*bytes, sample));
          } catch (const std::exception& e) {
            return Status(StatusCode::kCorruptData, fmt::format("{}: {}", file.string(), e.what()));
          }
        }
      }
      decoded.push_back(std::move(d));
    }
  } catch (const std::exception& e) {
    return Status(StatusCode::kCorruptData,
                  fmt::format("{}: {}; expected the index that save() writes", index_path.string(),
                              e.what()));
  }
  {
    std::unique_lock lock(mutex_);
    series_.clear();
  }
  for (Decoded& d : decoded) {
    CDFF_RETURN_IF_ERROR(setHistoryLimit(d.name, std::max<std::size_t>(d.limit, 1)));
    for (auto& [stamp, value] : d.samples)
      CDFF_RETURN_IF_ERROR(publish(d.name, stamp, std::move(value), d.type));
  }
  return Status::ok();
}

}  // namespace cdff::dfpc
