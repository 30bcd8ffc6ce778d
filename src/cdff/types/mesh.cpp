#include "cdff/types/mesh.hpp"

#include <cmath>
#include <vector>

#include <Eigen/Geometry>

namespace cdff {

Status TriangleMesh::validate(const char* what) const {
  if (triangles.empty()) return invalidInput("{} has no triangles; expected at least one", what);
  if (!vertex_normals.empty() && vertex_normals.size() != vertices.size())
    return invalidInput("{} has {} vertices but {} normals; expected one per vertex or none", what,
                        vertices.size(), vertex_normals.size());
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (!vertices[i].allFinite()) return invalidInput("{} vertex {} is not finite", what, i);
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (std::uint32_t index : triangles[t])
      if (index >= vertices.size())
        return invalidInput("{} triangle {} uses vertex {}; expected an index < {}", what, t, index,
                            vertices.size());
  return Status::ok();
}

double TriangleMesh::surfaceArea() const {
  double total = 0;
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = vertices[t[0]].cast<double>();
    total +=
        0.5 * (vertices[t[1]].cast<double>() - a).cross(vertices[t[2]].cast<double>() - a).norm();
  }
  return total;
}

namespace {

// SplitMix64: a tiny generator whose output is fixed by its definition, unlike the standard
// distributions, so that a seed gives the same samples with every standard library.
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  // [0, 1)
};

}  // namespace

Result<PointCloud> sampleSurface(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed,
                                 SampleNormals normals,
                                 std::vector<std::uint32_t>* sample_triangles) {
  CDFF_RETURN_IF_ERROR(mesh.validate("mesh to sample"));
  const bool has_vertex_normals = !mesh.vertex_normals.empty();
  if (normals == SampleNormals::kVertex && !has_vertex_normals)
    return invalidInput(
        "mesh to sample has no vertex normals; expected them for interpolated normals (or use "
        "face normals)");
  const bool interpolate =
      normals == SampleNormals::kVertex || (normals == SampleNormals::kAuto && has_vertex_normals);
  std::vector<double> cumulative(mesh.triangles.size());
  double total = 0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>();
    total += 0.5 * (mesh.vertices[tri[1]].cast<double>() - a)
                       .cross(mesh.vertices[tri[2]].cast<double>() - a)
                       .norm();
    cumulative[t] = total;
  }
  if (!(total > 0))
    return invalidInput("mesh to sample has zero surface area ({} degenerate triangles)",
                        mesh.triangles.size());
  if (count == 0) return invalidInput("asked for 0 surface samples; expected at least one");

  SplitMix64 rng{seed};
  std::vector<Point4f> points, point_normals;
  points.reserve(count);
  point_normals.reserve(count);
  if (sample_triangles) sample_triangles->clear();
  const double step = total / static_cast<double>(count);
  const double offset = rng.uniform() * step;
  std::size_t t = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const double position = offset + step * static_cast<double>(i);
    while (t + 1 < cumulative.size() && cumulative[t] <= position) ++t;
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[tri[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[tri[2]].cast<double>();
    // Uniform inside the triangle: fold the unit square onto it.
    double u = rng.uniform(), v = rng.uniform();
    if (u + v > 1.0) {
      u = 1.0 - u;
      v = 1.0 - v;
    }
    const Eigen::Vector3d p = a + u * (b - a) + v * (c - a);
    Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    if (interpolate) {
      const Eigen::Vector3d smooth = (1.0 - u - v) * mesh.vertex_normals[tri[0]].cast<double>() +
                                     u * mesh.vertex_normals[tri[1]].cast<double>() +
                                     v * mesh.vertex_normals[tri[2]].cast<double>();
      if (smooth.norm() > 1e-9) n = smooth.normalized();
    }
    points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                        static_cast<float>(p.z()));
    Point4f normal(static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()));
    normal.pad = 0.0f;
    point_normals.push_back(normal);
    if (sample_triangles) sample_triangles->push_back(static_cast<std::uint32_t>(t));
  }
  PointCloud cloud;
  cloud.stamp = mesh.stamp;
  cloud.frame_id = mesh.frame_id;
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  cloud.normals = Buffer<Point4f>::fromVector(std::move(point_normals));
  return cloud;
}

}  // namespace cdff
