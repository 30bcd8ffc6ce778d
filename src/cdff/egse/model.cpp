#include "cdff/egse/model.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

#include "cdff/egse/rng.hpp"

namespace cdff::egse {

Status TargetModel::validate() const {
  CDFF_RETURN_IF_ERROR(mesh.validate(("model '" + name + "'").c_str()));
  if (mesh.vertex_normals.size() != mesh.vertices.size())
    return invalidInput("model '{}' has {} vertices but {} normals; expected one normal per vertex",
                        name, mesh.vertices.size(), mesh.vertex_normals.size());
  if (triangle_material.size() != mesh.triangles.size())
    return invalidInput("model '{}' has {} triangles but {} triangle materials; expected one each",
                        name, mesh.triangles.size(), triangle_material.size());
  if (materials.empty())
    return invalidInput("model '{}' has no materials; expected at least one", name);
  for (std::size_t t = 0; t < triangle_material.size(); ++t)
    if (triangle_material[t] >= materials.size())
      return invalidInput("model '{}' triangle {} uses material {}; expected an index < {}", name,
                          t, triangle_material[t], materials.size());
  if (parts.empty() != triangle_part.empty() ||
      (!parts.empty() && triangle_part.size() != mesh.triangles.size()))
    return invalidInput(
        "model '{}' has {} parts and {} triangle parts for {} triangles; expected "
        "one part per triangle, or none",
        name, parts.size(), triangle_part.size(), mesh.triangles.size());
  for (std::size_t t = 0; t < triangle_part.size(); ++t)
    if (triangle_part[t] >= parts.size())
      return invalidInput("model '{}' triangle {} belongs to part {}; expected an index < {}", name,
                          t, triangle_part[t], parts.size());
  for (std::size_t p = 0; p < polygons.size(); ++p) {
    if (!parts.empty() && polygons[p].part >= parts.size())
      return invalidInput("model '{}' polygon {} belongs to part {}; expected an index < {}", name,
                          p, polygons[p].part, parts.size());
    if (polygons[p].vertices.size() < 3)
      return invalidInput("model '{}' polygon {} has {} vertices; expected at least 3", name, p,
                          polygons[p].vertices.size());
    for (std::uint32_t v : polygons[p].vertices)
      if (v >= mesh.vertices.size())
        return invalidInput("model '{}' polygon {} uses vertex {}; expected an index < {}", name, p,
                            v, mesh.vertices.size());
  }
  return Status::ok();
}

Eigen::AlignedBox3d TargetModel::bounds() const {
  Eigen::AlignedBox3d box;
  for (const auto& v : mesh.vertices) box.extend(v.cast<double>());
  return box;
}

Eigen::Vector3d TargetModel::boundingCentre() const {
  return bounds().center();
}

double TargetModel::boundingRadius() const {
  const Eigen::Vector3d c = boundingCentre();
  double r = 0;
  for (const auto& v : mesh.vertices) r = std::max(r, (v.cast<double>() - c).norm());
  return r;
}

double TargetModel::surfaceArea() const {
  double area = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[t[2]].cast<double>();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

// ---------------------------------------------------------------------------------------------

ModelBuilder::ModelBuilder(std::string name)
    : name_(std::move(name)), builtin_index_(static_cast<std::size_t>(MaterialId::kCount), -1) {}

std::uint16_t ModelBuilder::material(MaterialId id) {
  int& index = builtin_index_[static_cast<std::size_t>(id)];
  if (index < 0) index = addMaterial(builtinMaterial(id));
  return static_cast<std::uint16_t>(index);
}

std::uint16_t ModelBuilder::addMaterial(const Material& material) {
  materials_.push_back(material);
  return static_cast<std::uint16_t>(materials_.size() - 1);
}

void ModelBuilder::beginPart(const std::string& name) {
  const auto it = std::find(parts_.begin(), parts_.end(), name);
  const auto index = static_cast<std::uint16_t>(it - parts_.begin());
  if (it == parts_.end()) parts_.push_back(name);
  part_starts_.push_back({triangles_.size(), polygons_.size(), index});
}

std::uint32_t ModelBuilder::addVertex(const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  vertices_.push_back(p.cast<float>());
  normals_.push_back(n.normalized().cast<float>());
  return static_cast<std::uint32_t>(vertices_.size() - 1);
}

void ModelBuilder::addPolygon(const std::vector<Eigen::Vector3d>& points, std::uint16_t material) {
  // Newell's method: robust normal of a planar polygon, pointing out for counter-clockwise order.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& a = points[i];
    const Eigen::Vector3d& b = points[(i + 1) % points.size()];
    normal += Eigen::Vector3d((a.y() - b.y()) * (a.z() + b.z()), (a.z() - b.z()) * (a.x() + b.x()),
                              (a.x() - b.x()) * (a.y() + b.y()));
  }
  if (normal.norm() < 1e-15) return;  // degenerate
  ModelPolygon polygon;
  polygon.material = material;
  for (const auto& p : points) polygon.vertices.push_back(addVertex(p, normal));
  for (std::size_t i = 1; i + 1 < points.size(); ++i) {
    triangles_.push_back({polygon.vertices[0], polygon.vertices[i], polygon.vertices[i + 1]});
    triangle_material_.push_back(material);
  }
  polygons_.push_back(std::move(polygon));
}

void ModelBuilder::addBox(const Eigen::Isometry3d& pose, const Eigen::Vector3d& h,
                          const std::array<std::uint16_t, 6>& m) {
  auto corner = [&](double sx, double sy, double sz) {
    return pose * Eigen::Vector3d(sx * h.x(), sy * h.y(), sz * h.z());
  };
  // Each face counter-clockwise seen from outside.
  addPolygon({corner(-1, -1, -1), corner(-1, -1, 1), corner(-1, 1, 1), corner(-1, 1, -1)}, m[0]);
  addPolygon({corner(1, -1, -1), corner(1, 1, -1), corner(1, 1, 1), corner(1, -1, 1)}, m[1]);
  addPolygon({corner(-1, -1, -1), corner(1, -1, -1), corner(1, -1, 1), corner(-1, -1, 1)}, m[2]);
  addPolygon({corner(-1, 1, -1), corner(-1, 1, 1), corner(1, 1, 1), corner(1, 1, -1)}, m[3]);
  addPolygon({corner(-1, -1, -1), corner(-1, 1, -1), corner(1, 1, -1), corner(1, -1, -1)}, m[4]);
  addPolygon({corner(-1, -1, 1), corner(1, -1, 1), corner(1, 1, 1), corner(-1, 1, 1)}, m[5]);
}

void ModelBuilder::addBox(const Eigen::Isometry3d& pose, const Eigen::Vector3d& half_extents,
                          std::uint16_t material) {
  addBox(pose, half_extents, {material, material, material, material, material, material});
}

void ModelBuilder::addRevolution(const Eigen::Isometry3d& pose,
                                 const std::vector<Eigen::Vector2d>& profile, int segments,
                                 std::uint16_t material, bool outward) {
  if (profile.size() < 2 || segments < 3) return;
  const Eigen::Matrix3d R = pose.linear();
  auto point = [&](const Eigen::Vector2d& rz, double angle) {
    return pose * Eigen::Vector3d(rz.x() * std::cos(angle), rz.x() * std::sin(angle), rz.y());
  };
  // One smooth band per profile segment: its normal is perpendicular to the segment in the
  // meridian plane, so that bands meeting at a sharp profile corner keep a crease.
  for (std::size_t s = 0; s + 1 < profile.size(); ++s) {
    const Eigen::Vector2d p0 = profile[s], p1 = profile[s + 1];
    const Eigen::Vector2d d = p1 - p0;
    if (d.norm() < 1e-12) continue;
    // Meridian normal (radial, axial) of the segment; the outward one points away from the axis
    // for a profile going up (increasing z).
    Eigen::Vector2d mn(d.y(), -d.x());
    mn.normalize();
    if (!outward) mn = -mn;
    std::vector<std::uint32_t> ring0, ring1;
    for (int i = 0; i < segments; ++i) {
      const double a = 2.0 * M_PI * i / segments;
      const Eigen::Vector3d n =
          R * Eigen::Vector3d(mn.x() * std::cos(a), mn.x() * std::sin(a), mn.y());
      ring0.push_back(addVertex(point(p0, a), n));
      ring1.push_back(addVertex(point(p1, a), n));
    }
    for (int i = 0; i < segments; ++i) {
      const int j = (i + 1) % segments;
      // Counter-clockwise seen from the side the normals face.
      std::array<std::uint32_t, 4> quad = {ring0[i], ring0[j], ring1[j], ring1[i]};
      if (!outward) quad = {ring0[i], ring1[i], ring1[j], ring0[j]};
      // Orientation check against the band normal (robust to descending profiles).
      const Eigen::Vector3d qa = vertices_[quad[0]].cast<double>(),
                            qb = vertices_[quad[1]].cast<double>(),
                            qc = vertices_[quad[2]].cast<double>(),
                            qd = vertices_[quad[3]].cast<double>();
      Eigen::Vector3d fn = (qc - qa).cross(qd - qb);
      if (fn.norm() < 1e-18) fn = (qb - qa).cross(qc - qa);
      const Eigen::Vector3d mid_normal =
          normals_[quad[0]].cast<double>() + normals_[quad[2]].cast<double>();
      if (fn.dot(mid_normal) < 0) std::swap(quad[1], quad[3]);
      ModelPolygon polygon;
      polygon.material = material;
      // Degenerate quads (a profile point on the axis) become triangles.
      for (std::uint32_t v : quad) {
        if (!polygon.vertices.empty() &&
            (vertices_[polygon.vertices.back()] - vertices_[v]).norm() < 1e-9f)
          continue;
        polygon.vertices.push_back(v);
      }
      if (polygon.vertices.size() > 3 &&
          (vertices_[polygon.vertices.front()] - vertices_[polygon.vertices.back()]).norm() < 1e-9f)
        polygon.vertices.pop_back();
      if (polygon.vertices.size() < 3) continue;
      for (std::size_t k = 1; k + 1 < polygon.vertices.size(); ++k) {
        triangles_.push_back({polygon.vertices[0], polygon.vertices[k], polygon.vertices[k + 1]});
        triangle_material_.push_back(material);
      }
      polygons_.push_back(std::move(polygon));
    }
  }
}

void ModelBuilder::addAnnulus(const Eigen::Isometry3d& pose, double inner, double outer,
                              int segments, std::uint16_t material, bool facing_positive_z) {
  if (inner <= 0.0) {
    std::vector<Eigen::Vector3d> points;
    for (int i = 0; i < segments; ++i) {
      const double a = 2.0 * M_PI * (facing_positive_z ? i : segments - i) / segments;
      points.push_back(pose * Eigen::Vector3d(outer * std::cos(a), outer * std::sin(a), 0.0));
    }
    addPolygon(points, material);
    return;
  }
  for (int i = 0; i < segments; ++i) {
    double a0 = 2.0 * M_PI * i / segments, a1 = 2.0 * M_PI * (i + 1) / segments;
    if (!facing_positive_z) std::swap(a0, a1);
    auto p = [&](double r, double a) {
      return pose * Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0.0);
    };
    addPolygon({p(inner, a0), p(outer, a0), p(outer, a1), p(inner, a1)}, material);
  }
}

TargetModel ModelBuilder::build() {
  TargetModel model;
  if (!part_starts_.empty()) {
    // Whatever was added before the first part is the first part's too.
    part_starts_.front().triangle = 0;
    part_starts_.front().polygon = 0;
    model.triangle_part.resize(triangles_.size());
    for (std::size_t s = 0; s < part_starts_.size(); ++s) {
      const PartStart& start = part_starts_[s];
      const bool last = s + 1 == part_starts_.size();
      const std::size_t triangle_end = last ? triangles_.size() : part_starts_[s + 1].triangle;
      const std::size_t polygon_end = last ? polygons_.size() : part_starts_[s + 1].polygon;
      for (std::size_t t = start.triangle; t < triangle_end; ++t)
        model.triangle_part[t] = start.part;
      for (std::size_t p = start.polygon; p < polygon_end; ++p) polygons_[p].part = start.part;
    }
    model.parts = std::move(parts_);
  }
  model.name = name_;
  model.mesh.frame_id = "target";
  model.mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices_));
  model.mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals_));
  model.mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles_));
  model.triangle_material = std::move(triangle_material_);
  model.materials = std::move(materials_);
  model.polygons = std::move(polygons_);
  if (model.materials.empty()) model.materials.push_back(builtinMaterial(MaterialId::kStructure));
  return model;
}

// ---------------------------------------------------------------------------------------------

namespace {

struct QuantisedKey {
  std::int64_t x, y, z;
  bool operator==(const QuantisedKey&) const = default;
};
struct QuantisedKeyHash {
  std::size_t operator()(const QuantisedKey& k) const {
    return static_cast<std::size_t>(mix64(static_cast<std::uint64_t>(k.x) * 73856093ULL ^
                                          static_cast<std::uint64_t>(k.y) * 19349663ULL ^
                                          static_cast<std::uint64_t>(k.z) * 83492791ULL));
  }
};

}  // namespace

std::vector<std::uint32_t> weldVertices(const TriangleMesh& mesh, double tolerance,
                                        std::vector<Eigen::Vector3f>* welded_positions) {
  std::unordered_map<QuantisedKey, std::uint32_t, QuantisedKeyHash> index;
  std::vector<std::uint32_t> remap(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3f& v = mesh.vertices[i];
    const QuantisedKey key{std::llround(v.x() / tolerance), std::llround(v.y() / tolerance),
                           std::llround(v.z() / tolerance)};
    auto [it, inserted] = index.emplace(key, static_cast<std::uint32_t>(index.size()));
    if (inserted && welded_positions) welded_positions->push_back(v);
    remap[i] = it->second;
  }
  return remap;
}

std::vector<ModelEdge> extractEdges(const TargetModel& model, double min_dihedral,
                                    double crease_threshold) {
  const TriangleMesh& mesh = model.mesh;
  std::vector<Eigen::Vector3f> positions;
  const std::vector<std::uint32_t> remap = weldVertices(mesh, 1e-5, &positions);
  struct Adjacent {
    std::vector<Eigen::Vector3f> normals;
  };
  std::map<std::pair<std::uint32_t, std::uint32_t>, Adjacent> edges;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
    const Eigen::Vector3f n = (b - a).cross(c - a);
    if (n.norm() < 1e-14f) continue;
    for (int k = 0; k < 3; ++k) {
      std::uint32_t i = remap[t[k]], j = remap[t[(k + 1) % 3]];
      if (i == j) continue;
      if (i > j) std::swap(i, j);
      edges[{i, j}].normals.push_back(n.normalized());
    }
  }
  std::vector<ModelEdge> result;
  for (const auto& [key, adjacent] : edges) {
    ModelEdge edge;
    edge.a = positions[key.first];
    edge.b = positions[key.second];
    edge.normal_left = adjacent.normals.front();
    if (adjacent.normals.size() == 1) {
      edge.normal_right = edge.normal_left;
      edge.boundary = true;
      edge.crease = true;
      edge.dihedral_angle = 0;
      result.push_back(edge);
      continue;
    }
    // Non-manifold edges keep the pair of faces that bend most.
    float best = -1;
    for (std::size_t p = 0; p < adjacent.normals.size(); ++p)
      for (std::size_t q = p + 1; q < adjacent.normals.size(); ++q) {
        const float angle =
            std::acos(std::clamp(adjacent.normals[p].dot(adjacent.normals[q]), -1.0f, 1.0f));
        if (angle > best) {
          best = angle;
          edge.normal_left = adjacent.normals[p];
          edge.normal_right = adjacent.normals[q];
        }
      }
    edge.dihedral_angle = best;
    if (best < min_dihedral) continue;
    edge.crease = best >= crease_threshold;
    result.push_back(edge);
  }
  return result;
}

PointCloud samplePointCloud(const TargetModel& model, std::size_t count, std::uint64_t seed) {
  const TriangleMesh& mesh = model.mesh;
  std::vector<double> cumulative;
  cumulative.reserve(mesh.triangles.size());
  double total = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    total += 0.5 * (mesh.vertices[t[1]].cast<double>() - a)
                       .cross(mesh.vertices[t[2]].cast<double>() - a)
                       .norm();
    cumulative.push_back(total);
  }
  Rng rng = Rng::stream(seed, "model_point_cloud");
  std::vector<Point4f> points, normals;
  std::vector<float> intensity;
  points.reserve(count);
  normals.reserve(count);
  intensity.reserve(count);
  for (std::size_t i = 0; i < count && total > 0; ++i) {
    const double pick = rng.uniform() * total;
    const std::size_t tri = std::min<std::size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin(),
        cumulative.size() - 1);
    const auto& t = mesh.triangles[tri];
    // Uniform on the triangle: the square-root parameterisation.
    const double r1 = std::sqrt(rng.uniform()), r2 = rng.uniform();
    const double wa = 1 - r1, wb = r1 * (1 - r2), wc = r1 * r2;
    const Eigen::Vector3d p = wa * mesh.vertices[t[0]].cast<double>() +
                              wb * mesh.vertices[t[1]].cast<double>() +
                              wc * mesh.vertices[t[2]].cast<double>();
    const Eigen::Vector3d n = (wa * mesh.vertex_normals[t[0]].cast<double>() +
                               wb * mesh.vertex_normals[t[1]].cast<double>() +
                               wc * mesh.vertex_normals[t[2]].cast<double>())
                                  .normalized();
    points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                        static_cast<float>(p.z()));
    Point4f normal(static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()));
    normal.pad = 0.0f;
    normals.push_back(normal);
    intensity.push_back(model.triangleMaterial(tri).lidar_reflectivity);
  }
  PointCloud cloud;
  cloud.frame_id = mesh.frame_id;
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  cloud.normals = Buffer<Point4f>::fromVector(std::move(normals));
  cloud.intensity = Buffer<float>::fromVector(std::move(intensity));
  return cloud;
}

TargetModel transformModel(const TargetModel& model, const Eigen::Isometry3d& transform,
                           double scale) {
  TargetModel out = model;
  std::vector<Eigen::Vector3f> vertices, normals;
  vertices.reserve(model.mesh.vertices.size());
  normals.reserve(model.mesh.vertex_normals.size());
  const Eigen::Matrix3d R = transform.linear();
  for (const auto& v : model.mesh.vertices)
    vertices.push_back((transform * (scale * v.cast<double>())).cast<float>());
  for (const auto& n : model.mesh.vertex_normals)
    normals.push_back((R * n.cast<double>()).normalized().cast<float>());
  out.mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  out.mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
  return out;
}

}  // namespace cdff::egse
