// ForceMeshGeneration/TangentDelaunay: a local Delaunay triangulation of the contacts in each
// contact's tangent plane, the triangles the contacts agree on kept without folds.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include "ForceMeshGeneration.gen.hpp"
#include "cdff/types/kd_tree.hpp"

namespace cdff::dfn {

namespace {

/// A unit normal's norm may be off by float rounding and by the estimator's own normalisation;
/// anything farther is not a normal (OctomapUpdate's tolerance).
constexpr double kUnitTolerance = 1e-3;
/// Contacts closer than this are one point for the triangulation: a triangle on both would have
/// no area (the voxels' mean points of one contact sample are never this close).
constexpr double kCoincident = 1e-6;
/// Indices packed three to a 64-bit key, 21 bits each.
constexpr std::size_t kMaxContacts = std::size_t{1} << 21;
constexpr int kMinVotes = 1;

using Triangle = std::array<std::uint32_t, 3>;

std::uint64_t keyOf(Triangle t) {
  std::sort(t.begin(), t.end());
  return (std::uint64_t{t[0]} << 42) | (std::uint64_t{t[1]} << 21) | t[2];
}

Triangle fromKey(std::uint64_t key) {
  const std::uint64_t mask = kMaxContacts - 1;
  return {static_cast<std::uint32_t>(key >> 42), static_cast<std::uint32_t>((key >> 21) & mask),
          static_cast<std::uint32_t>(key & mask)};
}

/// Two unit vectors across `n`, completing a right-handed frame.
std::pair<Eigen::Vector3d, Eigen::Vector3d> tangentBasis(const Eigen::Vector3d& n) {
  const Eigen::Vector3d helper =
      std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d e1 = n.cross(helper).normalized();
  return {e1, n.cross(e1)};
}

struct Candidate {
  Triangle vertices;
  int votes = 0;
  double longest = 0;  // m, its longest edge
};

}  // namespace

class ForceMeshGenerationTangentDelaunay final : public ForceMeshGenerationTangentDelaunayBase {
 protected:
  Status onProcess() override {
    const PointCloud& contacts = *in.contacts;
    CDFF_RETURN_IF_ERROR(checkContacts(contacts));
    load(contacts);
    std::unordered_map<std::uint64_t, int> votes;
    if (points_.size() >= 3) {
      const KdTree3f tree(std::span<const Point4f>(contacts.points.data(), contacts.size()));
      std::vector<KdTree3f::Neighbour> found;
      for (std::uint32_t i = 0; i < points_.size(); ++i) umbrella(i, tree, found, votes);
    }
    const std::vector<Triangle> triangles = select(votes);
    out.triangles.set(static_cast<int>(triangles.size()));
    if (triangles.empty()) return Status::ok();
    TriangleMesh mesh;
    mesh.stamp = contacts.stamp;
    mesh.frame_id = contacts.frame_id;
    std::vector<Eigen::Vector3f> vertices(contacts.size()), normals(contacts.size());
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      vertices[i] = contacts.points[i].vec();
      normals[i] = normals_[i].cast<float>();
    }
    mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
    mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
    mesh.triangles = Buffer<Triangle>::fromVector(std::vector<Triangle>(triangles));
    out.mesh.set(std::move(mesh));
    out.forces.set(contacts);  // the same buffers: vertex i's force is point i's intensity
    return Status::ok();
  }

 private:
  Status checkContacts(const PointCloud& contacts) const {
    CDFF_RETURN_IF_ERROR(contacts.validate("input 'contacts'"));
    if (!contacts.hasNormals() || contacts.intensity.empty())
      return invalidInput(
          "input 'contacts' ({} points at {} us in '{}') has {}; expected each contact's normal "
          "and its normal force as intensity (OctomapUpdate's output)",
          contacts.size(), contacts.stamp, contacts.frame_id,
          contacts.hasNormals() ? "no intensity" : "no normals");
    if (contacts.size() >= kMaxContacts)
      return invalidInput("input 'contacts' has {} points; expected fewer than {}", contacts.size(),
                          kMaxContacts);
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      const double norm = contacts.normals[i].vec().cast<double>().norm();
      if (!(std::abs(norm - 1) <= kUnitTolerance))
        return invalidInput(
            "input 'contacts' point {} at {} us has a normal of norm {}; expected a unit normal", i,
            contacts.stamp, norm);
      if (!(std::isfinite(contacts.intensity[i]) && contacts.intensity[i] >= 0))
        return invalidInput(
            "input 'contacts' point {} at {} us has a normal force (intensity) of {} N; expected "
            "a finite force >= 0 (a contact pushes)",
            i, contacts.stamp, contacts.intensity[i]);
    }
    return Status::ok();
  }

  void load(const PointCloud& contacts) {
    points_.resize(contacts.size());
    normals_.resize(contacts.size());
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      points_[i] = contacts.points[i].vec().cast<double>();
      normals_[i] = contacts.normals[i].vec().cast<double>().normalized();
    }
  }

  /// The edge rule: the chord from i to j stays within max_deviation of the surface their
  /// normals imply (the crease through both across their normals, the normals' angle less their
  /// errors), and is no longer than max_edge_length. Normals 90 deg apart or more (two faces of
  /// an edge or of a thin panel) never join.
  bool joinable(std::uint32_t i, std::uint32_t j) const {
    const double length = (points_[i] - points_[j]).norm();
    if (length > params_.max_edge_length || length < kCoincident) return false;
    const double cosine = normals_[i].dot(normals_[j]);
    if (cosine <= 0) return false;
    const double angle = std::atan2(normals_[i].cross(normals_[j]).norm(), cosine);
    const double bend = std::max(0.0, angle - 2 * params_.normal_tolerance);
    return 0.5 * length * std::tan(0.5 * bend) <= params_.max_deviation;
  }

  /// Votes for the triangles of contact i that are Delaunay in its tangent plane among its
  /// joinable neighbours: the edges of i's Voronoi cell there are its Delaunay neighbours, two
  /// consecutive ones a Delaunay triangle (their cell vertex its circumcentre). Neighbours are
  /// taken nearest first until the next one's bisector lies beyond the cell (no farther one can
  /// cut it): a contact beside a wide gap in the map needs neighbours across it, however many
  /// nearer ones there are.
  void umbrella(std::uint32_t i, const KdTree3f& tree, std::vector<KdTree3f::Neighbour>& found,
                std::unordered_map<std::uint64_t, int>& votes) {
    const double reach = params_.max_edge_length;
    tree.withinRadius(points_[i].cast<float>(), static_cast<float>(reach * (1 + 1e-6)), found);
    std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) {
      return a.squared_distance < b.squared_distance ||
             (a.squared_distance == b.squared_distance && a.index < b.index);
    });
    const auto [e1, e2] = tangentBasis(normals_[i]);
    // The cell starts as a square far beyond any neighbour (label -1: not a neighbour's edge).
    const double far = 1e3 * reach;
    cell_ = {{{-far, -far}, -1}, {{far, -far}, -1}, {{far, far}, -1}, {{-far, far}, -1}};
    double cell_radius = far * std::sqrt(2.0);
    int clipped = 0;
    for (const KdTree3f::Neighbour& n : found) {
      if (0.5 * std::sqrt(n.squared_distance) > cell_radius || clipped >= params_.max_neighbours)
        break;
      if (n.index == i || !joinable(i, n.index)) continue;
      const Eigen::Vector3d d = points_[n.index] - points_[i];
      clip(Eigen::Vector2d(d.dot(e1), d.dot(e2)), static_cast<int>(n.index));
      ++clipped;
      cell_radius = 0;
      for (const CellVertex& v : cell_) cell_radius = std::max(cell_radius, v.at.norm());
    }
    for (std::size_t m = 0; m < cell_.size(); ++m) {
      const int j = cell_[m].label, k = cell_[(m + 1) % cell_.size()].label;
      if (j >= 0 && k >= 0 &&
          joinable(static_cast<std::uint32_t>(j), static_cast<std::uint32_t>(k)))
        ++votes[keyOf({i, static_cast<std::uint32_t>(j), static_cast<std::uint32_t>(k)})];
    }
  }

  /// Cuts the convex cell by the half-plane of the points nearer the origin than q (Sutherland-
  /// Hodgman); the new edge gets q's label.
  void clip(const Eigen::Vector2d& q, int label) {
    const double offset = 0.5 * q.squaredNorm();
    auto side = [&](const Eigen::Vector2d& x) { return x.dot(q) - offset; };
    clipped_.clear();
    for (std::size_t m = 0; m < cell_.size(); ++m) {
      const CellVertex& p = cell_[m];
      const CellVertex& r = cell_[(m + 1) % cell_.size()];
      const double sp = side(p.at), sr = side(r.at);
      const bool p_in = sp <= 0, r_in = sr <= 0;
      const Eigen::Vector2d cut = p.at + (sp / (sp - sr)) * (r.at - p.at);
      if (p_in) clipped_.push_back(p);
      if (p_in && !r_in) clipped_.push_back({cut, label});
      if (!p_in && r_in) clipped_.push_back({cut, p.label});
    }
    cell_.swap(clipped_);
  }

  /// The triangles voted for by all three vertices, then by two, shortest first, each kept when
  /// it neither gives an edge a third triangle nor folds over the triangle across a shared edge.
  std::vector<Triangle> select(const std::unordered_map<std::uint64_t, int>& votes) const {
    std::vector<Candidate> candidates;
    for (const auto& [key, count] : votes) {
      if (count < kMinVotes) continue;
      Candidate c{fromKey(key), count, 0};
      for (int k = 0; k < 3; ++k)
        c.longest =
            std::max(c.longest, (points_[c.vertices[k]] - points_[c.vertices[(k + 1) % 3]]).norm());
      candidates.push_back(c);
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
      if (x.votes != y.votes) return x.votes > y.votes;
      if (x.longest != y.longest) return x.longest < y.longest;
      return x.vertices < y.vertices;  // deterministic whatever the hash map's order
    });
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> opposite;  // edge -> thirds
    std::vector<Triangle> kept;
    for (const Candidate& c : candidates) {
      if (!fits(c.vertices, opposite)) continue;
      for (int k = 0; k < 3; ++k) {
        const auto [a, b] = std::minmax(c.vertices[k], c.vertices[(k + 1) % 3]);
        opposite[edgeKey(a, b)].push_back(c.vertices[(k + 2) % 3]);
      }
      kept.push_back(facingOut(c.vertices));
    }
    return kept;
  }

  static std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
    return (std::uint64_t{a} << 32) | b;
  }

  bool fits(const Triangle& t,
            const std::unordered_map<std::uint64_t, std::vector<std::uint32_t>>& opposite) const {
    for (int k = 0; k < 3; ++k) {
      const auto [a, b] = std::minmax(t[k], t[(k + 1) % 3]);
      const auto it = opposite.find(edgeKey(a, b));
      if (it == opposite.end()) continue;
      if (it->second.size() >= 2) return false;
      // Across the shared edge, seen along the edge's mean normal, the two third vertices must
      // lie on opposite sides.
      const Eigen::Vector3d axis = normals_[a] + normals_[b];
      const Eigen::Vector3d edge = points_[b] - points_[a];
      const double here = edge.cross(points_[t[(k + 2) % 3]] - points_[a]).dot(axis);
      const double there = edge.cross(points_[it->second.front()] - points_[a]).dot(axis);
      if (here * there >= 0) return false;
    }
    return true;
  }

  /// Counter-clockwise seen from outside: the face's normal along its vertices' normals.
  Triangle facingOut(Triangle t) const {
    const Eigen::Vector3d face =
        (points_[t[1]] - points_[t[0]]).cross(points_[t[2]] - points_[t[0]]);
    if (face.dot(normals_[t[0]] + normals_[t[1]] + normals_[t[2]]) < 0) std::swap(t[1], t[2]);
    return t;
  }

  /// A vertex of a contact's Voronoi cell in its tangent plane and the label of the edge that
  /// leaves it (counter-clockwise): the neighbour whose bisector it is, or -1.
  struct CellVertex {
    Eigen::Vector2d at;
    int label = -1;
  };

  std::vector<Eigen::Vector3d> points_, normals_;  // the current contacts, in double
  std::vector<CellVertex> cell_, clipped_;         // scratch of umbrella()
};

CDFF_REGISTER_DFI(ForceMeshGenerationTangentDelaunay);

}  // namespace cdff::dfn
