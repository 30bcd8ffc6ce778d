#pragma once
// What the mesh loaders (model_import*.cpp) share: reading a file, splitting text into lines and
// tokens, parsing numbers, the table of materials a file refers to, and turning the positions
// and triangles read into a TargetModel.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "cdff/egse/model_io.hpp"

namespace cdff::egse::mesh_import {

inline Status corrupt(const std::string& message) {
  return {StatusCode::kCorruptData, message};
}

inline Result<std::string> readWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return ioError("cannot open '{}': {}", path.string(), std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Splits a line into whitespace-separated tokens.
inline std::vector<std::string_view> tokens(std::string_view line) {
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

inline bool parseDouble(std::string_view s, double& value) {
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(value);
}

inline bool parseLong(std::string_view s, long long& value) {
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

inline void applyOptions(std::vector<Eigen::Vector3f>& positions, const MeshLoadOptions& options) {
  for (auto& p : positions) p *= static_cast<float>(options.scale);
  if (options.recentre && !positions.empty()) {
    Eigen::AlignedBox3f box;
    for (const auto& p : positions) box.extend(p);
    const Eigen::Vector3f c = box.center();
    for (auto& p : positions) p -= c;
  }
}

inline Status checkOptions(const MeshLoadOptions& options, const std::filesystem::path& path) {
  if (!std::isfinite(options.scale) || options.scale <= 0)
    return invalidParameter("loading '{}': scale = {} is invalid; expected > 0", path.string(),
                            options.scale);
  return Status::ok();
}

inline Material materialFromColour(const std::string& name, const Eigen::Vector3f& diffuse,
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

// The model of a loaded mesh: the options applied, normals built with creases, validated.
inline Result<TargetModel> finish(std::string name, std::vector<Eigen::Vector3f> positions,
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

}  // namespace cdff::egse::mesh_import
