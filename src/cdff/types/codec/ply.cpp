// Product files of point clouds and meshes: binary little-endian PLY, in the layouts written
// here (MeshLab and CloudCompare open them); the frame and stamp travel in the metadata.
#include <bit>
#include <cstring>
#include <sstream>

#include <fmt/ranges.h>

#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

namespace {

static_assert(std::endian::native == std::endian::little,
              "PLY files are written little-endian by copying memory");

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

}  // namespace

Status toPly(const PointCloud& v, ProductRecord& out) {
  out.json = {{"frame_id", v.frame_id}, {"data_stamp_us", v.stamp}};
  out.file = writeCloud(v);
  return Status::ok();
}

Status toPly(const TriangleMesh& v, ProductRecord& out) {
  out.json = {{"frame_id", v.frame_id}, {"data_stamp_us", v.stamp}};
  out.file = writeMesh(v);
  return Status::ok();
}

Status fromPly(const ProductRecord& in, PointCloud& out) {
  return detail::readJsonValue("point cloud PLY", [&] {
    PointCloud c = readCloud(in.file);
    c.frame_id = in.json.at("frame_id").get<std::string>();
    c.stamp = in.json.at("data_stamp_us").get<Timestamp>();
    out = std::move(c);
  });
}

Status fromPly(const ProductRecord& in, TriangleMesh& out) {
  return detail::readJsonValue("mesh PLY", [&] {
    TriangleMesh m = readMesh(in.file);
    m.frame_id = in.json.at("frame_id").get<std::string>();
    m.stamp = in.json.at("data_stamp_us").get<Timestamp>();
    out = std::move(m);
  });
}

}  // namespace cdff::codec
