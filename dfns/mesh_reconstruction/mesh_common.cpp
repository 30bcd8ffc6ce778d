#include "mesh_common.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "cdff/types/point_spacing.hpp"
#include "cdff/types/triangle.hpp"

namespace cdff::dfn::meshing {
namespace {

constexpr std::size_t kMinPoints = 9;  // pointSpacing needs 8 neighbours

/// Unit normals from the neighbourhoods' least spread (the covariance's smallest eigenvector),
/// turned away from the centroid or towards the viewpoint.
std::vector<Point4f> estimateNormals(const Prepared& data, const Settings& settings) {
  const Buffer<Point4f>& points = data.cloud.points;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Point4f& p : points) centroid += p.vec().cast<double>();
  centroid /= static_cast<double>(points.size());
  const Eigen::Vector3f centre = centroid.cast<float>();
  std::vector<Point4f> normals;
  normals.reserve(points.size());
  std::vector<KdTree3f::Neighbour> found;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver;
  for (const Point4f& point : points) {
    const Eigen::Vector3f p = point.vec();
    data.tree.kNearest(p, settings.normal_neighbours, found);
    // About the neighbourhood's mean, accumulated relative to p (single precision far from the
    // origin).
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    Eigen::Matrix3f sum2 = Eigen::Matrix3f::Zero();
    for (const KdTree3f::Neighbour& nb : found) {
      const Eigen::Vector3f d = points[nb.index].vec() - p;
      sum += d;
      sum2.noalias() += d * d.transpose();
    }
    const float count = static_cast<float>(found.size());
    const Eigen::Vector3f mean = sum / count;
    solver.computeDirect(sum2 / count - mean * mean.transpose());
    Eigen::Vector3f n = solver.eigenvectors().col(0).normalized();  // smallest eigenvalue first
    const Eigen::Vector3f away =
        settings.outward ? Eigen::Vector3f(p - centre) : Eigen::Vector3f(settings.viewpoint - p);
    if (n.dot(away) < 0) n = -n;
    normals.emplace_back(n.x(), n.y(), n.z());
    normals.back().pad = 0.0f;
  }
  return normals;
}

/// An error when the points lie along a line: their spread across its direction (the square
/// root of the covariance's middle eigenvalue) is under half a point spacing.
Status checkSpread(const Prepared& data) {
  const Buffer<Point4f>& points = data.cloud.points;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Point4f& p : points) mean += p.vec().cast<double>();
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Point4f& p : points) {
    const Eigen::Vector3d d = p.vec().cast<double>() - mean;
    covariance.noalias() += d * d.transpose();
  }
  covariance /= static_cast<double>(points.size());
  const Eigen::Vector3d spread =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance, Eigen::EigenvaluesOnly)
          .eigenvalues()
          .cwiseMax(0.0)
          .cwiseSqrt();  // ascending
  if (spread[1] < 0.5 * data.spacing)
    return invalidInput(
        "the {} usable points of input 'cloud' (frame '{}') lie along a line: {:.3g} m across "
        "it (standard deviation), under half their point spacing {:.3g} m; expected points "
        "sampling a surface",
        points.size(), data.cloud.frame_id, spread[1], data.spacing);
  return Status::ok();
}

Eigen::Vector3f faceNormal(const std::vector<Eigen::Vector3f>& v, const Triangle& t) {
  return (v[t[1]] - v[t[0]]).cross(v[t[2]] - v[t[0]]);  // twice the area long
}

}  // namespace

Result<Prepared> prepare(const PointCloud& input, const Settings& settings, const Warn& warn) {
  CDFF_RETURN_IF_ERROR(input.validate("input 'cloud'", /*require_finite=*/false));
  const bool has_normals = input.hasNormals();
  std::vector<Point4f> points, normals;
  points.reserve(input.size());
  if (has_normals) normals.reserve(input.size());
  for (std::size_t i = 0; i < input.size(); ++i) {
    if (!input.points[i].vec().allFinite()) continue;
    if (has_normals) {
      const Eigen::Vector3f n = input.normals[i].vec();
      const float length = n.norm();
      if (!std::isfinite(length) || length < 1e-6f) continue;
      normals.emplace_back(n.x() / length, n.y() / length, n.z() / length);
      normals.back().pad = 0.0f;
    }
    points.push_back(input.points[i]);
  }
  Prepared data;
  data.dropped = input.size() - points.size();
  if (data.dropped > 0)
    warn(
        fmt::format("{} of the {} points of input 'cloud' (frame '{}') have a non-finite "
                    "coordinate{}; they are left out",
                    data.dropped, input.size(), input.frame_id,
                    has_normals ? " or a non-finite or zero normal" : ""));
  if (points.size() < kMinPoints)
    return invalidInput(
        "input 'cloud' (frame '{}') has {} usable points (of {}); expected at least {} points "
        "sampling a surface",
        input.frame_id, points.size(), input.size(), kMinPoints);
  data.cloud.stamp = input.stamp;
  data.cloud.frame_id = input.frame_id;
  data.cloud.points = Buffer<Point4f>::fromVector(std::move(points));
  data.spacing = settings.point_spacing > 0 ? settings.point_spacing : pointSpacing(data.cloud);
  if (!(data.spacing > 0))
    return invalidInput(
        "input 'cloud' (frame '{}'): no point of its {} usable ones has 8 distinct neighbours "
        "(the points coincide), so it has no point spacing; expected points sampling a surface",
        input.frame_id, data.cloud.size());
  CDFF_RETURN_IF_ERROR(checkSpread(data));
  data.tree.build(data.cloud.points.span());
  data.min = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  data.max = -data.min;
  for (const Point4f& p : data.cloud.points) {
    data.min = data.min.cwiseMin(p.vec());
    data.max = data.max.cwiseMax(p.vec());
  }
  data.cloud.normals = Buffer<Point4f>::fromVector(has_normals ? std::move(normals)
                                                               : estimateNormals(data, settings));
  return data;
}

void trimFarFromPoints(const Prepared& data, double max_distance,
                       const std::vector<Eigen::Vector3f>& vertices,
                       std::vector<Triangle>& triangles) {
  const auto limit = static_cast<float>(max_distance * max_distance);
  std::vector<char> near(vertices.size());
  KdTree3f::Neighbour found;
  for (std::size_t i = 0; i < vertices.size(); ++i)
    near[i] = data.tree.nearest(vertices[i], limit, found) ? 1 : 0;
  std::erase_if(triangles,
                [&](const Triangle& t) { return !near[t[0]] || !near[t[1]] || !near[t[2]]; });
}

void orientByVertexNormals(const std::vector<Eigen::Vector3f>& vertices,
                           const std::vector<Eigen::Vector3f>& normals,
                           std::vector<Triangle>& triangles) {
  for (Triangle& t : triangles)
    if (faceNormal(vertices, t).dot(normals[t[0]] + normals[t[1]] + normals[t[2]]) < 0)
      std::swap(t[1], t[2]);
}

void orientByNearestPoints(const Prepared& data, const std::vector<Eigen::Vector3f>& vertices,
                           std::vector<Triangle>& triangles) {
  double agreement = 0;  // area-weighted
  KdTree3f::Neighbour found;
  for (const Triangle& t : triangles) {
    const Eigen::Vector3f centre = (vertices[t[0]] + vertices[t[1]] + vertices[t[2]]) / 3.0f;
    if (!data.tree.nearest(centre, std::numeric_limits<float>::infinity(), found)) continue;
    agreement += faceNormal(vertices, t).dot(data.cloud.normals[found.index].vec());
  }
  if (agreement < 0)
    for (Triangle& t : triangles) std::swap(t[1], t[2]);
}

TriangleMesh buildMesh(const Prepared& data, const std::vector<Eigen::Vector3f>& vertices,
                       const std::vector<Triangle>& triangles) {
  constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> index(vertices.size(), kUnused);
  std::vector<Eigen::Vector3f> kept_vertices, normals;
  std::vector<Triangle> kept;
  kept.reserve(triangles.size());
  for (const Triangle& t : triangles) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    const Eigen::Vector3f n = faceNormal(vertices, t);
    if (!(n.squaredNorm() > 0)) continue;
    Triangle mapped;
    for (int k = 0; k < 3; ++k) {
      std::uint32_t& i = index[t[k]];
      if (i == kUnused) {
        i = static_cast<std::uint32_t>(kept_vertices.size());
        kept_vertices.push_back(vertices[t[k]]);
        normals.push_back(Eigen::Vector3f::Zero());
      }
      mapped[k] = i;
      normals[i] += n;  // area-weighted
    }
    kept.push_back(mapped);
  }
  KdTree3f::Neighbour found;
  for (std::size_t i = 0; i < normals.size(); ++i) {
    const float length = normals[i].norm();
    if (length > 0) {
      normals[i] /= length;
    } else if (data.tree.nearest(kept_vertices[i], std::numeric_limits<float>::infinity(), found)) {
      normals[i] = data.cloud.normals[found.index].vec();  // its triangles cancel out
    }
  }
  TriangleMesh mesh;
  mesh.stamp = data.cloud.stamp;
  mesh.frame_id = data.cloud.frame_id;
  mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(kept_vertices));
  mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
  mesh.triangles = Buffer<Triangle>::fromVector(std::move(kept));
  return mesh;
}

double fitFraction(const PointCloud& points, const TriangleMesh& mesh, double tolerance) {
  if (points.empty() || mesh.triangles.empty()) return 0;
  const auto tol = static_cast<float>(tolerance);
  Eigen::Array3f lo = Eigen::Array3f::Constant(std::numeric_limits<float>::max());
  Eigen::Array3f hi = -lo;
  double edges = 0;
  for (const Triangle& t : mesh.triangles) {
    const Eigen::Vector3f &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]],
                          &c = mesh.vertices[t[2]];
    lo = lo.min(a.array()).min(b.array()).min(c.array());
    hi = hi.max(a.array()).max(b.array()).max(c.array());
    edges += (b - a).norm() + (c - b).norm() + (a - c).norm();
  }
  lo -= tol;
  hi += tol;
  // Cells as wide as a typical triangle's box grown by the tolerance, so that most triangles
  // are in 1 to 8 of them (narrower cells multiply the entries to sort); at most 2^20 a side
  // (21-bit keys).
  const float cell = std::max(static_cast<float>(edges / (3.0 * mesh.triangleCount())) + 2 * tol,
                              (hi - lo).maxCoeff() / float(1 << 20));
  auto cellOf = [&](const Eigen::Array3f& p) {
    return ((p - lo) / cell).floor().cast<std::int64_t>().max(0).min((1 << 20));
  };
  auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return static_cast<std::uint64_t>(x) | static_cast<std::uint64_t>(y) << 21 |
           static_cast<std::uint64_t>(z) << 42;
  };
  std::vector<std::pair<std::uint64_t, std::uint32_t>> entries;
  entries.reserve(mesh.triangleCount() * 8);
  for (std::size_t i = 0; i < mesh.triangleCount(); ++i) {
    const Triangle& t = mesh.triangles[i];
    const Eigen::Array3f &a = mesh.vertices[t[0]].array(), &b = mesh.vertices[t[1]].array(),
                         &c = mesh.vertices[t[2]].array();
    const Eigen::Array<std::int64_t, 3, 1> c0 = cellOf(a.min(b).min(c) - tol);
    const Eigen::Array<std::int64_t, 3, 1> c1 = cellOf(a.max(b).max(c) + tol);
    for (std::int64_t z = c0.z(); z <= c1.z(); ++z)
      for (std::int64_t y = c0.y(); y <= c1.y(); ++y)
        for (std::int64_t x = c0.x(); x <= c1.x(); ++x)
          entries.emplace_back(key(x, y, z), static_cast<std::uint32_t>(i));
  }
  std::sort(entries.begin(), entries.end());
  const double tol2 = static_cast<double>(tol) * tol;
  std::size_t finite = 0, within = 0;
  for (const Point4f& point : points.points) {
    const Eigen::Array3f p = point.vec().array();
    if (!p.allFinite()) continue;
    ++finite;
    if ((p < lo).any() || (p > hi).any()) continue;
    const Eigen::Array<std::int64_t, 3, 1> c = cellOf(p);
    const std::uint64_t k = key(c.x(), c.y(), c.z());
    const Eigen::Vector3d q = p.matrix().cast<double>();
    for (auto it = std::lower_bound(entries.begin(), entries.end(), std::make_pair(k, 0u));
         it != entries.end() && it->first == k; ++it) {
      const Triangle& t = mesh.triangles[it->second];
      const Eigen::Vector3d on = closestPointOnTriangle(q, mesh.vertices[t[0]].cast<double>(),
                                                        mesh.vertices[t[1]].cast<double>(),
                                                        mesh.vertices[t[2]].cast<double>());
      if ((on - q).squaredNorm() <= tol2) {
        ++within;
        break;
      }
    }
  }
  return finite == 0 ? 0.0 : static_cast<double>(within) / static_cast<double>(finite);
}

Status publish(MeshReconstruction::Outputs& out, const Prepared& data, const Settings& settings,
               TriangleMesh mesh) {
  if (mesh.triangles.empty()) {
    const Eigen::Vector3f extent = data.max - data.min;
    return numericalFailure(
        "no triangle from the {} points of input 'cloud' (frame '{}', spacing {:.3g} m, extent "
        "{:.3g} x {:.3g} x {:.3g} m); expected points sampling a surface, not a line or "
        "scattered points",
        data.cloud.size(), data.cloud.frame_id, data.spacing, extent.x(), extent.y(), extent.z());
  }
  const double tolerance = settings.fit_tolerance > 0 ? settings.fit_tolerance : data.spacing;
  const double fit = fitFraction(data.cloud, mesh, tolerance);
  out.triangles.set(static_cast<int>(mesh.triangleCount()));
  out.vertices.set(static_cast<int>(mesh.vertexCount()));
  out.point_spacing.set(data.spacing);
  out.fit_fraction.set(fit);
  out.dropped_points.set(static_cast<int>(data.dropped));
  out.mesh.set(std::move(mesh));
  return Status::ok();
}

}  // namespace cdff::dfn::meshing
