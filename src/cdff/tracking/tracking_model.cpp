#include "cdff/tracking/tracking_model.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

namespace cdff::tracking {

namespace {

// Welds points on a grid of cells `tolerance` wide: a point joins an earlier point within
// `tolerance` in its own or a neighbouring cell.
class Welder {
 public:
  explicit Welder(double tolerance) : tolerance_(tolerance) {}

  std::uint32_t add(const Eigen::Vector3d& p) {
    const Eigen::Vector3i cell = cellOf(p);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = cells_.find(key(cell + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (std::uint32_t index : it->second)
            if ((points_[index] - p).norm() <= tolerance_) return index;
        }
    const auto index = static_cast<std::uint32_t>(points_.size());
    points_.push_back(p);
    cells_[key(cell)].push_back(index);
    return index;
  }

  std::vector<Eigen::Vector3d> release() { return std::move(points_); }

 private:
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const {
    return (p / tolerance_).array().floor().cast<int>();
  }
  static std::uint64_t key(const Eigen::Vector3i& c) {
    const auto u = [](int v) {
      return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v)) & 0x1FFFFF;
    };
    return u(c.x()) | (u(c.y()) << 21) | (u(c.z()) << 42);
  }

  double tolerance_;
  std::vector<Eigen::Vector3d> points_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
};

// Newell's normal: robust for slightly non-planar or concave polygons.
Eigen::Vector3d newellNormal(const std::vector<Eigen::Vector3d>& p,
                             const std::vector<std::uint32_t>& loop) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const Eigen::Vector3d& a = p[loop[i]];
    const Eigen::Vector3d& b = p[loop[(i + 1) % loop.size()]];
    n += a.cross(b);  // twice the area vector, along the right-hand normal
  }
  return n;
}

// Splits a planar loop into convex pieces: the loop itself when convex, else ear-clipped
// triangles (2D, in the face plane).
std::vector<std::vector<std::uint32_t>> convexPieces(const std::vector<Eigen::Vector3d>& p,
                                                     const std::vector<std::uint32_t>& loop,
                                                     const Eigen::Vector3d& normal) {
  const Eigen::Vector3d u = normal.unitOrthogonal();
  const Eigen::Vector3d v = normal.cross(u);
  std::vector<Eigen::Vector2d> q;
  for (std::uint32_t i : loop) q.emplace_back(p[i].dot(u), p[i].dot(v));
  const auto cross = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                        const Eigen::Vector2d& c) {
    const Eigen::Vector2d ab = b - a, ac = c - a;
    return ab.x() * ac.y() - ab.y() * ac.x();
  };
  const std::size_t n = q.size();
  bool convex = true;
  for (std::size_t i = 0; i < n && convex; ++i)
    convex = cross(q[i], q[(i + 1) % n], q[(i + 2) % n]) >= -1e-15;
  if (convex) return {loop};

  std::vector<std::vector<std::uint32_t>> triangles;
  std::vector<std::size_t> remaining(n);
  for (std::size_t i = 0; i < n; ++i) remaining[i] = i;
  std::size_t guard = 0;
  while (remaining.size() > 3 && guard++ < n * n) {
    bool clipped = false;
    for (std::size_t k = 0; k < remaining.size(); ++k) {
      const std::size_t ia = remaining[(k + remaining.size() - 1) % remaining.size()];
      const std::size_t ib = remaining[k];
      const std::size_t ic = remaining[(k + 1) % remaining.size()];
      if (cross(q[ia], q[ib], q[ic]) <= 1e-15) continue;  // reflex or flat corner
      bool empty = true;
      for (std::size_t j : remaining) {
        if (j == ia || j == ib || j == ic) continue;
        if (cross(q[ia], q[ib], q[j]) >= 0 && cross(q[ib], q[ic], q[j]) >= 0 &&
            cross(q[ic], q[ia], q[j]) >= 0) {
          empty = false;
          break;
        }
      }
      if (!empty) continue;
      triangles.push_back({loop[ia], loop[ib], loop[ic]});
      remaining.erase(remaining.begin() + static_cast<std::ptrdiff_t>(k));
      clipped = true;
      break;
    }
    if (!clipped) break;  // self-intersecting outline: keep what was clipped
  }
  if (remaining.size() == 3)
    triangles.push_back({loop[remaining[0]], loop[remaining[1]], loop[remaining[2]]});
  return triangles;
}

// The outlines of a model's primitives on the welded points: the faces' loops (the polygons',
// then the facets of the cylinders), and the explicit lines (the model's, then the circles'
// segments).
struct Outlines {
  std::vector<std::vector<std::uint32_t>> loops;
  std::vector<bool> loop_is_facet;  // facets of a tessellated cylinder
  std::vector<std::pair<std::uint32_t, std::uint32_t>> explicit_lines;
};

// A face's loop on the welded points: repeated points (consecutive or closing the loop) once;
// fewer than 3 points left is no face.
void addPolygonFaces(const PolygonModel& model, const std::vector<std::uint32_t>& welded,
                     Outlines& out) {
  for (const PolygonModel::Face& face : model.faces) {
    std::vector<std::uint32_t> loop;
    for (std::uint32_t p : face.points) {
      const std::uint32_t w = welded[p];
      if (loop.empty() || loop.back() != w) loop.push_back(w);
    }
    while (loop.size() > 1 && loop.front() == loop.back()) loop.pop_back();
    if (loop.size() < 3) continue;
    out.loops.push_back(std::move(loop));
    out.loop_is_facet.push_back(false);
  }
}

// A cylinder as a prism of n facets between two rings of points around its axis.
void addCylinder(const PolygonModel& model, const PolygonModel::Cylinder& c, int n, Welder& welder,
                 Outlines& out) {
  const Eigen::Vector3d a = model.points[c.a], b = model.points[c.b];
  const Eigen::Vector3d w = (b - a).normalized();
  const Eigen::Vector3d u = w.unitOrthogonal();
  const Eigen::Vector3d v = w.cross(u);
  std::vector<std::uint32_t> ring_a(n), ring_b(n);
  for (int k = 0; k < n; ++k) {
    const double phi = 2.0 * M_PI * k / n;
    const Eigen::Vector3d r = c.radius * (std::cos(phi) * u + std::sin(phi) * v);
    ring_a[k] = welder.add(a + r);
    ring_b[k] = welder.add(b + r);
  }
  for (int k = 0; k < n; ++k) {
    const int k1 = (k + 1) % n;
    out.loops.push_back({ring_a[k], ring_a[k1], ring_b[k1], ring_b[k]});  // normal points outwards
    out.loop_is_facet.push_back(true);
  }
}

// A circle as a closed polygon of n explicit lines.
void addCircle(const PolygonModel& model, const PolygonModel::Circle& c, int n, Welder& welder,
               Outlines& out) {
  const Eigen::Vector3d centre = model.points[c.centre];
  const Eigen::Vector3d normal =
      (model.points[c.first] - centre).cross(model.points[c.second] - centre).normalized();
  const Eigen::Vector3d u = (model.points[c.first] - centre).normalized();
  const Eigen::Vector3d v = normal.cross(u);
  std::vector<std::uint32_t> ring(n);
  for (int k = 0; k < n; ++k) {
    const double phi = 2.0 * M_PI * k / n;
    ring[k] = welder.add(centre + c.radius * (std::cos(phi) * u + std::sin(phi) * v));
  }
  for (int k = 0; k < n; ++k) out.explicit_lines.emplace_back(ring[k], ring[(k + 1) % n]);
}

// The faces (planes, centroids, convex pieces) of the loops that are not degenerate after
// welding, and the unique edges with the faces on either side.
void addFacesAndEdges(const Outlines& outlines, TrackingModel& out) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> edge_of;
  const auto edgeIndex = [&](std::uint32_t a, std::uint32_t b) {
    const auto key = std::minmax(a, b);
    auto [it, inserted] =
        edge_of.try_emplace({key.first, key.second}, static_cast<std::uint32_t>(out.edges.size()));
    if (inserted) {
      TrackingModel::Edge e;
      e.a = a;
      e.b = b;
      out.edges.push_back(e);
    }
    return it->second;
  };
  for (std::size_t f = 0; f < outlines.loops.size(); ++f) {
    TrackingModel::Face face;
    face.loop = outlines.loops[f];
    const Eigen::Vector3d n = newellNormal(out.points, face.loop);
    if (n.norm() <= 1e-18) continue;  // degenerate after welding
    face.normal = n.normalized();
    for (std::uint32_t p : face.loop) face.centroid += out.points[p];
    face.centroid /= static_cast<double>(face.loop.size());
    face.offset = face.normal.dot(face.centroid);
    face.convex_pieces = convexPieces(out.points, face.loop, face.normal);
    const auto face_index = static_cast<std::int32_t>(out.faces.size());
    for (std::size_t i = 0; i < face.loop.size(); ++i) {
      TrackingModel::Edge& e =
          out.edges[edgeIndex(face.loop[i], face.loop[(i + 1) % face.loop.size()])];
      if (e.face_count < 2) e.faces[e.face_count] = face_index;
      ++e.face_count;
      // An edge is smooth only when every face it bounds is a facet of a curved surface.
      e.smooth = (e.face_count == 1 ? true : e.smooth) && outlines.loop_is_facet[f];
    }
    out.faces.push_back(std::move(face));
  }
  // Boundary edges of facets (the cylinder's end rims) are real contours.
  for (TrackingModel::Edge& e : out.edges)
    if (e.face_count < 2) e.smooth = false;
  for (const auto& [a, b] : outlines.explicit_lines) {
    TrackingModel::Edge& e = out.edges[edgeIndex(a, b)];
    e.explicit_line = true;
    e.smooth = false;
  }
}

}  // namespace

Result<TrackingModel> TrackingModel::build(const PolygonModel& model,
                                           const TrackingModelOptions& options) {
  CDFF_RETURN_IF_ERROR(model.validate());
  if (options.cylinder_segments < 3 || options.circle_segments < 3)
    return invalidParameter(
        "tessellation needs at least 3 segments per cylinder and circle; got "
        "{} and {}",
        options.cylinder_segments, options.circle_segments);
  TrackingModel out;
  Welder welder(options.weld_tolerance > 0 ? options.weld_tolerance : 1e-9);
  std::vector<std::uint32_t> welded(model.points.size());
  for (std::size_t i = 0; i < model.points.size(); ++i) welded[i] = welder.add(model.points[i]);
  Outlines outlines;
  addPolygonFaces(model, welded, outlines);
  for (const PolygonModel::Line& line : model.lines)
    if (welded[line.a] != welded[line.b])
      outlines.explicit_lines.emplace_back(welded[line.a], welded[line.b]);
  for (const PolygonModel::Cylinder& c : model.cylinders)
    addCylinder(model, c, options.cylinder_segments, welder, outlines);
  for (const PolygonModel::Circle& c : model.circles)
    addCircle(model, c, options.circle_segments, welder, outlines);
  out.points = welder.release();
  addFacesAndEdges(outlines, out);

  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : out.points) box.extend(p);
  out.centre = box.center();
  for (const Eigen::Vector3d& p : out.points)
    out.radius = std::max(out.radius, (p - out.centre).norm());
  return out;
}

}  // namespace cdff::tracking
