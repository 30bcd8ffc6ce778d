#include "cdff/tracking/contours.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

namespace cdff::tracking {

namespace {

// a + s b >= 0 constraints on a segment parameter s, intersected into [lo, hi].
struct Interval {
  double lo, hi;
  bool empty() const { return !(lo < hi); }
  void clip(double a, double b) {
    if (std::abs(b) < 1e-15) {
      if (a < 0) hi = lo - 1;  // never satisfied
      return;
    }
    const double s = -a / b;
    if (b > 0)
      lo = std::max(lo, s);
    else
      hi = std::min(hi, s);
  }
};

struct Halfspace {  // n . x - d >= 0
  Eigen::Vector3d n;
  double d;
};

// A convex piece of a face in the camera frame, as the half-spaces of its occlusion volume:
// the cone from the camera through the piece and the far side
// of its plane.
struct Occluder {
  std::vector<Halfspace> sides;
  Halfspace behind;
  Eigen::AlignedBox2d pixels;  // bounding box of the projection
  std::int32_t face;
};

// Sutherland-Hodgman clip of a polygon to z >= near. `outline[i]` says whether the edge from
// vertex i to the next is part of the face's outline (not a diagonal of its triangulation); the
// edge the clip creates counts as outline.
void clipNear(std::vector<Eigen::Vector3d>& polygon, std::vector<bool>& outline, double near) {
  std::vector<Eigen::Vector3d> out;
  std::vector<bool> out_outline;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector3d& a = polygon[i];
    const Eigen::Vector3d& b = polygon[(i + 1) % polygon.size()];
    const bool in_a = a.z() >= near, in_b = b.z() >= near;
    const auto cut = [&] {
      return Eigen::Vector3d(a + (b - a) * ((near - a.z()) / (b.z() - a.z())));
    };
    if (in_a) {
      out.push_back(a);
      out_outline.push_back(outline[i]);
      if (!in_b) {
        out.push_back(cut());
        out_outline.push_back(true);
      }
    } else if (in_b) {
      out.push_back(cut());
      out_outline.push_back(outline[i]);
    }
  }
  polygon = std::move(out);
  outline = std::move(out_outline);
}

Eigen::Vector2d project(const CameraModel& c, const Eigen::Vector3d& p) {
  return {c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy};
}

void clipTo(Interval& in, const Halfspace& h, const Eigen::Vector3d& p, const Eigen::Vector3d& d) {
  in.clip(h.n.dot(p) - h.d, h.n.dot(d));
}

// Which side of each face the camera sees, and whether it sees the face squarely enough for its
// creases and borders to show; the faces it sees, with their outlines, for depth association.
struct FaceVisibility {
  std::vector<signed char> side;  // +1 front, -1 back, 0 in the plane
  std::vector<bool> seen;
  std::vector<VisibleFace> faces;
};

FaceVisibility faceVisibility(const TrackingModel& model, const std::vector<Eigen::Vector3d>& pc,
                              const Eigen::Vector3d& eye, const VisibilityOptions& options) {
  const double cos_max = std::cos(options.max_view_angle);
  const std::size_t nf = model.faces.size();
  FaceVisibility out;
  out.side.assign(nf, 0);
  out.seen.assign(nf, false);
  for (std::size_t f = 0; f < nf; ++f) {
    const TrackingModel::Face& face = model.faces[f];
    const double s = face.normal.dot(eye) - face.offset;
    out.side[f] = s > 0 ? 1 : (s < 0 ? -1 : 0);
    const Eigen::Vector3d to_eye = eye - face.centroid;
    const double distance = to_eye.norm();
    const double cos_view = distance > 0 ? face.normal.dot(to_eye) / distance : 0.0;
    out.seen[f] = cos_view > cos_max || (options.two_sided_faces && -cos_view > cos_max);
    if (out.seen[f]) {
      VisibleFace v;
      v.face = static_cast<std::uint32_t>(f);
      v.normal = face.normal;
      v.offset = face.offset;
      for (std::uint32_t p : face.loop) v.outline.push_back(model.points[p]);
      // The face must reach in front of the camera to be seen at all.
      bool in_front = false;
      for (std::uint32_t p : face.loop) in_front = in_front || pc[p].z() > options.near_clipping;
      if (in_front)
        out.faces.push_back(std::move(v));
      else
        out.seen[f] = false;
    }
  }
  return out;
}

// Occlusion volumes of every face piece in front of the camera.
// The cones are exact up to rounding: narrowed by a hair at the face's outline (a point on
// the outline, like the corner an edge shares with the face, is not hidden by it) and widened
// by a hair at the diagonals between a face's triangles (no crack between them). Any wider
// margin would open cracks between neighbouring faces that hide an edge together.
std::vector<Occluder> occluders(const TrackingModel& model, const std::vector<Eigen::Vector3d>& pc,
                                const Eigen::Isometry3d& c_T_m, const CameraModel& camera,
                                const VisibilityOptions& options) {
  constexpr double kHair = 1e-9;
  std::vector<Occluder> occluders;
  for (std::size_t f = 0; f < model.faces.size(); ++f) {
    const TrackingModel::Face& face = model.faces[f];
    const Eigen::Vector3d n_c = c_T_m.linear() * face.normal;
    const double d_c = n_c.dot(c_T_m * face.centroid);
    if (std::abs(d_c) < 1e-12) continue;  // seen edge-on: hides nothing
    const double sigma = d_c > 0 ? 1.0 : -1.0;
    const std::size_t n_loop = face.loop.size();
    const auto onOutline = [&](std::uint32_t u, std::uint32_t v) {
      for (std::size_t i = 0; i < n_loop; ++i) {
        const std::uint32_t a = face.loop[i], b = face.loop[(i + 1) % n_loop];
        if ((a == u && b == v) || (a == v && b == u)) return true;
      }
      return false;
    };
    for (const auto& piece : face.convex_pieces) {
      std::vector<Eigen::Vector3d> poly;
      std::vector<bool> outline;
      for (std::size_t i = 0; i < piece.size(); ++i) {
        poly.push_back(pc[piece[i]]);
        outline.push_back(piece.size() == n_loop ||
                          onOutline(piece[i], piece[(i + 1) % piece.size()]));
      }
      clipNear(poly, outline, options.near_clipping * 0.5);
      if (poly.size() < 3) continue;
      Occluder o;
      o.face = static_cast<std::int32_t>(f);
      Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
      for (const auto& v : poly) centroid += v;
      centroid /= static_cast<double>(poly.size());
      bool degenerate = false;
      for (std::size_t i = 0; i < poly.size(); ++i) {
        Eigen::Vector3d m = poly[i].cross(poly[(i + 1) % poly.size()]);
        const double norm = m.norm();
        if (norm < 1e-15) continue;  // repeated vertex after clipping
        m /= norm;
        if (m.dot(centroid) < 0) m = -m;
        // m . x -+ shrink * z >= 0: narrowed at the face's outline, widened at the diagonals
        // between its triangles so that neighbouring pieces overlap instead of leaving a crack.
        const double slope = outline[i] ? kHair : -kHair;
        o.sides.push_back({m - Eigen::Vector3d(0, 0, slope), 0.0});
      }
      if (o.sides.size() < 3) degenerate = true;
      if (degenerate) continue;
      o.behind = {sigma * n_c, sigma * d_c + options.occlusion_tolerance};
      for (const auto& v : poly) o.pixels.extend(project(camera, v));
      occluders.push_back(std::move(o));
    }
  }
  return occluders;
}

// Frustum: near, optional far, and the image borders shrunk by the margin.
std::vector<Halfspace> viewFrustum(const CameraModel& camera, const VisibilityOptions& options) {
  std::vector<Halfspace> frustum;
  frustum.push_back({Eigen::Vector3d(0, 0, 1), options.near_clipping});
  if (options.far_clipping > 0)
    frustum.push_back({Eigen::Vector3d(0, 0, -1), -options.far_clipping});
  const double m = options.image_margin;
  frustum.push_back({Eigen::Vector3d(camera.fx, 0, camera.cx - m), 0});
  frustum.push_back({Eigen::Vector3d(-camera.fx, 0, camera.width - 1 - m - camera.cx), 0});
  frustum.push_back({Eigen::Vector3d(0, camera.fy, camera.cy - m), 0});
  frustum.push_back({Eigen::Vector3d(0, -camera.fy, camera.height - 1 - m - camera.cy), 0});
  return frustum;
}

// Whether an edge can show as a contour from where the camera is, and as what: explicit lines
// always, a free border when its face is seen, an edge between a face seen from the front and
// one seen from the back as a silhouette, and other edges as creases when they bend enough (or
// are explicit lines) and one of their faces is seen.
std::optional<ContourKind> contourKind(const TrackingModel& model, const TrackingModel::Edge& edge,
                                       const FaceVisibility& faces,
                                       const VisibilityOptions& options) {
  const std::vector<signed char>& side = faces.side;
  const std::vector<bool>& seen = faces.seen;
  ContourKind kind = ContourKind::kCrease;
  bool candidate = false;
  if (edge.face_count == 0) {
    kind = ContourKind::kLine;
    candidate = true;
  } else if (edge.face_count == 1) {
    const int f = edge.faces[0];
    kind = ContourKind::kBoundary;
    candidate = seen[f] && (side[f] > 0 || options.two_sided_faces);
  } else {
    const int fa = edge.faces[0], fb = edge.faces[1];
    if (edge.face_count == 2 && side[fa] != side[fb] && side[fa] != 0 && side[fb] != 0 &&
        (options.two_sided_faces || side[fa] > 0 || side[fb] > 0)) {
      kind = ContourKind::kSilhouette;
      candidate = true;
    } else {
      const bool sides_ok = options.two_sided_faces || (side[fa] > 0 && side[fb] > 0);
      const double bend =
          std::acos(std::clamp(model.faces[fa].normal.dot(model.faces[fb].normal), -1.0, 1.0));
      candidate = sides_ok && (seen[fa] || seen[fb]) &&
                  ((!edge.smooth && bend >= options.min_crease_angle) || edge.explicit_line);
    }
  }
  if (!candidate) return std::nullopt;
  return kind;
}

// The hidden-line test of segments against the occluders.
class Occlusion {
 public:
  // The occluders' image boxes and faces side by side: the box test rejects most edge-occluder
  // pairs, which makes it the visibility determination's inner loop, so it scans these compact
  // arrays rather than the occluders themselves (whose half-spaces sit in vectors).
  explicit Occlusion(std::vector<Occluder> occluders) : occluders_(std::move(occluders)) {
    boxes_.reserve(occluders_.size());
    for (const Occluder& o : occluders_)
      boxes_.push_back(
          {o.pixels.min().x(), o.pixels.min().y(), o.pixels.max().x(), o.pixels.max().y(), o.face});
  }

  // The parameter intervals of p + s d, s in `range`, that the faces other than the edge's own
  // hide, sorted; `pa` and `pb` are the projections of the range's ends.
  void hiddenParts(const Eigen::Vector3d& p, const Eigen::Vector3d& d, const Interval& range,
                   const Eigen::Vector2d& pa, const Eigen::Vector2d& pb,
                   const TrackingModel::Edge& edge,
                   std::vector<std::pair<double, double>>& hidden) const {
    Eigen::AlignedBox2d box(pa.cwiseMin(pb), pa.cwiseMax(pb));
    hidden.clear();
    const double bx0 = box.min().x(), by0 = box.min().y(), bx1 = box.max().x(), by1 = box.max().y();
    for (std::size_t i = 0; i < boxes_.size(); ++i) {
      const OccluderBox& b = boxes_[i];
      // Eigen's AlignedBox::intersects (overlapping or touching on both axes; NaN never).
      if (!(b.x0 <= bx1 && bx0 <= b.x1 && b.y0 <= by1 && by0 <= b.y1)) continue;
      if (b.face == edge.faces[0] || b.face == edge.faces[1]) continue;
      const Occluder& o = occluders_[i];
      Interval in = range;
      for (const Halfspace& h : o.sides) {
        clipTo(in, h, p, d);
        if (in.empty()) break;
      }
      if (in.empty()) continue;
      clipTo(in, o.behind, p, d);
      if (!in.empty()) hidden.emplace_back(in.lo, in.hi);
    }
    std::sort(hidden.begin(), hidden.end());
  }

 private:
  struct OccluderBox {
    double x0, y0, x1, y1;
    std::int32_t face;
  };
  std::vector<Occluder> occluders_;
  std::vector<OccluderBox> boxes_;
};

}  // namespace

Status checkPinhole(const CameraModel& camera, const char* what) {
  CDFF_RETURN_IF_ERROR(camera.validate().withContext(what));
  if (camera.hasDistortion())
    return invalidInput(
        "{} has {} distortion; expected an undistorted image (run "
        "ImageUndistortion first)",
        what, toString(camera.distortion_model));
  return Status::ok();
}

Result<ModelContours> computeContours(const TrackingModel& model, const CameraModel& camera,
                                      const Transform& camera_T_model,
                                      const Transform& camera_T_reference,
                                      const VisibilityOptions& options) {
  CDFF_RETURN_IF_ERROR(checkPinhole(camera, "camera"));
  CDFF_RETURN_IF_ERROR(camera_T_model.validate().withContext("camera_T_model"));
  ModelContours out;
  out.stamp = camera_T_model.stamp;
  out.camera = camera;
  out.camera_T_model = camera_T_model;
  out.camera_T_reference = camera_T_reference;

  const Eigen::Isometry3d c_T_m = camera_T_model.isometry();
  const Eigen::Vector3d eye = c_T_m.inverse().translation();  // camera centre, model frame
  std::vector<Eigen::Vector3d> pc(model.points.size());
  for (std::size_t i = 0; i < pc.size(); ++i) pc[i] = c_T_m * model.points[i];

  FaceVisibility faces = faceVisibility(model, pc, eye, options);
  out.faces = std::move(faces.faces);
  if (!options.compute_segments) return out;

  const Occlusion occlusion(occluders(model, pc, c_T_m, camera, options));
  const std::vector<Halfspace> frustum = viewFrustum(camera, options);
  const Eigen::Isometry3d m_T_c = c_T_m.inverse();
  std::vector<std::pair<double, double>> hidden;
  for (std::size_t e = 0; e < model.edges.size(); ++e) {
    const TrackingModel::Edge& edge = model.edges[e];
    const std::optional<ContourKind> kind = contourKind(model, edge, faces, options);
    if (!kind) continue;

    const Eigen::Vector3d& p = pc[edge.a];
    const Eigen::Vector3d d = pc[edge.b] - p;
    Interval range{0.0, 1.0};
    for (const Halfspace& h : frustum) clipTo(range, h, p, d);
    if (range.empty()) continue;

    const Eigen::Vector2d pa = project(camera, p + range.lo * d);
    const Eigen::Vector2d pb = project(camera, p + range.hi * d);
    occlusion.hiddenParts(p, d, range, pa, pb, edge, hidden);
    // The visible parts are those between the hidden ones, when long enough in the image.
    double start = range.lo;
    const auto emit = [&](double s0, double s1) {
      if (s1 <= s0) return;
      const Eigen::Vector3d a = p + s0 * d, b = p + s1 * d;
      if ((project(camera, a) - project(camera, b)).norm() < options.min_segment_length) return;
      out.segments.push_back({m_T_c * a, m_T_c * b, static_cast<std::uint32_t>(e), *kind});
    };
    for (const auto& [lo, hi] : hidden) {
      if (lo > start) emit(start, lo);
      start = std::max(start, hi);
    }
    emit(start, range.hi);
  }
  return out;
}

ContourSamples sampleContours(std::shared_ptr<const ModelContours> contours,
                              const SamplingOptions& options) {
  ContourSamples out;
  out.contours = contours;
  if (!contours) return out;
  const ModelContours& c = *contours;
  const Eigen::Isometry3d c_T_m = c.camera_T_model.isometry();
  const double w = c.camera.width, h = c.camera.height, margin = options.image_margin;

  struct Projected {
    Eigen::Vector3d a, b;  // camera frame
    Eigen::Vector2d pa, pb;
    double length;
  };
  std::vector<Projected> projected(c.segments.size());
  double total = 0;
  for (std::size_t i = 0; i < c.segments.size(); ++i) {
    Projected& s = projected[i];
    s.a = c_T_m * c.segments[i].a;
    s.b = c_T_m * c.segments[i].b;
    if (s.a.z() <= 0 || s.b.z() <= 0) {
      s.length = 0;
      continue;
    }
    s.pa = project(c.camera, s.a);
    s.pb = project(c.camera, s.b);
    s.length = (s.pb - s.pa).norm();
    total += s.length;
  }
  double step = std::max(options.step, 1e-3);
  if (options.max_samples > 0 && total / step > options.max_samples)
    step = total / options.max_samples;

  const Eigen::Isometry3d m_T_c = c_T_m.inverse();
  for (std::size_t i = 0; i < projected.size(); ++i) {
    const Projected& s = projected[i];
    const int n = static_cast<int>(std::floor(s.length / step));
    if (n < 1) continue;
    const Eigen::Vector2d dir = (s.pb - s.pa) / s.length;
    const Eigen::Vector2d normal(-dir.y(), dir.x());
    for (int k = 0; k < n; ++k) {
      // Evenly spaced in the image: the segment parameter follows the perspective division.
      const double u = (k + 0.5) / n;
      const double t = u * s.a.z() / ((1 - u) * s.b.z() + u * s.a.z());
      const Eigen::Vector3d x = s.a + t * (s.b - s.a);
      const Eigen::Vector2d pixel = project(c.camera, x);
      if (pixel.x() < margin || pixel.y() < margin || pixel.x() > w - 1 - margin ||
          pixel.y() > h - 1 - margin)
        continue;
      ContourSample sample;
      sample.point = m_T_c * x;
      sample.pixel = pixel;
      sample.normal = normal;
      sample.segment = static_cast<std::uint32_t>(i);
      out.samples.push_back(sample);
    }
  }
  return out;
}

}  // namespace cdff::tracking
