// The STL loader: ascii and binary.
#include <cstring>
#include <unordered_map>

#include "cdff/egse/model_import_common.hpp"
#include "cdff/egse/model_io.hpp"

namespace cdff::egse {

using mesh_import::checkOptions;
using mesh_import::corrupt;
using mesh_import::finish;
using mesh_import::LineReader;
using mesh_import::MaterialTable;
using mesh_import::parseDouble;
using mesh_import::readWholeFile;
using mesh_import::tokens;

namespace {

// The triangles read so far, on positions welded so that the mesh is connected (STL stores each
// triangle alone).
struct StlMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::unordered_map<std::string, std::uint32_t> index;  // a position's bytes -> its index

  // The index of position p, added the first time it is seen.
  std::uint32_t weld(const Eigen::Vector3f& p) {
    std::string key(reinterpret_cast<const char*>(p.data()), sizeof(float) * 3);
    auto [it, inserted] =
        index.emplace(std::move(key), static_cast<std::uint32_t>(positions.size()));
    if (inserted) positions.push_back(p);
    return it->second;
  }
};

// The triangles of a binary STL file: an 80-byte header, a uint32 count, 50 bytes per triangle.
Status readBinaryStl(const std::string& data, std::uint32_t count, const std::string& file,
                     StlMesh& mesh) {
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
      tri[k] = mesh.weld(p);
    }
    if (tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2]) mesh.triangles.push_back(tri);
  }
  return Status::ok();
}

// The triangles of an ascii STL file: `solid`, then facets of one `outer loop` of 3 vertices.
Status readAsciiStl(const std::string& data, const std::string& file, StlMesh& mesh) {
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
      loop.push_back(mesh.weld(p));
    } else if (t[0] == "outer") {
      in_loop = true;
      loop.clear();
    } else if (t[0] == "endloop") {
      if (loop.size() != 3)
        return corrupt(
            fmt::format("{}:{}: a facet has {} vertices; expected 3", file, ln, loop.size()));
      if (loop[0] != loop[1] && loop[1] != loop[2] && loop[0] != loop[2])
        mesh.triangles.push_back({loop[0], loop[1], loop[2]});
      in_loop = false;
    } else if (t[0] == "solid" || t[0] == "facet" || t[0] == "endfacet" || t[0] == "endsolid") {
      continue;
    } else {
      return corrupt(fmt::format("{}:{}: unexpected '{}' in an ascii STL", file, ln, t[0]));
    }
  }
  if (in_loop) return corrupt(fmt::format("{}: the file ends inside a facet", file));
  return Status::ok();
}

}  // namespace

Result<TargetModel> loadStl(const std::filesystem::path& path, const MeshLoadOptions& options) {
  CDFF_RETURN_IF_ERROR(checkOptions(options, path));
  auto text = readWholeFile(path);
  if (!text) return text.status();
  const std::string file = path.string();
  const std::string& data = *text;
  StlMesh mesh;
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
    CDFF_RETURN_IF_ERROR(readBinaryStl(data, count, file, mesh));
  } else if (starts_solid) {
    CDFF_RETURN_IF_ERROR(readAsciiStl(data, file, mesh));
  } else {
    return corrupt(fmt::format(
        "{}: not an STL file: {} bytes, neither 'solid ...' (ascii) nor 84 + 50 x {} bytes "
        "(binary)",
        file, data.size(), count));
  }
  MaterialTable table(options.default_material);
  const std::uint16_t m = table.index("");
  return finish(path.stem().string(), std::move(mesh.positions), mesh.triangles,
                std::vector<std::uint16_t>(mesh.triangles.size(), m), table.take(), options, path);
}

}  // namespace cdff::egse
