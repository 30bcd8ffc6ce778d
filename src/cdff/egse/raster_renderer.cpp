// The CPU rasteriser: a visibility buffer filled with exact fixed-point coverage (pixel centres,
// top-left rule) and perspective-correct inverse depth, then one shading pass per covered pixel
// with the shading model documented in render.hpp. Deterministic: single-threaded, no
// dependence on timing; the same inputs give the same bits.
//
// The shading pass is the cost at high coverage, so everything that is constant over a
// triangle is set up once per frame (FrameTriangle): flat triangles (boxes, panels: most of
// a spacecraft) need no barycentrics per pixel, only a few affine functions of the pixel, and
// the specular lobe comes from a per-material table instead of pow(). Each row is then shaded
// in runs of pixels that show the same triangle, with loops the compiler vectorises
// (raster_kernels.hpp; figures in docs/simulator.md).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>

#include "cdff/egse/raster_kernels.hpp"
#include "cdff/egse/render.hpp"

namespace cdff::egse {

namespace raster {

namespace {

constexpr std::uint32_t kNoSurface = 0xffffffffu;
constexpr double kGuardBand = 4096.0;  // pixels outside the image before clipping in 3D
// Pixels per pass of the shading stages.
constexpr int kShadeChunk = 128;

struct ModelData {
  std::vector<Eigen::Vector3f> vertices, normals;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint16_t> material;
  std::vector<ShadeMaterial> materials;
  std::vector<std::uint8_t> flat;  // the three normals equal the face normal
  std::vector<Eigen::Vector3f> face_normal;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0;
};

// A triangle of the current frame, set up for the shading pass.
struct FrameTriangle {
  PixelAffine beta, gamma;  // barycentric coordinates of vertices 1 and 2
  // Flat triangles only (the others evaluate these per pixel):
  PixelAffine pattern_u, pattern_v;  // crinkle texels / solar cells along the triplanar axes
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // camera frame, turned towards the camera
  // Crinkle: the normal's change per unit facet tilt along each axis, camera frame.
  Eigen::Vector3f tilt_u = Eigen::Vector3f::Zero(), tilt_v = Eigen::Vector3f::Zero();
  // Sun texel (x, y) and biased depth of the normal offset.
  Eigen::Vector3f shadow = Eigen::Vector3f::Zero();
  float ndl = 0;  // normal . sun
  std::uint16_t material = 0;
  std::uint8_t flat = 0;
};

// A 3D point where the shadow map is looked up, split so that only the z-scaled part varies
// per pixel: map coordinates = z * ray_term(x, y) + offset_term.
struct ShadowLookup {
  Eigen::Vector3f
      dx = Eigen::Vector3f::Zero(),
      dy = Eigen::Vector3f::Zero(),
      d0 = Eigen::Vector3f::Zero();  // sun-frame ray per pixel step in x, y, and at pixel (0, 0)
};

// Calls span(y, x_first, x_last) for every row of pixel centres inside the triangle (sx, sy)
// (pixel units, y down), with exact 24.8 fixed-point edge functions and the top-left rule.
template <typename Span>
inline void rasterise(const double sx[3], const double sy[3], int width, int height,
                      Span&& row_span) {
  std::int64_t X[3], Y[3];
  for (int i = 0; i < 3; ++i) {
    X[i] = std::llround(sx[i] * 256.0);
    Y[i] = std::llround(sy[i] * 256.0);
  }
  std::int64_t area = (X[1] - X[0]) * (Y[2] - Y[0]) - (Y[1] - Y[0]) * (X[2] - X[0]);
  if (area == 0) return;
  if (area < 0) {
    std::swap(X[1], X[2]);
    std::swap(Y[1], Y[2]);
  }
  const std::int64_t min_x = std::min({X[0], X[1], X[2]}), max_x = std::max({X[0], X[1], X[2]});
  const std::int64_t min_y = std::min({Y[0], Y[1], Y[2]}), max_y = std::max({Y[0], Y[1], Y[2]});
  auto ceil_div = [](std::int64_t a) { return a >= 0 ? (a + 255) / 256 : -((-a) / 256); };
  auto floor_div = [](std::int64_t a) { return a >= 0 ? a / 256 : -((-a + 255) / 256); };
  const int x0 = static_cast<int>(std::max<std::int64_t>(0, ceil_div(min_x)));
  const int x1 = static_cast<int>(std::min<std::int64_t>(width - 1, floor_div(max_x)));
  const int y0 = static_cast<int>(std::max<std::int64_t>(0, ceil_div(min_y)));
  const int y1 = static_cast<int>(std::min<std::int64_t>(height - 1, floor_div(max_y)));
  if (x0 > x1 || y0 > y1) return;
  std::int64_t step_x[3], step_y[3], row[3];
  for (int k = 0; k < 3; ++k) {
    const int j = (k + 1) % 3;
    const std::int64_t dx = X[j] - X[k], dy = Y[j] - Y[k];
    // Top edge (horizontal, interior below) or left edge (going up): pixels on it are in.
    const std::int64_t bias = (dy < 0 || (dy == 0 && dx > 0)) ? 0 : -1;
    step_x[k] = -dy * 256;
    step_y[k] = dx * 256;
    row[k] = dx * (std::int64_t{y0} * 256 - Y[k]) - dy * (std::int64_t{x0} * 256 - X[k]) + bias;
  }
  const std::int64_t span = x1 - x0;
  for (int y = y0; y <= y1; ++y) {
    // The covered span of this row from the three edge functions (no per-pixel tests).
    std::int64_t lo = 0, hi = span;
    for (int k = 0; k < 3 && lo <= hi; ++k) {
      const std::int64_t e = row[k], s = step_x[k];
      if (s > 0) {
        if (e < 0) lo = std::max(lo, (-e + s - 1) / s);
      } else if (s < 0) {
        if (e < 0)
          hi = -1;
        else
          hi = std::min(hi, e / (-s));
      } else if (e < 0) {
        hi = -1;
      }
    }
    if (lo <= hi) row_span(y, x0 + static_cast<int>(lo), x0 + static_cast<int>(hi));
    for (int k = 0; k < 3; ++k) row[k] += step_y[k];
  }
}

// Clips a camera-space polygon against planes n.p + d >= 0 (Sutherland-Hodgman).
struct ClipPlane {
  Eigen::Vector3d n;
  double d;
};

int clipPolygon(Eigen::Vector3d* poly, int count, const ClipPlane& plane, Eigen::Vector3d* out) {
  int n = 0;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d& a = poly[i];
    const Eigen::Vector3d& b = poly[(i + 1) % count];
    const double da = plane.n.dot(a) + plane.d, db = plane.n.dot(b) + plane.d;
    if (da >= 0) out[n++] = a;
    if ((da >= 0) != (db >= 0)) out[n++] = a + (b - a) * (da / (da - db));
  }
  return n;
}

// A run of pixels of one row that show the same triangle (see raster_kernels.hpp).
struct PixelRun {
  int first, last;                // [first, last) in the chunk
  std::uint32_t code;             // the visibility buffer's entry
  const ShadeMaterial* material;  // null where nothing was drawn
};

class CpuRenderer final : public Renderer {
 public:
  RendererBackend backend() const override { return RendererBackend::kCpu; }
  std::string description() const override {
    return "cpu: CDFF rasteriser (visibility buffer, fixed-point coverage, single thread)";
  }

  Result<int> addModel(const TargetModel& model) override {
    CDFF_RETURN_IF_ERROR(model.validate());
    ModelData m;
    m.vertices.assign(model.mesh.vertices.begin(), model.mesh.vertices.end());
    m.normals.assign(model.mesh.vertex_normals.begin(), model.mesh.vertex_normals.end());
    m.triangles.assign(model.mesh.triangles.begin(), model.mesh.triangles.end());
    m.material = model.triangle_material;
    for (const Material& mat : model.materials) m.materials.emplace_back(mat);
    for (const auto& t : m.triangles) {
      Eigen::Vector3f n =
          (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
      n = n.norm() > 0 ? n.normalized() : Eigen::Vector3f::UnitZ();
      // Orient the face normal with the shading normals (files may wind inconsistently).
      if (n.dot(m.normals[t[0]] + m.normals[t[1]] + m.normals[t[2]]) < 0) n = -n;
      m.face_normal.push_back(n);
      bool flat = true;
      for (int k = 0; k < 3; ++k) flat = flat && (m.normals[t[k]] - n).norm() < 1e-6f;
      m.flat.push_back(flat ? 1 : 0);
    }
    m.centre = model.boundingCentre();
    m.radius = model.boundingRadius();
    models_.push_back(std::move(m));
    return static_cast<int>(models_.size() - 1);
  }

  Status render(const RenderScene& scene, const PinholeCamera& camera, RenderOutput& out) override {
    if (camera.width <= 0 || camera.height <= 0 || !(camera.fx > 0) || !(camera.fy > 0))
      return invalidInput(
          "cpu renderer: camera {}x{} with fx = {}, fy = {}; expected a positive size and focal "
          "lengths",
          camera.width, camera.height, camera.fx, camera.fy);
    if (scene.objects.size() > 255)
      return invalidInput("cpu renderer: {} objects; expected at most 255", scene.objects.size());
    for (const RenderObject& o : scene.objects)
      if (o.model < 0 || o.model >= static_cast<int>(models_.size()))
        return invalidInput("cpu renderer: object uses model {}; {} models were added", o.model,
                            models_.size());
    const int W = camera.width, H = camera.height;
    const std::size_t pixels = static_cast<std::size_t>(W) * H;
    if (inv_depth_.size() != pixels) {
      inv_depth_.assign(pixels, 0.0f);
      vis_.assign(pixels, kNoSurface);
      dirty_ = {W, H, -1, -1};
    }
    if (out.width != W || out.height != H || out.depth.size() != pixels) out.resize(W, H);

    // Camera-space vertices of every object.
    frame_vertices_.resize(scene.objects.size());
    for (std::size_t o = 0; o < scene.objects.size(); ++o) {
      const ModelData& m = models_[scene.objects[o].model];
      const Eigen::Matrix3f R = scene.objects[o].camera_T_object.linear().cast<float>();
      const Eigen::Vector3f t = scene.objects[o].camera_T_object.translation().cast<float>();
      auto& fv = frame_vertices_[o];
      fv.resize(m.vertices.size());
      for (std::size_t v = 0; v < m.vertices.size(); ++v) fv[v] = R * m.vertices[v] + t;
    }

    const bool lit = scene.sun_irradiance > 0;
    shadow_frame_ = ShadowFrame{};
    if (lit && scene.shadows) buildShadowMap(scene);
    rasteriseScene(scene, camera);
    setUpTriangles(scene, camera);
    shade(scene, camera, out);
    return Status::ok();
  }

 private:
  void rasteriseScene(const RenderScene& scene, const PinholeCamera& cam) {
    const int W = cam.width, H = cam.height;
    const ClipPlane planes[5] = {
        {{0, 0, 1}, -cam.near_plane},
        {{cam.fx, 0, cam.cx + kGuardBand}, 0},
        {{-cam.fx, 0, W - 1 + kGuardBand - cam.cx}, 0},
        {{0, cam.fy, cam.cy + kGuardBand}, 0},
        {{0, -cam.fy, H - 1 + kGuardBand - cam.cy}, 0},
    };
    float* ibuf = inv_depth_.data();
    std::uint32_t* vis = vis_.data();
    Dirty& d = dirty_;
    for (std::size_t o = 0; o < scene.objects.size(); ++o) {
      const ModelData& m = models_[scene.objects[o].model];
      const auto& fv = frame_vertices_[o];
      for (std::size_t k = 0; k < m.triangles.size(); ++k) {
        const auto& tri = m.triangles[k];
        Eigen::Vector3d poly[9], tmp[9];
        for (int i = 0; i < 3; ++i) poly[i] = fv[tri[i]].cast<double>();
        if (poly[0].z() > cam.far_plane && poly[1].z() > cam.far_plane &&
            poly[2].z() > cam.far_plane)
          continue;
        int count = 3;
        bool needs_clip = false;
        for (int i = 0; i < 3 && !needs_clip; ++i)
          for (const ClipPlane& p : planes)
            if (p.n.dot(poly[i]) + p.d < 0) {
              needs_clip = true;
              break;
            }
        if (needs_clip) {
          for (const ClipPlane& p : planes) {
            count = clipPolygon(poly, count, p, tmp);
            std::copy(tmp, tmp + count, poly);
            if (count < 3) break;
          }
          if (count < 3) continue;
        }
        const std::uint32_t code =
            (static_cast<std::uint32_t>(o) << 24) | static_cast<std::uint32_t>(k);
        // Fan over the (clipped) polygon.
        double u[9], v[9], iz[9];
        for (int i = 0; i < count; ++i) {
          iz[i] = 1.0 / poly[i].z();
          u[i] = cam.fx * poly[i].x() * iz[i] + cam.cx;
          v[i] = cam.fy * poly[i].y() * iz[i] + cam.cy;
        }
        for (int i = 1; i + 1 < count; ++i) {
          const double sx[3] = {u[0], u[i], u[i + 1]}, sy[3] = {v[0], v[i], v[i + 1]};
          const double sz[3] = {iz[0], iz[i], iz[i + 1]};
          // Inverse depth is affine in screen space: iz = A u + B v + C.
          const double det = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
          if (det == 0) continue;
          const double A =
              ((sz[1] - sz[0]) * (sy[2] - sy[0]) - (sz[2] - sz[0]) * (sy[1] - sy[0])) / det;
          const double B =
              ((sx[1] - sx[0]) * (sz[2] - sz[0]) - (sx[2] - sx[0]) * (sz[1] - sz[0])) / det;
          const double C = sz[0] - A * sx[0] - B * sy[0];
          // The dirty box grows by the triangle's box (clamped to the image).
          d.x0 = std::min(
              d.x0, std::max(0, static_cast<int>(std::floor(std::min({sx[0], sx[1], sx[2]})))));
          d.x1 = std::max(
              d.x1, std::min(W - 1, static_cast<int>(std::ceil(std::max({sx[0], sx[1], sx[2]})))));
          d.y0 = std::min(
              d.y0, std::max(0, static_cast<int>(std::floor(std::min({sy[0], sy[1], sy[2]})))));
          d.y1 = std::max(
              d.y1, std::min(H - 1, static_cast<int>(std::ceil(std::max({sy[0], sy[1], sy[2]})))));
          rasterise(sx, sy, W, H, [&](int y, int first, int last) {
            const std::size_t row = static_cast<std::size_t>(y) * W;
            depthTestSpan(first, last, A, B * y + C, code, ibuf + row, vis + row);
          });
        }
      }
    }
  }

  // The shadow map's texel (x, y), x and y from -kShadowBorder to size - 1 + kShadowBorder.
  float* shadowTexel(int x, int y) {
    const std::ptrdiff_t P = shadow_frame_.size + 2 * kShadowBorder;
    return shadow_.data() + (y + kShadowBorder) * P + x + kShadowBorder;
  }

  void buildShadowMap(const RenderScene& scene) {
    std::vector<std::pair<Eigen::Vector3d, double>> casters;
    for (const RenderObject& o : scene.objects) {
      if (!o.casts_shadow) continue;
      const ModelData& m = models_[o.model];
      casters.emplace_back(o.camera_T_object * m.centre, m.radius);
    }
    shadow_frame_ = fitShadowFrame(scene.sun_direction, casters, scene.shadow_map_size);
    if (!shadow_frame_.valid) return;
    const int S = shadow_frame_.size;
    const int P = S + 2 * kShadowBorder;  // stride: the border stays at infinity
    const float inf = std::numeric_limits<float>::infinity();
    if (shadow_.size() != static_cast<std::size_t>(P) * P) {
      shadow_.assign(static_cast<std::size_t>(P) * P, inf);
    } else if (shadow_dirty_.x0 <= shadow_dirty_.x1) {
      for (int y = shadow_dirty_.y0; y <= shadow_dirty_.y1; ++y) {
        float* row = shadowTexel(0, y);
        std::fill(row + shadow_dirty_.x0, row + shadow_dirty_.x1 + 1, inf);
      }
    }
    shadow_dirty_ = {S, S, -1, -1};
    Dirty& sd = shadow_dirty_;
    const Eigen::Matrix3d R = shadow_frame_.sun_T_camera.linear();
    const Eigen::Vector3d t = shadow_frame_.sun_T_camera.translation();
    for (std::size_t o = 0; o < scene.objects.size(); ++o) {
      if (!scene.objects[o].casts_shadow) continue;
      const ModelData& m = models_[scene.objects[o].model];
      const auto& fv = frame_vertices_[o];
      sun_vertices_.resize(fv.size());
      for (std::size_t v = 0; v < fv.size(); ++v) {
        const Eigen::Vector3d s = R * fv[v].cast<double>() + t;
        sun_vertices_[v] = {s.x() * shadow_frame_.scale + shadow_frame_.offset,
                            s.y() * shadow_frame_.scale + shadow_frame_.offset, s.z()};
      }
      for (const auto& tri : m.triangles) {
        const double sx[3] = {sun_vertices_[tri[0]].x(), sun_vertices_[tri[1]].x(),
                              sun_vertices_[tri[2]].x()};
        const double sy[3] = {sun_vertices_[tri[0]].y(), sun_vertices_[tri[1]].y(),
                              sun_vertices_[tri[2]].y()};
        const double sz[3] = {sun_vertices_[tri[0]].z(), sun_vertices_[tri[1]].z(),
                              sun_vertices_[tri[2]].z()};
        const double det = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
        if (det == 0) continue;
        // Orthographic: depth itself is affine in map coordinates.
        const double A =
            ((sz[1] - sz[0]) * (sy[2] - sy[0]) - (sz[2] - sz[0]) * (sy[1] - sy[0])) / det;
        const double B =
            ((sx[1] - sx[0]) * (sz[2] - sz[0]) - (sx[2] - sx[0]) * (sz[1] - sz[0])) / det;
        const double C = sz[0] - A * sx[0] - B * sy[0];
        rasterise(sx, sy, S, S, [&](int y, int first, int last) {
          const double row_c = B * y + C;
          float* __restrict map_row = shadowTexel(0, y);
          for (int x = first; x <= last; ++x) {
            const float depth = static_cast<float>(A * x + row_c);
            map_row[x] = depth < map_row[x] ? depth : map_row[x];
          }
          // The texels to clear next time (a superset of those written).
          sd.x0 = std::min(sd.x0, first);
          sd.x1 = std::max(sd.x1, last);
          sd.y0 = std::min(sd.y0, y);
          sd.y1 = std::max(sd.y1, y);
        });
      }
    }
  }

  // Everything the shading pass needs that is constant over a triangle (after the shadow map,
  // whose frame it uses).
  void setUpTriangles(const RenderScene& scene, const PinholeCamera& cam) {
    const Eigen::Vector3d L = scene.sun_direction.normalized();
    const PixelAffineOf affine(cam);
    const ShadowTransform shadow = setUpShadowTransform(cam);
    triangle_base_.resize(scene.objects.size());
    std::size_t total = 0;
    for (std::size_t o = 0; o < scene.objects.size(); ++o) {
      triangle_base_[o] = total;
      total += models_[scene.objects[o].model].triangles.size();
    }
    frame_triangles_.resize(total);
    for (std::size_t o = 0; o < scene.objects.size(); ++o) {
      const ModelData& m = models_[scene.objects[o].model];
      const Eigen::Matrix3d R = scene.objects[o].camera_T_object.linear();
      FrameTriangle* out = frame_triangles_.data() + triangle_base_[o];
      for (std::size_t k = 0; k < m.triangles.size(); ++k)
        setUpTriangle(m, k, R, frame_vertices_[o], L, affine, shadow, out[k]);
    }
  }

  // f = g . P + c on a triangle's plane, as a PixelAffine, with P = z (ifx (x - cx),
  // ify (y - cy), 1).
  struct PixelAffineOf {
    double ifx, ify, cx, cy;
    explicit PixelAffineOf(const PinholeCamera& cam)
        : ifx(1.0 / cam.fx), ify(1.0 / cam.fy), cx(cam.cx), cy(cam.cy) {}
    PixelAffine operator()(const Eigen::Vector3d& g, double c) const {
      PixelAffine a;
      a.kx = static_cast<float>(g.x() * ifx);
      a.ky = static_cast<float>(g.y() * ify);
      a.k0 = static_cast<float>(g.z() - g.x() * ifx * cx - g.y() * ify * cy);
      a.c = static_cast<float>(c);
      return a;
    }
  };

  // Shadow-map coordinates (texel x, y and the biased depth) of camera-frame points p:
  // S p + s0, and the offset along the normal.
  struct ShadowTransform {
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    Eigen::Vector3d s0 = Eigen::Vector3d::Zero();
    double normal_offset = 0;
  };

  // The shadow map's transform, also kept in float for the shading pass with the shadow-map ray
  // per pixel (identity and zero without a shadow map).
  ShadowTransform setUpShadowTransform(const PinholeCamera& cam) {
    const double ifx = 1.0 / cam.fx, ify = 1.0 / cam.fy;
    ShadowTransform st;
    Eigen::Matrix3d& S = st.S;
    Eigen::Vector3d& s0 = st.s0;
    if (shadow_frame_.valid) {
      const ShadowFrame& sf = shadow_frame_;
      S = sf.sun_T_camera.linear();
      S.row(0) *= sf.scale;
      S.row(1) *= sf.scale;
      s0 = sf.sun_T_camera.translation();
      s0.x() = s0.x() * sf.scale + sf.offset;
      s0.y() = s0.y() * sf.scale + sf.offset;
      s0.z() -= kShadowBiasTexels * sf.texel;
      st.normal_offset = kShadowNormalOffsetTexels * sf.texel;
      shadow_ray_.dx = (S.col(0) * ifx).cast<float>();
      shadow_ray_.dy = (S.col(1) * ify).cast<float>();
      shadow_ray_.d0 = (S.col(2) - S.col(0) * ifx * cam.cx - S.col(1) * ify * cam.cy).cast<float>();
    }
    sun_S_camera_ = S.cast<float>();
    sun_s0_ = s0.cast<float>();
    shadow_normal_offset_ = static_cast<float>(st.normal_offset);
    return st;
  }

  // Triangle k of model m, whose vertices are fv in the camera frame (R: camera <- body).
  void setUpTriangle(const ModelData& m, std::size_t k, const Eigen::Matrix3d& R,
                     const std::vector<Eigen::Vector3f>& fv, const Eigen::Vector3d& L,
                     const PixelAffineOf& affine, const ShadowTransform& shadow, FrameTriangle& f) {
    const auto& tri = m.triangles[k];
    f = FrameTriangle{};
    f.material = m.material[k];
    f.flat = m.flat[k];
    const Eigen::Vector3d a = fv[tri[0]].cast<double>();
    const Eigen::Vector3d e1 = fv[tri[1]].cast<double>() - a;
    const Eigen::Vector3d e2 = fv[tri[2]].cast<double>() - a;
    const double d00 = e1.dot(e1), d01 = e1.dot(e2), d11 = e2.dot(e2);
    const double denom = d00 * d11 - d01 * d01;
    if (!(denom > 0)) return;  // degenerate: covers no pixel centre
    // In-plane gradients of the barycentric coordinates of vertices 1 and 2.
    const Eigen::Vector3d gb = (d11 * e1 - d01 * e2) / denom;
    const Eigen::Vector3d gg = (d00 * e2 - d01 * e1) / denom;
    f.beta = affine(gb, -gb.dot(a));
    f.gamma = affine(gg, -gg.dot(a));
    if (!f.flat) return;
    const Eigen::Vector3f& n_o = m.face_normal[k];
    Eigen::Vector3d n = R * n_o.cast<double>();
    // Two-sided surfaces: seen from behind when the camera is on the back of the plane.
    const double side = n.dot(a) > 0 ? -1.0 : 1.0;
    n *= side;
    f.normal = n.cast<float>();
    f.ndl = static_cast<float>(n.dot(L));
    if (shadow_frame_.valid)
      f.shadow = (shadow.S * (shadow.normal_offset * n) + shadow.s0).cast<float>();
    const ShadeMaterial& mat = m.materials[f.material];
    if (mat.pattern == SurfacePattern::kNone) return;
    // Triplanar projection on the plane of the normal's two smaller components.
    const Eigen::Vector3f an = n_o.cwiseAbs();
    const int axis = an.x() >= an.y() && an.x() >= an.z() ? 0 : (an.y() >= an.z() ? 1 : 2);
    const int a1 = axis == 0 ? 1 : 0, a2 = axis == 2 ? 1 : 2;
    auto pattern = [&](int axis_index) {
      const double f0 = m.vertices[tri[0]][axis_index] * double{mat.pattern_frequency};
      const double f1 = m.vertices[tri[1]][axis_index] * double{mat.pattern_frequency};
      const double f2 = m.vertices[tri[2]][axis_index] * double{mat.pattern_frequency};
      const Eigen::Vector3d g = (f1 - f0) * gb + (f2 - f0) * gg;
      return affine(g, f0 - g.dot(a));
    };
    f.pattern_u = pattern(a1);
    f.pattern_v = pattern(a2);
    if (mat.pattern == SurfacePattern::kCrinkle) {
      f.tilt_u = (side * mat.pattern_strength * R.col(a1)).cast<float>();
      f.tilt_v = (side * mat.pattern_strength * R.col(a2)).cast<float>();
    }
  }

  // The shading pass, one row at a time in chunks whose arrays stay in the L1 cache:
  //   0. over the chunk: depth, view and half vectors (they depend on the pixel only);
  //   1. per run of pixels of one triangle: depth and id outputs, the shading normal (not
  //      normalised; 0 where the sun is below the surface), the shadow-map point, the albedo
  //      boost;
  //   2. over the chunk: unit normals, N.L and N.H, and the shadow factor;
  //   3. per run: the radiance, with the material's constants.
  // The operations are the scalar code's (IEEE, no reassociation): vectorised, the same bits.
  struct RowBuffers {
    std::vector<float> z, vx, vy, vz, hx, hy, hz, nx, ny, nz, ndl, ndh, sx, sy, sz, shadow;
    std::vector<float> albedo_boost;  // solar-cell interconnects: added to the diffuse albedo
    std::vector<float> f0, f1, f2, f3, f4, f5, f6, f7;  // scratch of the look-up loops
    std::vector<int> index, index2, index3;
    std::vector<PixelRun> runs;
    void resize(std::size_t n) {
      for (auto* v :
           {&z,  &vx, &vy,     &vz,           &hx, &hy, &hz, &nx, &ny, &nz, &ndl, &ndh, &sx,
            &sy, &sz, &shadow, &albedo_boost, &f0, &f1, &f2, &f3, &f4, &f5, &f6,  &f7})
        v->resize(n);
      for (auto* v : {&index, &index2, &index3}) v->resize(n);
      runs.resize(n);
    }
  };

  // What the shading pass reads for the whole frame, and the buffers it writes.
  struct ShadeFrame {
    const RenderScene* scene;
    Eigen::Vector3f L;  // towards the sun
    float E;            // the sun's irradiance
    bool lit, shadows;
    const std::uint8_t* crinkle_cells;
    const float* crinkle_tilts;
    const float* shadow_map;
    std::vector<Eigen::Matrix3f> rotations;  // per object, camera <- body
    float* rad;
    float* depth;
    std::uint8_t* ids;
    float* ibuf;
    std::uint32_t* vis;
    const FrameTriangle* triangles;
  };

  void shade(const RenderScene& scene, const PinholeCamera& cam, RenderOutput& out) {
    const int W = cam.width, H = cam.height;
    ShadeFrame fr;
    fr.scene = &scene;
    fr.L = scene.sun_direction.normalized().cast<float>();
    fr.E = static_cast<float>(scene.sun_irradiance);
    fr.lit = fr.E > 0;
    fr.shadows = shadow_frame_.valid;
    fr.crinkle_cells = crinkleCells().data();
    fr.crinkle_tilts = crinkleTilts().data();
    fr.shadow_map = fr.shadows ? shadowTexel(0, 0) : nullptr;
    const float ify = static_cast<float>(1.0 / cam.fy);
    const float cx = static_cast<float>(cam.cx), cy = static_cast<float>(cam.cy);
    const float ifx = static_cast<float>(1.0 / cam.fx);
    for (const RenderObject& o : scene.objects)
      fr.rotations.push_back(o.camera_T_object.linear().cast<float>());
    fr.rad = out.radiance.data();
    fr.depth = out.depth.data();
    fr.ids = out.id.data();
    fr.ibuf = inv_depth_.data();
    fr.vis = vis_.data();
    fr.triangles = frame_triangles_.data();
    // Outside the dirty box nothing was drawn: clear the outputs there in one go.
    const bool any = dirty_.x0 <= dirty_.x1 && dirty_.y0 <= dirty_.y1;
    const int x0 = dirty_.x0;
    const int n = any ? dirty_.x1 - dirty_.x0 + 1 : 0;
    row_.resize(kShadeChunk);
    column_rx_.resize(static_cast<std::size_t>(std::max(n, 0)));
    for (int j = 0; j < n; ++j) column_rx_[j] = (static_cast<float>(x0 + j) - cx) * ifx;
    for (int y = 0; y < H; ++y) {
      const std::size_t row = static_cast<std::size_t>(y) * W;
      const bool row_dirty = any && y >= dirty_.y0 && y <= dirty_.y1;
      if (!row_dirty) {
        clearOutputs(fr, row, row + W);
        continue;
      }
      clearOutputs(fr, row, row + dirty_.x0);
      clearOutputs(fr, row + dirty_.x1 + 1, row + W);
      const float fy = static_cast<float>(y);
      const float ry = (fy - cy) * ify;
      const Eigen::Vector3f shadow_row = shadow_ray_.dy * fy + shadow_ray_.d0;
      for (int c0 = 0; c0 < n; c0 += kShadeChunk) {
        const int cn = std::min(kShadeChunk, n - c0), xs = x0 + c0;
        shadeChunk(fr, row + xs, xs, c0, cn, fy, ry, shadow_row);
      }
    }
    dirty_ = {W, H, -1, -1};
  }

  // Pixels [from, to) show nothing.
  static void clearOutputs(const ShadeFrame& fr, std::size_t from, std::size_t to) {
    if (from >= to) return;
    const float inf = std::numeric_limits<float>::infinity();
    std::fill(fr.rad + 3 * from, fr.rad + 3 * to, 0.0f);
    std::fill(fr.depth + from, fr.depth + to, inf);
    std::memset(fr.ids + from, 0, to - from);
  }

  // The cn pixels of a row from column xs (pixel index i0), c0 columns into the dirty box.
  void shadeChunk(const ShadeFrame& fr, std::size_t i0, int xs, int c0, int cn, float fy, float ry,
                  const Eigen::Vector3f& shadow_row) {
    RowBuffers& b = row_;
    // Stage 0. (Where nothing was drawn the inverse depth is 0: z = inf, unused.)
    viewAndHalfVectors(cn, fr.ibuf + i0, column_rx_.data() + c0, ry, fr.L, b.z.data(), b.vx.data(),
                       b.vy.data(), b.vz.data(), b.hx.data(), b.hy.data(), b.hz.data());
    // The runs of equal visibility-buffer entries; the buffer is reset as it is read.
    int run_count = 0;
    for (int j = 0; j < cn;) {
      const std::uint32_t code = fr.vis[i0 + j];
      int e = j + 1;
      while (e < cn && fr.vis[i0 + e] == code) ++e;
      b.runs[run_count++] = {j, e, code, nullptr};
      j = e;
    }
    std::fill(fr.vis + i0, fr.vis + i0 + cn, kNoSurface);
    std::fill(fr.ibuf + i0, fr.ibuf + i0 + cn, 0.0f);
    // Stage 1.
    for (int r = 0; r < run_count; ++r) shadeRun(fr, b.runs[r], i0, xs, fy, shadow_row);
    // Stage 2.
    normalDotProducts(cn, b.nx.data(), b.ny.data(), b.nz.data(), b.hx.data(), b.hy.data(),
                      b.hz.data(), fr.L, b.ndl.data(), b.ndh.data());
    if (fr.shadows)
      shadowFactors(cn, b.sx.data(), b.sy.data(), b.sz.data(), fr.shadow_map, shadow_frame_.size,
                    b.index.data(), b.f0.data(), b.f1.data(), b.f2.data(), b.f3.data(), b.f4.data(),
                    b.f5.data(), b.shadow.data());
    else
      fillSpan(cn, 1.0f, b.shadow.data());
    // Stage 3, over runs of one material (neighbouring triangles often share it).
    for (int r = 0; r < run_count;) {
      const int first = b.runs[r].first;
      const ShadeMaterial* mat = b.runs[r].material;
      int e = r + 1;
      while (e < run_count && b.runs[e].material == mat) ++e;
      const int last = b.runs[e - 1].last;
      r = e;
      float* c = fr.rad + 3 * (i0 + first);
      if (mat == nullptr) {
        std::fill(c, c + 3 * (last - first), 0.0f);
        continue;
      }
      radianceSpan(last - first, *mat, fr.E, b.ndl.data() + first, b.ndh.data() + first,
                   b.shadow.data() + first, b.albedo_boost.data() + first, b.index.data(),
                   b.f0.data(), b.f1.data(), b.f2.data(), b.f3.data(), b.f4.data(), b.f5.data(), c);
    }
  }

  // Stage 1 of a run: the depth and id outputs, the shading normal, the shadow-map point and the
  // albedo boost; the run's material for stage 3.
  // Inlined, as a step of the row loop: it runs once per run of pixels.
  [[gnu::always_inline]] void shadeRun(const ShadeFrame& fr, PixelRun& run, std::size_t i0, int xs,
                                       float fy, const Eigen::Vector3f& shadow_row) {
    RowBuffers& b = row_;
    const auto [first, last, code, material] = run;
    const float inf = std::numeric_limits<float>::infinity();
    const int len = last - first;
    float* nx = b.nx.data() + first;
    float* ny = b.ny.data() + first;
    float* nz = b.nz.data() + first;
    float* sx = b.sx.data() + first;
    float* sy = b.sy.data() + first;
    float* sz = b.sz.data() + first;
    float* boost = b.albedo_boost.data() + first;
    const float* z = b.z.data() + first;
    auto unlit = [&] {
      for (float* v : {nx, ny, nz, sx, sy, sz, boost}) fillSpan(len, 0.0f, v);
    };
    if (code == kNoSurface) {
      std::fill(fr.depth + i0 + first, fr.depth + i0 + last, inf);
      std::memset(fr.ids + i0 + first, 0, static_cast<std::size_t>(len));
      unlit();
      return;
    }
    const std::size_t o = code >> 24, k = code & 0xffffffu;
    std::copy(z, z + len, fr.depth + i0 + first);
    std::memset(fr.ids + i0 + first, fr.scene->objects[o].id, static_cast<std::size_t>(len));
    const FrameTriangle& f = fr.triangles[triangle_base_[o] + k];
    const ModelData& m = models_[fr.scene->objects[o].model];
    const ShadeMaterial& mat = m.materials[f.material];
    run.material = &mat;
    if (!fr.lit || (f.flat && !(f.ndl > 0))) {
      unlit();
      return;
    }
    if (!f.flat) {
      const SmoothTriangle t = smoothTriangle(fr, m, k, fr.rotations[o], f, mat, shadow_row);
      smoothSpan(len, xs + first, fy, t, z, b.vx.data() + first, b.vy.data() + first,
                 b.vz.data() + first, fr.crinkle_cells, fr.crinkle_tilts, b.f0.data(), b.f1.data(),
                 b.f2.data(), b.f3.data(), b.f4.data(), b.f5.data(), b.f6.data(), b.f7.data(),
                 b.index.data(), b.index2.data(), b.index3.data(), nx, ny, nz, boost, sx, sy, sz);
      return;
    }
    const int x_first = xs + first;
    if (mat.pattern == SurfacePattern::kCrinkle) {
      crinkleTexels(len, x_first, fy, z, f.pattern_u, f.pattern_v, b.index.data());
      facetTilts(len, b.index.data(), fr.crinkle_cells, fr.crinkle_tilts, b.f0.data(), b.f1.data());
      tiltedNormals(len, f.normal, f.tilt_u, f.tilt_v, b.f0.data(), b.f1.data(), nx, ny, nz);
    } else {
      fillSpan(len, f.normal.x(), nx);
      fillSpan(len, f.normal.y(), ny);
      fillSpan(len, f.normal.z(), nz);
    }
    if (mat.pattern == SurfacePattern::kSolarCell)
      solarCellBoost(len, x_first, fy, z, f.pattern_u, f.pattern_v, mat.pattern_strength, boost);
    else
      fillSpan(len, 0.0f, boost);
    shadowPoints(len, x_first, z, shadow_ray_.dx, shadow_row, f.shadow, sx, sy, sz);
  }

  // The constants of triangle k of model m (camera <- body: R) for smoothSpan.
  SmoothTriangle smoothTriangle(const ShadeFrame& fr, const ModelData& m, std::size_t k,
                                const Eigen::Matrix3f& R, const FrameTriangle& f,
                                const ShadeMaterial& mat, const Eigen::Vector3f& shadow_row) const {
    const auto& tri = m.triangles[k];
    SmoothTriangle t;
    t.beta = f.beta;
    t.gamma = f.gamma;
    for (int v = 0; v < 3; ++v) {
      t.n[v] = m.normals[tri[v]];
      t.p[v] = m.vertices[tri[v]];
    }
    t.R = R;
    t.L = fr.L;
    t.ray_dx = shadow_ray_.dx;
    t.ray_row = shadow_row;
    t.shadows = fr.shadows;
    t.S = sun_S_camera_;
    t.s0 = sun_s0_;
    t.normal_offset = shadow_normal_offset_;
    t.pattern = mat.pattern;
    t.frequency = mat.pattern_frequency;
    t.strength = mat.pattern_strength;
    return t;
  }

  struct Dirty {
    int x0, y0, x1, y1;
  };

  std::vector<ModelData> models_;
  std::vector<float> inv_depth_;
  std::vector<std::uint32_t> vis_;
  Dirty dirty_{0, 0, -1, -1};
  std::vector<std::vector<Eigen::Vector3f>> frame_vertices_;
  std::vector<FrameTriangle> frame_triangles_;
  std::vector<std::size_t> triangle_base_;  // per object: its first triangle in frame_triangles_
  std::vector<Eigen::Vector3d> sun_vertices_;
  std::vector<float> shadow_;
  Dirty shadow_dirty_{0, 0, -1, -1};
  ShadowFrame shadow_frame_;
  ShadowLookup shadow_ray_;
  Eigen::Matrix3f sun_S_camera_ = Eigen::Matrix3f::Identity();  // to shadow-map coordinates
  Eigen::Vector3f sun_s0_ = Eigen::Vector3f::Zero();
  float shadow_normal_offset_ = 0;
  RowBuffers row_;
  std::vector<float> column_rx_;  // the ray's x per column of the dirty box
};

}  // namespace

}  // namespace raster

std::unique_ptr<Renderer> createCpuRenderer() {
  return std::make_unique<raster::CpuRenderer>();
}

}  // namespace cdff::egse
