#include "cdff/tracking/pose_solver.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "cdff/tracking/contours.hpp"

namespace cdff::tracking {

namespace {

using Vector6 = Eigen::Matrix<double, 6, 1>;
using Matrix36 = Eigen::Matrix<double, 3, 6>;

double robustSigma(std::vector<double>& absolute, double floor) {
  if (absolute.empty()) return floor;
  const auto mid = absolute.begin() + static_cast<std::ptrdiff_t>(absolute.size() / 2);
  std::nth_element(absolute.begin(), mid, absolute.end());
  return std::max(floor, 1.4826 * *mid);
}

double tukey(double r, double c) {
  const double u = r / c;
  if (std::abs(u) >= 1) return 0.0;
  const double v = 1 - u * u;
  return v * v;
}

// Depth of the nearest point of a polygon's plane hit by the ray through pixel (u, v), or NaN.
struct ProjectedFace {
  std::vector<Eigen::Vector2d> outline;  // pixels
  Eigen::Vector3d normal;                // camera frame
  double offset;
  Eigen::AlignedBox2d box;
};

bool insidePolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
  }
  return inside;
}

// What one evaluation at a pose produces: the normal equations and the statistics.
struct Evaluation {
  Matrix6d H = Matrix6d::Zero();
  Vector6 g = Vector6::Zero();
  std::size_t used = 0;  // residuals with a non-zero weight
  double sigma_edge = 0, sigma_depth = 0;
  std::vector<ViewStatistics> views;
  std::size_t samples = 0, inliers = 0, depth_points = 0, depth_inliers = 0;
  double edge_sq = 0, depth_sq = 0;
};

// One weighted residual of the normal equations, with the cluster it belongs to (a contour chain,
// in every camera that sees it, or a depth face): H += a J J^T, g += a r J.
struct Term {
  std::uint64_t cluster = 0;
  double a = 0, r = 0;
  Vector6 J = Vector6::Zero();
};
using Terms = std::vector<Term, Eigen::aligned_allocator<Term>>;

// The contour chain of every segment: segments of one model edge, and segments that continue
// each other at a shared end turning by less than `angle` (the pieces of a tessellated curve),
// belong to one chain, identified by its smallest segment index.
std::vector<std::uint32_t> contourChains(const ModelContours& mc, double angle) {
  const std::size_t n = mc.segments.size();
  std::vector<std::uint32_t> parent(n);
  for (std::size_t i = 0; i < n; ++i) parent[i] = static_cast<std::uint32_t>(i);
  const auto root = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  const auto join = [&](std::uint32_t a, std::uint32_t b) {
    a = root(a);
    b = root(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  };
  std::map<std::uint32_t, std::uint32_t> by_edge;
  // Segment ends, rounded to 1 um: a model vertex shared by two visible edges.
  std::map<std::array<std::int64_t, 3>, std::vector<std::uint32_t>> ends;
  const auto key = [](const Eigen::Vector3d& p) {
    return std::array<std::int64_t, 3>{std::llround(p.x() * 1e6), std::llround(p.y() * 1e6),
                                       std::llround(p.z() * 1e6)};
  };
  for (std::uint32_t i = 0; i < n; ++i) {
    const ContourSegment& s = mc.segments[i];
    const auto [it, fresh] = by_edge.try_emplace(s.edge, i);
    if (!fresh) join(i, it->second);
    ends[key(s.a)].push_back(i);
    ends[key(s.b)].push_back(i);
  }
  const double straight = std::cos(angle);
  for (const auto& [at, segments] : ends) {
    for (std::size_t x = 0; x < segments.size(); ++x)
      for (std::size_t y = x + 1; y < segments.size(); ++y) {
        const ContourSegment& p = mc.segments[segments[x]];
        const ContourSegment& q = mc.segments[segments[y]];
        // Directions away from the shared end: a straight continuation points them apart.
        const Eigen::Vector3d u = key(p.a) == at ? p.b - p.a : p.a - p.b;
        const Eigen::Vector3d w = key(q.a) == at ? q.b - q.a : q.a - q.b;
        const double nu = u.norm(), nw = w.norm();
        if (nu > 0 && nw > 0 && -u.dot(w) >= straight * nu * nw) join(segments[x], segments[y]);
      }
  }
  // Named by the smallest model edge index in the chain, so that the cameras of a rig that see
  // the same contour put it in the same cluster.
  std::vector<std::uint32_t> name(n, std::numeric_limits<std::uint32_t>::max());
  for (std::uint32_t i = 0; i < n; ++i)
    name[root(i)] = std::min(name[root(i)], mc.segments[i].edge);
  std::vector<std::uint32_t> chain(n);
  for (std::uint32_t i = 0; i < n; ++i) chain[i] = name[root(i)];
  return chain;
}

class Problem {
 public:
  Problem(std::span<const EdgeView> views, const DepthPoints* depth, const PoseSolverOptions& o)
      : views_(views), depth_(depth), o_(o) {
    // The chains depend on the contours only, not on the pose: once per solve.
    for (const EdgeView& v : views_)
      chains_.push_back(contourChains(*v.samples->contours, o.chain_angle));
  }

  Evaluation evaluate(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
    Evaluation e;
    terms_.clear();
    edge_r_.clear();
    edge_j_.clear();
    edge_view_.clear();
    edge_cluster_.clear();
    e.views.resize(views_.size());
    for (std::size_t v = 0; v < views_.size(); ++v) {
      const ContourSamples& cs = *views_[v].samples;
      ViewStatistics& stats = e.views[v];
      stats.samples = cs.samples.size();
      projectSegments(*cs.contours, R, t);
      addEdgeResiduals(cs, static_cast<std::uint32_t>(v), stats);
      e.samples += stats.samples;
    }
    addEdgeTerms(e);
    if (depth_ && !depth_->points.empty()) addDepthTerms(R, t, e);
    return e;
  }

  /// The weighted residuals of the last evaluate(), with their clusters.
  const Terms& terms() const { return terms_; }

 private:
  struct Line {
    Eigen::Vector3d l;  // the projected line in pixels: l . (u, v, 1) = 0
    double r = 0;       // |l_xy|
    Matrix36 JN;        // d(plane normal N)/d(pose)
    bool valid = false;
  };

  // Per segment of one view: the projected line in pixels at the pose (R, t) and its Jacobian
  // (lines_).
  void projectSegments(const ModelContours& mc, const Eigen::Matrix3d& R,
                       const Eigen::Vector3d& t) {
    const CameraModel& k = mc.camera;
    const Eigen::Isometry3d c_T_r = mc.camera_T_reference.isometry();
    const Eigen::Matrix3d& Rcr = c_T_r.linear();
    lines_.resize(mc.segments.size());
    for (std::size_t s = 0; s < mc.segments.size(); ++s) {
      const Eigen::Vector3d a = R * mc.segments[s].a, b = R * mc.segments[s].b;
      const Eigen::Vector3d Ac = Rcr * (a + t) + c_T_r.translation();
      const Eigen::Vector3d Bc = Rcr * (b + t) + c_T_r.translation();
      Line& line = lines_[s];
      line.valid = Ac.z() > 0 && Bc.z() > 0;
      if (!line.valid) continue;
      Matrix36 JA, JB;
      JA << Rcr, -Rcr * skew(a);
      JB << Rcr, -Rcr * skew(b);
      const Eigen::Vector3d N = Ac.cross(Bc);
      line.JN = -skew(Bc) * JA + skew(Ac) * JB;
      line.l = Eigen::Vector3d(N.x() / k.fx, N.y() / k.fy,
                               N.z() - k.cx * N.x() / k.fx - k.cy * N.y() / k.fy);
      line.r = line.l.head<2>().norm();
      line.valid = line.r > 1e-12;
    }
  }

  // The edge residual of every matched sample of view `v` whose line is valid: the signed
  // distance of its candidate nearest to the projected line, with its Jacobian.
  void addEdgeResiduals(const ContourSamples& cs, std::uint32_t v, ViewStatistics& stats) {
    const CameraModel& k = cs.contours->camera;
    for (const ContourSample& s : cs.samples) {
      if (s.candidate_count == 0) continue;
      ++stats.matched;
      const Line& line = lines_[s.segment];
      if (!line.valid) continue;
      double best = std::numeric_limits<double>::infinity();
      Eigen::Vector3d best_m = Eigen::Vector3d::Zero();
      for (std::uint32_t c = 0; c < s.candidate_count; ++c) {
        const Eigen::Vector2d m = candidatePixel(s, cs.candidates[s.first_candidate + c]);
        const Eigen::Vector3d mh(m.x(), m.y(), 1.0);
        const double d = line.l.dot(mh) / line.r;
        if (std::abs(d) < std::abs(best)) {
          best = d;
          best_m = mh;
        }
      }
      const double s_val = line.l.dot(best_m);
      const Eigen::Vector3d dl = best_m / line.r - (s_val / (line.r * line.r * line.r)) *
                                                       Eigen::Vector3d(line.l.x(), line.l.y(), 0.0);
      // l = K^-T N, so the gradient with respect to N is K^-1 times the one with respect to l.
      const Eigen::Vector3d dN((dl.x() - k.cx * dl.z()) / k.fx, (dl.y() - k.cy * dl.z()) / k.fy,
                               dl.z());
      const Vector6 J = line.JN.transpose() * dN;
      edge_r_.push_back(best);
      edge_j_.push_back(J);
      edge_view_.push_back(v);
      edge_cluster_.push_back(chains_[v][s.segment]);
    }
  }

  // The edge residuals' robust scale, inlier statistics and Tukey-weighted normal equations.
  void addEdgeTerms(Evaluation& e) {
    abs_.resize(edge_r_.size());
    for (std::size_t i = 0; i < edge_r_.size(); ++i) abs_[i] = std::abs(edge_r_[i]);
    e.sigma_edge = robustSigma(abs_, o_.min_edge_sigma);
    const double ce = o_.tukey_constant * e.sigma_edge;
    const double ie = 1.0 / (e.sigma_edge * e.sigma_edge);
    for (std::size_t i = 0; i < edge_r_.size(); ++i) {
      const double w = tukey(edge_r_[i], ce);
      if (std::abs(edge_r_[i]) <= o_.inlier_threshold) {
        ++e.views[edge_view_[i]].inliers;
        ++e.inliers;
        e.edge_sq += edge_r_[i] * edge_r_[i];
      }
      if (w <= 0) continue;
      ++e.used;
      e.H.noalias() += (w * ie) * edge_j_[i] * edge_j_[i].transpose();
      e.g.noalias() += (w * ie * edge_r_[i]) * edge_j_[i];
      terms_.push_back({edge_cluster_[i], w * ie, edge_r_[i], edge_j_[i]});
    }
  }

  // The depth residuals (point to face plane at the pose (R, t)), their robust scale and their
  // Tukey-weighted normal equations, after the edges' (whose count sets the depth's share).
  void addDepthTerms(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, Evaluation& e) {
    const std::size_t n = depth_->points.size();
    depth_r_.resize(n);
    abs_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d nr = R * depth_->planes[i].head<3>();
      depth_r_[i] = nr.dot(depth_->points[i] - t) - depth_->planes[i].w();
      abs_[i] = std::abs(depth_r_[i]);
    }
    e.sigma_depth = robustSigma(abs_, o_.min_depth_sigma);
    const double cd = o_.tukey_constant * e.sigma_depth;
    // Dense depth points are strongly correlated (a face off by a fraction of a millimetre
    // shifts all of its points alike), so together they count as depth_weight times the
    // number of edge residuals rather than as thousands of independent measurements.
    const double share = edge_r_.empty() ? 1.0
                                         : o_.depth_weight * static_cast<double>(edge_r_.size()) /
                                               static_cast<double>(n);
    const double id = share / (e.sigma_depth * e.sigma_depth);
    e.depth_points = n;
    // Depth clusters: one per face plane, after every edge cluster (a model edge index, below
    // 2^32).
    std::map<std::array<double, 4>, std::uint64_t> faces;
    for (std::size_t i = 0; i < n; ++i) {
      const double w = tukey(depth_r_[i], cd);
      if (w <= 0) continue;
      ++e.depth_inliers;
      e.depth_sq += depth_r_[i] * depth_r_[i];
      ++e.used;
      const Eigen::Vector3d nr = R * depth_->planes[i].head<3>();
      Vector6 J;
      J << -nr, nr.cross(depth_->points[i] - t);
      e.H.noalias() += (w * id) * J * J.transpose();
      e.g.noalias() += (w * id * depth_r_[i]) * J;
      const Eigen::Vector4d& pl = depth_->planes[i];
      const auto face = faces.try_emplace({pl.x(), pl.y(), pl.z(), pl.w()}, faces.size()).first;
      terms_.push_back({(std::uint64_t{1} << 63) | face->second, w * id, depth_r_[i], J});
    }
  }

  std::span<const EdgeView> views_;
  const DepthPoints* depth_;
  const PoseSolverOptions& o_;
  std::vector<Line> lines_;
  std::vector<double> edge_r_, depth_r_, abs_;
  std::vector<Vector6, Eigen::aligned_allocator<Vector6>> edge_j_;
  std::vector<std::uint32_t> edge_view_;
  std::vector<std::uint64_t> edge_cluster_;
  std::vector<std::vector<std::uint32_t>> chains_;  // per view, per segment
  Terms terms_;
};

// The jackknife over the clusters (pose_solver.hpp): sum over clusters c of d_c d_c^T, d_c =
// (H - H_c)^-1 g_c, at least `floor` (the inverse of the information) in every direction. A
// cluster without which H is singular (it alone fixes a direction) is counted with H^-1 g_c.
Matrix6d clusterCovariance(const Terms& terms, const Matrix6d& H, const Matrix6d& floor,
                           std::size_t& clusters) {
  std::vector<const Term*> sorted(terms.size());
  for (std::size_t i = 0; i < terms.size(); ++i) sorted[i] = &terms[i];
  std::sort(sorted.begin(), sorted.end(),
            [](const Term* a, const Term* b) { return a->cluster < b->cluster; });
  const Eigen::LDLT<Matrix6d> full(H);
  Matrix6d V = Matrix6d::Zero();
  clusters = 0;
  for (std::size_t i = 0; i < sorted.size();) {
    Matrix6d Hc = Matrix6d::Zero();
    Vector6 gc = Vector6::Zero();
    std::size_t j = i;
    for (; j < sorted.size() && sorted[j]->cluster == sorted[i]->cluster; ++j) {
      Hc.noalias() += sorted[j]->a * sorted[j]->J * sorted[j]->J.transpose();
      gc.noalias() += (sorted[j]->a * sorted[j]->r) * sorted[j]->J;
    }
    i = j;
    ++clusters;
    const Eigen::LDLT<Matrix6d> rest(H - Hc);
    const Eigen::VectorXd d = rest.vectorD();
    const bool regular = rest.info() == Eigen::Success && d.minCoeff() > 1e-9 * d.maxCoeff();
    const Vector6 delta = regular ? Vector6(rest.solve(gc)) : Vector6(full.solve(gc));
    V.noalias() += delta * delta.transpose();
  }
  // In the floor's whitened coordinates (floor = L L^T) the eigenvalues of L^-1 V L^-T are the
  // factors by which the clusters' residuals inflate the floor, direction by direction. A sum
  // over K clusters has rank K at most, and few clusters sample some directions poorly or not at
  // all (at close range a handful of contours), so no factor is taken below their mean: a
  // direction the residuals do not sample is as inflated as the average one, not left at the
  // floor's optimism. Nor below 1 (the samples' own noise).
  const Eigen::LLT<Matrix6d> llt(floor);
  if (llt.info() != Eigen::Success) return V;
  const Matrix6d L = llt.matrixL();
  const Matrix6d Li = L.triangularView<Eigen::Lower>().solve(Matrix6d::Identity());
  const Matrix6d W = Li * V * Li.transpose();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (W + W.transpose()));
  const Vector6 lambda = eig.eigenvalues().cwiseMax(std::max(1.0, eig.eigenvalues().mean()));
  const Matrix6d clamped =
      eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
  return L * clamped * L.transpose();
}

}  // namespace

namespace {

// The visible faces in the depth camera's frame, clipped to z >= 1 cm so that faces reaching
// behind the camera still project correctly, with their outlines in pixels.
std::vector<ProjectedFace> projectFaces(std::span<const VisibleFace> faces,
                                        const Eigen::Isometry3d& d_T_m, const CameraModel& k) {
  std::vector<ProjectedFace> projected;
  for (const VisibleFace& f : faces) {
    std::vector<Eigen::Vector3d> poly;
    for (const Eigen::Vector3d& p : f.outline) poly.push_back(d_T_m * p);
    std::vector<Eigen::Vector3d> clipped;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const Eigen::Vector3d& a = poly[i];
      const Eigen::Vector3d& b = poly[(i + 1) % poly.size()];
      const double near = 0.01;
      if (a.z() >= near) clipped.push_back(a);
      if ((a.z() >= near) != (b.z() >= near))
        clipped.push_back(a + (b - a) * ((near - a.z()) / (b.z() - a.z())));
    }
    if (clipped.size() < 3) continue;
    ProjectedFace pf;
    pf.normal = d_T_m.linear() * f.normal;
    pf.offset = pf.normal.dot(d_T_m * f.outline.front());
    for (const Eigen::Vector3d& p : clipped) {
      const Eigen::Vector2d px(k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy);
      pf.outline.push_back(px);
      pf.box.extend(px);
    }
    projected.push_back(std::move(pf));
  }
  return projected;
}

// The depth pixels used: every step_x-th column and step_y-th row, cell (i, j) centred on pixel
// (x0 + i step_x, y0 + j step_y).
struct SamplingGrid {
  int gw = 0, gh = 0;
  double x0 = 0, y0 = 0;
  int step_x = 1, step_y = 1;
};

// For each grid cell, the projected face nearest to the camera there (-1: none): a depth buffer
// of the predicted model.
std::vector<std::int32_t> nearestFaces(const std::vector<ProjectedFace>& projected,
                                       const SamplingGrid& grid, const CameraModel& k) {
  const int gw = grid.gw, gh = grid.gh;
  const double x0 = grid.x0, y0 = grid.y0;
  std::vector<float> zbuffer(static_cast<std::size_t>(gw) * gh,
                             std::numeric_limits<float>::infinity());
  std::vector<std::int32_t> owner(zbuffer.size(), -1);
  for (std::size_t f = 0; f < projected.size(); ++f) {
    const ProjectedFace& pf = projected[f];
    const int i0 = std::max(0, static_cast<int>(std::ceil((pf.box.min().x() - x0) / grid.step_x)));
    const int i1 =
        std::min(gw - 1, static_cast<int>(std::floor((pf.box.max().x() - x0) / grid.step_x)));
    const int j0 = std::max(0, static_cast<int>(std::ceil((pf.box.min().y() - y0) / grid.step_y)));
    const int j1 =
        std::min(gh - 1, static_cast<int>(std::floor((pf.box.max().y() - y0) / grid.step_y)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const Eigen::Vector2d p(x0 + i * grid.step_x, y0 + j * grid.step_y);
        if (!insidePolygon(pf.outline, p)) continue;
        const Eigen::Vector3d ray((p.x() - k.cx) / k.fx, (p.y() - k.cy) / k.fy, 1.0);
        const double denom = pf.normal.dot(ray);
        if (std::abs(denom) < 1e-12) continue;
        const double z = pf.offset / denom;
        const std::size_t cell = static_cast<std::size_t>(j) * gw + i;
        if (z > 0 && z < zbuffer[cell]) {
          zbuffer[cell] = static_cast<float>(z);
          owner[cell] = static_cast<std::int32_t>(f);
        }
      }
  }
  return owner;
}

// The depth in metres at pixel (u, v); NaN for a pixel format that holds no depth.
double depthAt(const DepthMap& depth, int u, int v) {
  const Image& image = depth.image;
  switch (image.format) {
    case PixelFormat::kFloat32:
      return image.at<float>(u, v) * depth.meters_per_unit;
    case PixelFormat::kGray16:
      return image.at<std::uint16_t>(u, v) * depth.meters_per_unit;
    default:
      return std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace

Result<DepthPoints> associateDepth(const DepthMap& depth,
                                   const Eigen::Isometry3d& depth_T_reference,
                                   std::span<const VisibleFace> faces,
                                   const Eigen::Isometry3d& reference_T_model,
                                   const DepthAssociationOptions& options) {
  CDFF_RETURN_IF_ERROR(depth.validate());
  const Image& image = depth.image;
  if (!image.camera)
    return invalidInput(
        "depth map has no camera model; expected the intrinsics of the depth "
        "camera with the image");
  const CameraModel& k = *image.camera;
  CDFF_RETURN_IF_ERROR(checkPinhole(k, "depth camera"));
  if (options.step_x < 1 || options.step_y < 1)
    return invalidParameter("depth sampling steps are {} and {}; expected at least 1 pixel",
                            options.step_x, options.step_y);
  const Eigen::Isometry3d d_T_m = depth_T_reference * reference_T_model;
  const Eigen::Isometry3d r_T_d = depth_T_reference.inverse();

  const std::vector<ProjectedFace> projected = projectFaces(faces, d_T_m, k);
  SamplingGrid grid;
  grid.gw = (image.width + options.step_x - 1) / options.step_x;
  grid.gh = (image.height + options.step_y - 1) / options.step_y;
  grid.x0 = 0.5 * (options.step_x - 1);
  grid.y0 = 0.5 * (options.step_y - 1);
  grid.step_x = options.step_x;
  grid.step_y = options.step_y;
  const std::vector<std::int32_t> owner = nearestFaces(projected, grid, k);

  // A pixel's depth point is kept when it lies near the plane of the face predicted there.
  DepthPoints out;
  for (int j = 0; j < grid.gh; ++j)
    for (int i = 0; i < grid.gw; ++i) {
      const std::int32_t f = owner[static_cast<std::size_t>(j) * grid.gw + i];
      if (f < 0) continue;
      const int u = static_cast<int>(grid.x0 + i * options.step_x);
      const int v = static_cast<int>(grid.y0 + j * options.step_y);
      if (u >= image.width || v >= image.height) continue;
      const double z = depthAt(depth, u, v);
      if (!std::isfinite(z) || z <= 0 || z <= options.min_depth || z > options.max_depth) continue;
      const Eigen::Vector3d q(z * (u - k.cx) / k.fx, z * (v - k.cy) / k.fy, z);
      const ProjectedFace& pf = projected[static_cast<std::size_t>(f)];
      if (std::abs(pf.normal.dot(q) - pf.offset) > options.max_distance) continue;
      out.points.push_back(r_T_d * q);
      const VisibleFace& face = faces[static_cast<std::size_t>(f)];
      out.planes.emplace_back(face.normal.x(), face.normal.y(), face.normal.z(), face.offset);
    }
  return out;
}

Result<PoseSolution> solvePose(const Eigen::Isometry3d& initial, std::span<const EdgeView> views,
                               const DepthPoints* depth, const PoseSolverOptions& options) {
  for (std::size_t v = 0; v < views.size(); ++v) {
    if (!views[v].samples)
      return invalidInput("view {} has no samples; expected matched contour samples", v);
    CDFF_RETURN_IF_ERROR(views[v].samples->validate("view samples"));
  }
  Problem problem(views, depth, options);
  Eigen::Matrix3d R = initial.linear();
  Eigen::Vector3d t = initial.translation();
  const Eigen::Quaterniond q0(initial.linear());
  PoseSolution out;
  Evaluation e;
  for (int it = 0; it < options.max_iterations; ++it) {
    e = problem.evaluate(R, t);
    if (e.used < static_cast<std::size_t>(options.min_measurements))
      return numericalFailure(
          "{} usable measurements (edge samples and depth points) at "
          "iteration {}; expected at least {}",
          e.used, it, options.min_measurements);
    // A little Levenberg-Marquardt damping keeps weakly observed directions from jumping.
    Matrix6d A = e.H;
    A.diagonal() += 1e-9 * (e.H.diagonal().cwiseAbs() + Vector6::Ones());
    if (options.lateral_only) {
      for (int i = 2; i < 6; ++i) {
        A.row(i).setZero();
        A.col(i).setZero();
        A(i, i) = 1;
        e.g(i) = 0;
      }
    }
    const Eigen::LDLT<Matrix6d> ldlt(A);
    if (ldlt.info() != Eigen::Success)
      return numericalFailure("the normal equations are singular at iteration {}", it);
    const Vector6 delta = -ldlt.solve(e.g);
    if (!delta.allFinite())
      return numericalFailure("the pose update is not finite at iteration {}", it);
    t += delta.head<3>();
    R = expSO3(delta.tail<3>()).toRotationMatrix() * R;
    out.iterations = it + 1;
    const double moved = (t - initial.translation()).norm();
    const double turned = angularDistance(Eigen::Quaterniond(R), q0);
    if (moved > options.divergence_translation || turned > options.divergence_rotation) {
      out.diverged = true;
      break;
    }
    if (delta.head<3>().norm() < options.convergence_translation &&
        delta.tail<3>().norm() < options.convergence_rotation) {
      out.converged = true;
      break;
    }
  }
  // Re-orthonormalise, then evaluate once more for the statistics and the covariance.
  R = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  e = problem.evaluate(R, t);
  out.reference_T_model.linear() = R;
  out.reference_T_model.translation() = t;
  out.views = e.views;
  out.samples = e.samples;
  out.inliers = e.inliers;
  out.depth_points = e.depth_points;
  out.depth_inliers = e.depth_inliers;
  out.edge_rms = e.inliers ? std::sqrt(e.edge_sq / e.inliers) : 0.0;
  out.depth_rms = e.depth_inliers ? std::sqrt(e.depth_sq / e.depth_inliers) : 0.0;
  const Eigen::LDLT<Matrix6d> information(e.H);
  if (information.info() == Eigen::Success && e.H.diagonal().minCoeff() > 0) {
    out.information_covariance = information.solve(Matrix6d::Identity());
    out.information_covariance =
        0.5 * (out.information_covariance + out.information_covariance.transpose()).eval();
    out.covariance =
        options.edge_cluster_covariance
            ? clusterCovariance(problem.terms(), e.H, out.information_covariance, out.clusters)
            : out.information_covariance;
    out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  } else {
    out.covariance = Matrix6d::Identity() * 1e6;  // unobservable: say so with a huge variance
    out.information_covariance = out.covariance;
  }
  return out;
}

}  // namespace cdff::tracking
