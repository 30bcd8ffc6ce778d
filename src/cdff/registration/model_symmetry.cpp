#include "cdff/registration/model_symmetry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

#include <Eigen/Eigenvalues>

#include "cdff/registration/icp.hpp"

namespace cdff::registration {
namespace {

struct Samples {
  std::vector<Eigen::Vector3f> points, normals;
};

/// `count` of the model's points and normals, strided (the model is sampled uniformly by area).
Samples samplesOf(const ModelIndex& index, std::size_t count) {
  Samples s;
  const std::size_t n = index.points.size(), keep = std::min(n, count);
  for (std::size_t k = 0; k < keep; ++k) {
    s.points.push_back(index.points[k * n / keep].vec());
    s.normals.push_back(index.normals[k * n / keep].vec());
  }
  return s;
}

/// Which voxels of a grid over the model hold its surface, dilated by one voxel: a point is "on
/// the surface" within about one to one and a half voxels.
class SurfaceOccupancy {
 public:
  SurfaceOccupancy(const ModelIndex& index, const Eigen::Vector3d& low, const Eigen::Vector3d& high,
                   double voxel)
      : voxel_(voxel), origin_(low.array() - 2 * voxel) {
    const Eigen::Array3d extent = (high - low).array() + 4 * voxel;
    for (int a = 0; a < 3; ++a) size_[a] = static_cast<int>(std::ceil(extent[a] / voxel)) + 1;
    std::vector<std::uint8_t> surface(cellCount(), 0);
    for (const Point4f& p : index.points) {
      const long c = cellOf(p.vec().cast<double>());
      if (c >= 0) surface[static_cast<std::size_t>(c)] = 1;
    }
    occupied_.assign(cellCount(), 0);
    for (int z = 1; z + 1 < size_[2]; ++z)
      for (int y = 1; y + 1 < size_[1]; ++y)
        for (int x = 1; x + 1 < size_[0]; ++x) {
          if (!surface[flat(x, y, z)]) continue;
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) occupied_[flat(x + dx, y + dy, z + dz)] = 1;
        }
  }

  bool occupied(const Eigen::Vector3d& p) const {
    const long c = cellOf(p);
    return c >= 0 && occupied_[static_cast<std::size_t>(c)];
  }

 private:
  std::size_t cellCount() const { return static_cast<std::size_t>(size_[0]) * size_[1] * size_[2]; }
  std::size_t flat(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * size_[1] + y) * size_[0] + x;
  }
  long cellOf(const Eigen::Vector3d& p) const {
    const Eigen::Array3d c = (p.array() - origin_) / voxel_;
    if ((c < 0).any() || c[0] >= size_[0] || c[1] >= size_[1] || c[2] >= size_[2]) return -1;
    return static_cast<long>(
        flat(static_cast<int>(c[0]), static_cast<int>(c[1]), static_cast<int>(c[2])));
  }

  double voxel_;
  Eigen::Array3d origin_;
  int size_[3] = {0, 0, 0};
  std::vector<std::uint8_t> occupied_;
};

/// Lines are the same within `angle` (directions or their opposites).
bool sameLine(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double angle) {
  return std::abs(a.dot(b)) >= std::cos(angle);
}

/// The directions along which many surface normals lie (the faces' normals, up to sign), most
/// area first: greedy clusters of the normals within 8 degrees holding at least 3 % of them.
std::vector<Eigen::Vector3d> dominantNormals(const std::vector<Eigen::Vector3f>& normals) {
  constexpr double kWithin = 8 * M_PI / 180, kMinShare = 0.03;
  constexpr int kMaxDirections = 12;
  std::vector<Eigen::Vector3d> found;
  std::vector<bool> taken(normals.size(), false);
  const double cos_within = std::cos(kWithin);
  for (int round = 0; round < kMaxDirections; ++round) {
    std::size_t best_count = 0, best = 0;
    for (std::size_t s = 0; s < normals.size(); s += 3) {
      if (taken[s]) continue;
      std::size_t count = 0;
      for (std::size_t i = 0; i < normals.size(); ++i)
        count += !taken[i] && std::abs(normals[s].dot(normals[i])) >= cos_within;
      if (count > best_count) best_count = count, best = s;
    }
    if (best_count < kMinShare * normals.size() || best_count == 0) break;
    // The cluster's direction: the principal eigenvector of its normals' scatter.
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < normals.size(); ++i)
      if (!taken[i] && std::abs(normals[best].dot(normals[i])) >= cos_within) {
        const Eigen::Vector3d n = normals[i].cast<double>();
        scatter += n * n.transpose();
        taken[i] = true;
      }
    found.push_back(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(2));
  }
  return found;
}

/// The axis directions searched: the dominant normals, their bisectors and cross products, and
/// the principal axes of the points; one per line within 2 degrees.
std::vector<Eigen::Vector3d> candidateAxes(const std::vector<Eigen::Vector3d>& dominant,
                                           const Eigen::Matrix3d& principal) {
  std::vector<Eigen::Vector3d> axes;
  auto add = [&](const Eigen::Vector3d& v) {
    if (v.norm() < 1e-6) return;
    const Eigen::Vector3d d = v.normalized();
    if (std::none_of(axes.begin(), axes.end(),
                     [&](const Eigen::Vector3d& a) { return sameLine(a, d, 2 * M_PI / 180); }))
      axes.push_back(d);
  };
  for (const Eigen::Vector3d& d : dominant) add(d);
  for (int a = 0; a < 3; ++a) add(principal.col(a));
  for (std::size_t i = 0; i < dominant.size(); ++i)
    for (std::size_t j = i + 1; j < dominant.size(); ++j) {
      const Eigen::Vector3d &a = dominant[i],
                            b = a.dot(dominant[j]) >= 0 ? dominant[j] : -dominant[j];
      if (sameLine(a, b, 2 * M_PI / 180)) continue;
      add(a + b);
      add(a - b);
      add(a.cross(b));
    }
  return axes;
}

/// The fraction of the `turned` samples that land on the occupied surface moved by `shift`.
double coarseOverlap(const SurfaceOccupancy& surface, const std::vector<Eigen::Vector3d>& turned,
                     const Eigen::Vector3d& shift) {
  std::size_t on = 0;
  for (const Eigen::Vector3d& p : turned) on += surface.occupied(p + shift);
  return static_cast<double>(on) / static_cast<double>(std::max<std::size_t>(1, turned.size()));
}

/// The placements of the axis of `turn`: axis points `a` in the plane through `centre` across
/// the axis, within `reach` of it, on a square grid whose shifts (I - R) a are `shift_step`
/// apart (a turn by angle t moves an axis offset d by 2 sin(t/2) d); the best `count` of them
/// at least `separation` apart (in shift), best first.
struct Placement {
  Eigen::Vector3d axis_point = Eigen::Vector3d::Zero();
  double overlap = -1;
};
std::vector<Placement> bestPlacements(const SurfaceOccupancy& surface,
                                      const std::vector<Eigen::Vector3d>& turned,
                                      const Eigen::AngleAxisd& turn, const Eigen::Vector3d& centre,
                                      double reach, double shift_step, std::size_t count,
                                      double separation) {
  const Eigen::Matrix3d rotation = turn.toRotationMatrix();
  const Eigen::Vector3d u = turn.axis().unitOrthogonal(), v = turn.axis().cross(u);
  const double gain = 2 * std::sin(turn.angle() / 2), step = shift_step / gain;
  const int steps = static_cast<int>(std::ceil(reach / step));
  std::vector<Placement> all;
  for (int i = -steps; i <= steps; ++i)
    for (int j = -steps; j <= steps; ++j) {
      const Eigen::Vector3d a = centre + i * step * u + j * step * v;
      all.push_back({a, coarseOverlap(surface, turned, a - rotation * a)});
    }
  std::stable_sort(all.begin(), all.end(),
                   [](const Placement& x, const Placement& y) { return x.overlap > y.overlap; });
  std::vector<Placement> best;
  for (const Placement& p : all) {
    if (best.size() >= count) break;
    if (std::none_of(best.begin(), best.end(), [&](const Placement& b) {
          return gain * (b.axis_point - p.axis_point).norm() < separation;
        }))
      best.push_back(p);
  }
  return best;
}

double rotationAngle(const Eigen::Matrix3d& r) {
  return Eigen::AngleAxisd(r).angle();
}

}  // namespace

std::vector<Eigen::Isometry3d> motionsOf(const std::vector<NearSymmetry>& symmetries) {
  std::vector<Eigen::Isometry3d> motions;
  for (const NearSymmetry& s : symmetries) motions.push_back(s.motion);
  return motions;
}

double symmetryOverlap(const ModelIndex& index, const Eigen::Isometry3d& motion,
                       const std::vector<Eigen::Vector3f>& points,
                       const std::vector<Eigen::Vector3f>& normals, double tolerance) {
  const float max_sq = static_cast<float>(tolerance * tolerance);
  const Eigen::Matrix3f r = motion.linear().cast<float>();
  const Eigen::Vector3f t = motion.translation().cast<float>();
  const float cos_agree = static_cast<float>(std::cos(30 * M_PI / 180));
  std::vector<KdTree3f::Neighbour> found;
  std::size_t on = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f n = r * normals[i];
    index.tree.kNearest(r * points[i] + t, 4, found, max_sq);
    on += std::any_of(found.begin(), found.end(), [&](const KdTree3f::Neighbour& f) {
      return std::abs(index.normals[f.index].vec().dot(n)) >= cos_agree;
    });
  }
  return static_cast<double>(on) / static_cast<double>(std::max<std::size_t>(1, points.size()));
}

namespace {

/// What the search measures the model by: its box, bounding radius, centroid, the overlap's
/// tolerance and its surface samples (400 to score, 64 to search with).
struct ModelGauge {
  ModelBounds bounds;
  Eigen::Vector3d centroid;
  double radius = 0, tolerance = 0;
  Samples fine, coarse;
  std::vector<double> angles;  // 360 k / n degrees up to a half turn, each once

  /// Two motions are one within 5 degrees and where they put the centroid.
  bool same(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) const {
    const Eigen::Isometry3d d = a.inverse() * b;
    return rotationAngle(d.linear()) < 5 * M_PI / 180 &&
           (d * centroid - centroid).norm() < 2 * tolerance + radius * 5 * M_PI / 180;
  }
};

ModelGauge gaugeOf(const ModelIndex& index, const SymmetryOptions& options) {
  ModelGauge g;
  g.bounds = modelBounds(index);
  g.radius = g.bounds.radius();
  g.centroid = modelCentroid(index);
  g.tolerance = options.tolerance > 0 ? options.tolerance
                                      : std::max(2 * modelSpacing(index), 0.02 * g.radius);
  g.fine = samplesOf(index, options.samples);
  g.coarse = samplesOf(index, 64);
  for (int n = 2; n <= std::max(2, options.max_order); ++n)
    for (int k = 1; 2 * k <= n; ++k)
      if (std::gcd(k, n) == 1) g.angles.push_back(2 * M_PI * k / n);
  return g;
}

/// A turn placed by the search, with its coarse overlap.
struct PlacedTurn {
  Eigen::Isometry3d motion;
  double coarse = 0;
};

/// Every candidate axis and angle, its axis placed where the coarse samples land on the surface's
/// voxels at two scales (a grid a ninth of the radius apart, then around the three best
/// placements, a fortieth); those that land well enough, best first.
std::vector<PlacedTurn> placedTurns(const ModelIndex& index, const ModelGauge& g,
                                    double min_overlap) {
  const SurfaceOccupancy wide(index, g.bounds.low, g.bounds.high, g.radius / 9);
  const SurfaceOccupancy narrow(index, g.bounds.low, g.bounds.high, g.radius / 40);
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3f& p : g.fine.points) {
    const Eigen::Vector3d d = p.cast<double>() - g.centroid;
    covariance += d * d.transpose();
  }
  const std::vector<Eigen::Vector3d> axes =
      candidateAxes(dominantNormals(g.fine.normals),
                    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance).eigenvectors());
  std::vector<PlacedTurn> placed;
  std::vector<Eigen::Vector3d> turned(g.coarse.points.size());
  for (const Eigen::Vector3d& axis : axes)
    for (double angle : g.angles) {
      const Eigen::AngleAxisd turn(angle, axis);
      const Eigen::Matrix3d rotation = turn.toRotationMatrix();
      for (std::size_t i = 0; i < turned.size(); ++i)
        turned[i] = rotation * g.coarse.points[i].cast<double>();
      Placement sharp;
      for (const Placement& rough : bestPlacements(wide, turned, turn, g.centroid, g.radius,
                                                   g.radius / 9, 3, g.radius / 4)) {
        if (rough.overlap < min_overlap) break;
        const Placement p = bestPlacements(narrow, turned, turn, rough.axis_point, g.radius / 9,
                                           g.radius / 40, 1, 0)
                                .front();
        if (p.overlap > sharp.overlap) sharp = p;
      }
      if (sharp.overlap < 0.7 * min_overlap) continue;
      Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
      motion.linear() = rotation;
      motion.translation() = sharp.axis_point - rotation * sharp.axis_point;
      placed.push_back({motion, sharp.overlap});
    }
  std::sort(placed.begin(), placed.end(),
            [](const PlacedTurn& a, const PlacedTurn& b) { return a.coarse > b.coarse; });
  return placed;
}

/// Each distinct placed turn refined by point-to-plane ICP of the model onto itself and kept
/// when it is still a turn of finite order mapping min_overlap of the fine samples.
std::vector<NearSymmetry> refinedSymmetries(const ModelIndex& index, const ModelGauge& g,
                                            const std::vector<PlacedTurn>& placed,
                                            double min_overlap) {
  Icp icp;
  IcpOptions icp_options;
  icp_options.max_correspondence_distance = g.radius / 20;
  icp_options.min_correspondence_distance = g.tolerance;
  icp_options.point_to_point_above = 0;
  icp_options.min_kernel_scale = g.tolerance / 3;
  icp_options.association.back_face_rejection = false;
  icp.configure(icp_options);
  icp.setModel(
      ModelSearch{std::shared_ptr<const ModelIndex>(&index, [](const ModelIndex*) {}), nullptr});
  std::vector<NearSymmetry> kept;
  std::vector<Eigen::Isometry3d> tried;
  for (const PlacedTurn& f : placed) {
    if (std::any_of(tried.begin(), tried.end(),
                    [&](const Eigen::Isometry3d& t) { return g.same(t, f.motion); }))
      continue;
    tried.push_back(f.motion);
    // The registration maps scan points p to p = pose * x, so the symmetry x -> motion * x is
    // the inverse pose.
    Result<IcpRun> run =
        icp.iterate(g.fine.points,
                    IcpRun::startingAt(f.motion.inverse(), icp_options.max_correspondence_distance),
                    30, NearestPoints::kExact);
    Eigen::Isometry3d motion = f.motion;
    if (run && !run->starved) {
      motion = run->pose.inverse();
      motion.linear() = Eigen::Quaterniond(motion.linear()).normalized().toRotationMatrix();
    }
    // A symmetry of finite order turns by one of the angles searched; a run that slid off to
    // another angle (a plate turned about its normal stays on its plane) found none.
    const double angle = rotationAngle(motion.linear());
    if (std::none_of(g.angles.begin(), g.angles.end(),
                     [&](double a) { return std::abs(angle - a) < 3 * M_PI / 180; }))
      continue;
    const double overlap =
        symmetryOverlap(index, motion, g.fine.points, g.fine.normals, g.tolerance);
    if (overlap < min_overlap) continue;
    if (std::any_of(kept.begin(), kept.end(),
                    [&](const NearSymmetry& k) { return g.same(k.motion, motion); }))
      continue;
    kept.push_back({motion, overlap, angle});
  }
  return kept;
}

}  // namespace

std::vector<NearSymmetry> nearSymmetries(const ModelIndex& index, const SymmetryOptions& options) {
  if (index.points.size() < 10) return {};
  const ModelGauge g = gaugeOf(index, options);
  if (!(g.radius > 0)) return {};
  std::vector<NearSymmetry> kept =
      refinedSymmetries(index, g, placedTurns(index, g, options.min_overlap), options.min_overlap);
  // The inverses (a turn by more than a half turn about the same axis), where not found already.
  const std::size_t direct = kept.size();
  for (std::size_t i = 0; i < direct; ++i) {
    const Eigen::Isometry3d inverse = kept[i].motion.inverse();
    if (std::none_of(kept.begin(), kept.end(),
                     [&](const NearSymmetry& k) { return g.same(k.motion, inverse); }))
      kept.push_back({inverse, kept[i].overlap, kept[i].angle});
  }
  std::stable_sort(kept.begin(), kept.end(), [](const NearSymmetry& a, const NearSymmetry& b) {
    return a.overlap > b.overlap;
  });
  return kept;
}

}  // namespace cdff::registration
