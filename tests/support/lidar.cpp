#include "support/lidar.hpp"

#include <cmath>
#include <limits>
#include <random>

namespace cdff::testing {

namespace {

void appendBox(std::vector<Eigen::Vector3f>& vertices,
               std::vector<std::array<std::uint32_t, 3>>& triangles, const Eigen::Vector3d& half,
               const Eigen::Vector3d& centre) {
  const auto base = static_cast<std::uint32_t>(vertices.size());
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(),
                                 (i & 4) ? half.z() : -half.z());
    vertices.push_back((centre + corner).cast<float>());
  }
  // Quads (counter-clockwise seen from outside) of the faces -x, +x, -y, +y, -z, +z.
  const std::array<std::array<std::uint32_t, 4>, 6> quads{
      {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}}};
  for (const auto& q : quads) {
    triangles.push_back({base + q[0], base + q[1], base + q[2]});
    triangles.push_back({base + q[0], base + q[2], base + q[3]});
  }
}

TriangleMesh makeMesh(std::vector<Eigen::Vector3f> vertices,
                      std::vector<std::array<std::uint32_t, 3>> triangles,
                      const std::string& frame_id) {
  TriangleMesh mesh;
  mesh.frame_id = frame_id;
  mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
  return mesh;
}

// Moeller-Trumbore; returns the ray parameter of the hit or infinity.
double intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                 const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a;
  const Eigen::Vector3d p = dir.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-14) return std::numeric_limits<double>::infinity();
  const double inv = 1.0 / det;
  const Eigen::Vector3d s = origin - a;
  const double u = s.dot(p) * inv;
  if (u < 0 || u > 1) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d q = s.cross(e1);
  const double v = dir.dot(q) * inv;
  if (v < 0 || u + v > 1) return std::numeric_limits<double>::infinity();
  const double t = e2.dot(q) * inv;
  return t > 0 ? t : std::numeric_limits<double>::infinity();
}

}  // namespace

TriangleMesh boxMesh(const Eigen::Vector3d& half_extents, const Eigen::Vector3d& centre,
                     const std::string& frame_id) {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  appendBox(vertices, triangles, half_extents, centre);
  return makeMesh(std::move(vertices), std::move(triangles), frame_id);
}

TriangleMesh satelliteMesh() {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  appendBox(vertices, triangles, {0.6, 0.5, 0.5}, {0, 0, 0});               // bus
  appendBox(vertices, triangles, {0.4, 1.0, 0.015}, {0.1, 1.75, 0.1});      // wing +y
  appendBox(vertices, triangles, {0.4, 1.0, 0.015}, {0.1, -1.75, 0.1});     // wing -y
  appendBox(vertices, triangles, {0.03, 0.1, 0.03}, {0.1, 0.65, 0.1});      // yoke +y
  appendBox(vertices, triangles, {0.03, 0.1, 0.03}, {0.1, -0.65, 0.1});     // yoke -y
  appendBox(vertices, triangles, {0.15, 0.15, 0.2}, {0.25, 0.2, 0.7});      // antenna on +z
  appendBox(vertices, triangles, {0.08, 0.3, 0.3}, {-0.68, -0.05, -0.05});  // adapter on -x
  return makeMesh(std::move(vertices), std::move(triangles), "target");
}

TriangleMesh mergeMeshes(const std::vector<TriangleMesh>& meshes) {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  for (const TriangleMesh& m : meshes) {
    const auto base = static_cast<std::uint32_t>(vertices.size());
    vertices.insert(vertices.end(), m.vertices.begin(), m.vertices.end());
    for (const auto& t : m.triangles) triangles.push_back({base + t[0], base + t[1], base + t[2]});
  }
  return makeMesh(std::move(vertices), std::move(triangles),
                  meshes.empty() ? std::string() : meshes.front().frame_id);
}

PointCloud simulateScan(const TriangleMesh& mesh, const Eigen::Isometry3d& sensor_T_mesh,
                        const ScanOptions& o, std::uint32_t seed, const std::string& frame_id) {
  // Triangles in the sensor frame, with a bounding cone (direction of the centroid, cosine of
  // the angular radius) to skip most ray-triangle tests.
  struct Tri {
    Eigen::Vector3d a, b, c, axis;
    double cos_radius;
  };
  std::vector<Tri> tris;
  for (const auto& t : mesh.triangles) {
    Tri tri;
    tri.a = sensor_T_mesh * mesh.vertices[t[0]].cast<double>();
    tri.b = sensor_T_mesh * mesh.vertices[t[1]].cast<double>();
    tri.c = sensor_T_mesh * mesh.vertices[t[2]].cast<double>();
    const Eigen::Vector3d centroid = (tri.a + tri.b + tri.c) / 3.0;
    const double radius =
        std::max({(tri.a - centroid).norm(), (tri.b - centroid).norm(), (tri.c - centroid).norm()});
    const double distance = centroid.norm();
    tri.axis = centroid / distance;
    tri.cos_radius = radius >= distance ? -1.0 : std::cos(std::asin(radius / distance));
    tris.push_back(tri);
  }
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, o.range_noise);
  std::vector<Point4f> points;
  std::vector<std::uint16_t> rings;
  const int steps = static_cast<int>(std::floor((o.max_azimuth - o.min_azimuth) / o.azimuth_step));
  const std::vector<double> elevations = laserElevations(o);
  for (std::size_t ring = 0; ring < elevations.size(); ++ring) {
    const double elevation = elevations[ring];
    for (int k = 0; k < steps; ++k) {
      const double azimuth = o.min_azimuth + k * o.azimuth_step;
      const Eigen::Vector3d dir(std::cos(elevation) * std::cos(azimuth),
                                std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
      double range = std::numeric_limits<double>::infinity();
      for (const Tri& tri : tris)
        if (dir.dot(tri.axis) >= tri.cos_radius)
          range = std::min(range, intersect(Eigen::Vector3d::Zero(), dir, tri.a, tri.b, tri.c));
      if (!std::isfinite(range) && o.room_half_size > 0) {
        const double largest = dir.cwiseAbs().maxCoeff();
        range = o.room_half_size / largest;
      }
      if (!std::isfinite(range)) continue;
      range += noise(rng);
      if (range < o.min_range || range > o.max_range) continue;
      const Eigen::Vector3d p = dir * range;
      points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                          static_cast<float>(p.z()));
      rings.push_back(static_cast<std::uint16_t>(ring));
    }
  }
  PointCloud cloud;
  cloud.frame_id = frame_id;
  cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  cloud.ring = Buffer<std::uint16_t>::fromVector(std::move(rings));
  return cloud;
}

std::vector<double> laserElevations(const ScanOptions& o) {
  if (!o.elevations.empty()) return o.elevations;
  std::vector<double> elevations;
  for (int ring = 0; ring < o.rings; ++ring)
    elevations.push_back(o.rings == 1 ? o.min_elevation
                                      : o.min_elevation + (o.max_elevation - o.min_elevation) *
                                                              ring / (o.rings - 1));
  return elevations;
}

LidarInfo lidarInfo(const ScanOptions& options, const std::string& frame_id) {
  LidarInfo info;
  info.frame_id = frame_id;
  info.elevations = laserElevations(options);
  info.rotation_rate = 10.0;
  info.min_range = options.min_range;
  info.max_range = options.max_range;
  info.range_noise = options.range_noise;
  return info;
}

PoseError poseError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  PoseError e;
  e.translation = (estimate.translation() - truth.translation()).norm();
  e.rotation = Eigen::AngleAxisd(estimate.linear() * truth.linear().transpose()).angle();
  return e;
}

Eigen::Isometry3d perturb(const Eigen::Isometry3d& pose, double translation, double angle,
                          std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d dt = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized() * translation;
  const Eigen::Vector3d axis = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  Eigen::Isometry3d out = pose;
  out.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * pose.linear();
  out.translation() = pose.translation() + dt;
  return out;
}

}  // namespace cdff::testing
