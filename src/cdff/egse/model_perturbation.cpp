#include "cdff/egse/model_perturbation.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace cdff::egse {

namespace {

// A bound on the re-triangulated mesh: beyond it a max_edge is a mistake (millimetres on a
// satellite), not a model error.
constexpr std::size_t kMaxTriangles = 20'000'000;

template <typename T>
std::vector<T> toVector(const Buffer<T>& buffer) {
  return {buffer.begin(), buffer.end()};
}

std::string partList(const TargetModel& model) {
  return model.parts.empty() ? std::string("none")
                             : fmt::format("{}", fmt::join(model.parts, ", "));
}

Result<TargetModel> removeParts(const TargetModel& model, const std::vector<std::string>& names) {
  if (names.empty()) return model;
  if (model.parts.empty())
    return invalidParameter(
        "model '{}' has no named parts, so part '{}' cannot be removed; expected a model built "
        "with parts (a scenario's procedural target, or a PLY written by cdff)",
        model.name, names.front());
  std::vector<bool> removed(model.parts.size(), false);
  for (const std::string& name : names) {
    const auto it = std::find(model.parts.begin(), model.parts.end(), name);
    if (it == model.parts.end())
      return invalidParameter("model '{}' has no part '{}'; expected one of: {}", model.name, name,
                              partList(model));
    removed[static_cast<std::size_t>(it - model.parts.begin())] = true;
  }
  // The parts left, renumbered.
  TargetModel out;
  out.name = model.name;
  out.materials = model.materials;
  std::vector<std::uint16_t> part_index(model.parts.size(), 0);
  for (std::size_t p = 0; p < model.parts.size(); ++p)
    if (!removed[p]) {
      part_index[p] = static_cast<std::uint16_t>(out.parts.size());
      out.parts.push_back(model.parts[p]);
    }
  if (out.parts.empty())
    return invalidParameter("model '{}': removing {} leaves nothing; expected at least one part",
                            model.name, fmt::join(names, ", "));
  // The vertices the kept triangles and polygons use, renumbered in their order.
  const std::size_t none = model.mesh.vertices.size();
  std::vector<std::uint32_t> vertex_index(none, static_cast<std::uint32_t>(none));
  std::vector<Eigen::Vector3f> vertices, normals;
  auto use = [&](std::uint32_t v) {
    if (vertex_index[v] == none) {
      vertex_index[v] = static_cast<std::uint32_t>(vertices.size());
      vertices.push_back(model.mesh.vertices[v]);
      normals.push_back(model.mesh.vertex_normals[v]);
    }
    return vertex_index[v];
  };
  std::vector<std::array<std::uint32_t, 3>> triangles;
  for (std::size_t t = 0; t < model.mesh.triangles.size(); ++t) {
    if (removed[model.triangle_part[t]]) continue;
    const auto& tri = model.mesh.triangles[t];
    triangles.push_back({use(tri[0]), use(tri[1]), use(tri[2])});
    out.triangle_material.push_back(model.triangle_material[t]);
    out.triangle_part.push_back(part_index[model.triangle_part[t]]);
  }
  for (const ModelPolygon& polygon : model.polygons) {
    if (removed[polygon.part]) continue;
    ModelPolygon kept = polygon;
    for (std::uint32_t& v : kept.vertices) v = use(v);
    kept.part = part_index[polygon.part];
    out.polygons.push_back(std::move(kept));
  }
  out.mesh = model.mesh;
  out.mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  out.mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
  out.mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
  return out;
}

TargetModel scaleModel(const TargetModel& model, const Eigen::Vector3d& factor) {
  if (factor == Eigen::Vector3d::Ones()) return model;
  TargetModel out = model;
  std::vector<Eigen::Vector3f> vertices, normals;
  vertices.reserve(model.mesh.vertices.size());
  normals.reserve(model.mesh.vertex_normals.size());
  // Normals transform with the inverse transpose: a plane's normal scaled by 1 / factor.
  const Eigen::Vector3d inverse = factor.cwiseInverse();
  for (const auto& v : model.mesh.vertices)
    vertices.push_back(v.cast<double>().cwiseProduct(factor).cast<float>());
  for (const auto& n : model.mesh.vertex_normals)
    normals.push_back(n.cast<double>().cwiseProduct(inverse).normalized().cast<float>());
  out.mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  out.mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
  return out;
}

Result<TargetModel> addBox(const TargetModel& model, const ExtraBox& box) {
  if (std::find(model.parts.begin(), model.parts.end(), box.name) != model.parts.end())
    return invalidParameter("model '{}' already has a part '{}'; expected a new name for the box",
                            model.name, box.name);
  ModelBuilder builder(box.name);
  builder.material(MaterialId::kStructure);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = box.centre;
  builder.addBox(pose, box.half_extents, 0);
  const TargetModel added = builder.build();

  TargetModel out = model;
  // A model without parts becomes one part (named after it) plus the box.
  if (out.parts.empty()) {
    out.parts.push_back(model.name.empty() ? std::string("model") : model.name);
    out.triangle_part.assign(model.mesh.triangles.size(), 0);
  }
  const auto part = static_cast<std::uint16_t>(out.parts.size());
  out.parts.push_back(box.name);
  std::uint16_t material = 0;
  const Material structure = builtinMaterial(MaterialId::kStructure);
  const auto it = std::find_if(out.materials.begin(), out.materials.end(),
                               [&](const Material& m) { return m.name == structure.name; });
  if (it != out.materials.end()) {
    material = static_cast<std::uint16_t>(it - out.materials.begin());
  } else {
    material = static_cast<std::uint16_t>(out.materials.size());
    out.materials.push_back(structure);
  }
  const auto offset = static_cast<std::uint32_t>(model.mesh.vertices.size());
  std::vector<Eigen::Vector3f> vertices = toVector(model.mesh.vertices);
  std::vector<Eigen::Vector3f> normals = toVector(model.mesh.vertex_normals);
  std::vector<std::array<std::uint32_t, 3>> triangles = toVector(model.mesh.triangles);
  for (std::size_t v = 0; v < added.mesh.vertices.size(); ++v) {
    vertices.push_back(added.mesh.vertices[v]);
    normals.push_back(added.mesh.vertex_normals[v]);
  }
  for (const auto& t : added.mesh.triangles) {
    triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
    out.triangle_material.push_back(material);
    out.triangle_part.push_back(part);
  }
  for (ModelPolygon polygon : added.polygons) {
    for (std::uint32_t& v : polygon.vertices) v += offset;
    polygon.material = material;
    polygon.part = part;
    out.polygons.push_back(std::move(polygon));
  }
  out.mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  out.mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
  out.mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
  return out;
}

// One pass of the re-triangulation: every edge longer than max_edge split at its middle.
// Returns false when no edge was split.
struct Refinement {
  std::vector<Eigen::Vector3f> vertices, normals;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint16_t> material, part;
};

bool splitLongEdges(Refinement& r, double max_edge) {
  const double limit = max_edge * max_edge;
  // Midpoints by vertex pair, so that neighbours sharing the vertices share the midpoint too;
  // neighbours with vertices of their own (flat faces) compute the same point from the same
  // positions.
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
  auto midpoint = [&](std::uint32_t i, std::uint32_t j) {
    const std::pair<std::uint32_t, std::uint32_t> key(std::min(i, j), std::max(i, j));
    const auto [it, inserted] = midpoints.emplace(key, 0);
    if (inserted) {
      it->second = static_cast<std::uint32_t>(r.vertices.size());
      const Eigen::Vector3d p = (r.vertices[i].cast<double>() + r.vertices[j].cast<double>()) / 2;
      Eigen::Vector3d n = r.normals[i].cast<double>() + r.normals[j].cast<double>();
      n = n.norm() > 1e-9 ? n.normalized() : r.normals[i].cast<double>();
      r.vertices.push_back(p.cast<float>());
      r.normals.push_back(n.cast<float>());
    }
    return it->second;
  };
  auto length2 = [&](std::uint32_t i, std::uint32_t j) {
    return (r.vertices[i].cast<double>() - r.vertices[j].cast<double>()).squaredNorm();
  };
  bool any = false;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint16_t> material, part;
  const bool parts = !r.part.empty();
  auto emit = [&](std::size_t from, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    triangles.push_back({a, b, c});
    material.push_back(r.material[from]);
    if (parts) part.push_back(r.part[from]);
  };
  for (std::size_t t = 0; t < r.triangles.size(); ++t) {
    const auto v = r.triangles[t];
    bool split[3];
    int count = 0;
    for (int k = 0; k < 3; ++k) count += (split[k] = length2(v[k], v[(k + 1) % 3]) > limit);
    if (count == 0) {
      emit(t, v[0], v[1], v[2]);
      continue;
    }
    any = true;
    if (count == 3) {
      const std::uint32_t m0 = midpoint(v[0], v[1]), m1 = midpoint(v[1], v[2]),
                          m2 = midpoint(v[2], v[0]);
      emit(t, v[0], m0, m2);
      emit(t, m0, v[1], m1);
      emit(t, m2, m1, v[2]);
      emit(t, m0, m1, m2);
    } else if (count == 1) {
      const int k = split[0] ? 0 : split[1] ? 1 : 2;
      const std::uint32_t a = v[k], b = v[(k + 1) % 3], c = v[(k + 2) % 3];
      const std::uint32_t m = midpoint(a, b);
      emit(t, a, m, c);
      emit(t, m, b, c);
    } else {
      // Edges a-b and b-c split, c-a not: a corner triangle at b and a quad split along its
      // shorter diagonal.
      const int k = !split[0] ? 1 : !split[1] ? 2 : 0;
      const std::uint32_t a = v[k], b = v[(k + 1) % 3], c = v[(k + 2) % 3];
      const std::uint32_t mab = midpoint(a, b), mbc = midpoint(b, c);
      emit(t, mab, b, mbc);
      if (length2(a, mbc) <= length2(mab, c)) {
        emit(t, a, mab, mbc);
        emit(t, a, mbc, c);
      } else {
        emit(t, a, mab, c);
        emit(t, mab, mbc, c);
      }
    }
  }
  r.triangles = std::move(triangles);
  r.material = std::move(material);
  r.part = std::move(part);
  return any;
}

}  // namespace

Status ModelPerturbation::validate() const {
  static const char* kAxes[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(scale_error[i]) || std::abs(scale_error[i]) >= 0.5)
      return invalidParameter(
          "model error: scale error along {} = {} is invalid; expected a finite relative error "
          "within (-0.5, 0.5) (0.01: 1 % larger)",
          kAxes[i], scale_error[i]);
  for (const ExtraBox& box : add_boxes) {
    if (box.name.empty())
      return invalidParameter("model error: an extra box has no name; expected a part name");
    if (!box.centre.allFinite())
      return invalidParameter("model error: box '{}' has a centre that is not finite ({}, {}, {})",
                              box.name, box.centre.x(), box.centre.y(), box.centre.z());
    for (int i = 0; i < 3; ++i)
      if (!std::isfinite(box.half_extents[i]) || box.half_extents[i] <= 0)
        return invalidParameter(
            "model error: box '{}' half extent along {} = {} is invalid; expected a positive "
            "length in m",
            box.name, kAxes[i], box.half_extents[i]);
  }
  if (!std::isfinite(max_edge) || max_edge < 0)
    return invalidParameter(
        "model error: max_edge = {} is invalid; expected a length >= 0 m (0: no "
        "re-triangulation)",
        max_edge);
  return Status::ok();
}

Result<TargetModel> splitLongEdges(const TargetModel& model, double max_edge) {
  if (!std::isfinite(max_edge) || max_edge <= 0)
    return invalidParameter(
        "re-triangulation: max_edge = {} is invalid; expected a positive length in m", max_edge);
  CDFF_RETURN_IF_ERROR(model.validate());
  Refinement r{toVector(model.mesh.vertices), toVector(model.mesh.vertex_normals),
               toVector(model.mesh.triangles), model.triangle_material, model.triangle_part};
  while (splitLongEdges(r, max_edge))
    if (r.triangles.size() > kMaxTriangles)
      return invalidParameter(
          "re-triangulation of model '{}': max_edge = {} m gives more than {} triangles; expected "
          "a larger max_edge",
          model.name, max_edge, kMaxTriangles);
  TargetModel out = model;
  out.mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(r.vertices));
  out.mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(r.normals));
  out.mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(r.triangles));
  out.triangle_material = std::move(r.material);
  out.triangle_part = std::move(r.part);
  return out;
}

TargetModel flipDiagonals(const TargetModel& model) {
  const auto& vertices = model.mesh.vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles = toVector(model.mesh.triangles);
  auto position = [&](std::uint32_t v) { return vertices[v].cast<double>(); };
  auto normal = [&](const std::array<std::uint32_t, 3>& t) {
    return (position(t[1]) - position(t[0])).cross(position(t[2]) - position(t[0]));
  };
  // The triangles on each directed edge (a, b), a < b by index.
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::size_t>> on_edge;
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = triangles[t][k], b = triangles[t][(k + 1) % 3];
      on_edge[{std::min(a, b), std::max(a, b)}].push_back(t);
    }
  const bool parts = !model.triangle_part.empty();
  constexpr double kCoplanar = 1e-5;  // rad between the two normals
  std::vector<bool> flipped(triangles.size(), false);
  for (const auto& [edge, faces] : on_edge) {
    if (faces.size() != 2) continue;
    const std::size_t t = faces[0], u = faces[1];
    if (flipped[t] || flipped[u] || model.triangle_material[t] != model.triangle_material[u] ||
        (parts && model.triangle_part[t] != model.triangle_part[u]))
      continue;
    const Eigen::Vector3d nt = normal(triangles[t]), nu = normal(triangles[u]);
    if (nt.norm() < 1e-18 || nu.norm() < 1e-18 ||
        nt.normalized().dot(nu.normalized()) < std::cos(kCoplanar))
      continue;
    // t = (a, b, c) with the shared edge a -> b; u runs it b -> a and has its own vertex d.
    const auto& T = triangles[t];
    int k = 0;
    while (std::pair(std::min(T[k], T[(k + 1) % 3]), std::max(T[k], T[(k + 1) % 3])) != edge) ++k;
    const std::uint32_t a = T[k], b = T[(k + 1) % 3], c = T[(k + 2) % 3];
    const auto& U = triangles[u];
    std::uint32_t d = U[0];
    for (std::uint32_t v : U)
      if (v != a && v != b) d = v;
    if (d == c) continue;
    // The quad a-d-b-c is convex when both new triangles (c, a, d) and (d, b, c) face the same
    // way as the old ones.
    const std::array<std::uint32_t, 3> first = {c, a, d}, second = {d, b, c};
    const Eigen::Vector3d n = nt + nu;
    if (normal(first).dot(n) <= 1e-12 * n.squaredNorm() ||
        normal(second).dot(n) <= 1e-12 * n.squaredNorm())
      continue;
    triangles[t] = first;
    triangles[u] = second;
    flipped[t] = flipped[u] = true;
  }
  TargetModel out = model;
  out.mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
  return out;
}

Result<TargetModel> perturbModel(const TargetModel& model, const ModelPerturbation& perturbation) {
  CDFF_RETURN_IF_ERROR(perturbation.validate());
  CDFF_RETURN_IF_ERROR(model.validate());
  Result<TargetModel> out = removeParts(model, perturbation.remove_parts);
  if (!out) return out.status();
  out = scaleModel(*out, Eigen::Vector3d::Ones() + perturbation.scale_error);
  for (const ExtraBox& box : perturbation.add_boxes) {
    out = addBox(*out, box);
    if (!out) return out.status();
  }
  if (perturbation.flip_diagonals) out = flipDiagonals(*out);
  if (perturbation.max_edge > 0) out = splitLongEdges(*out, perturbation.max_edge);
  if (!out) return out.status();
  CDFF_RETURN_IF_ERROR(out->validate());
  return out;
}

}  // namespace cdff::egse
