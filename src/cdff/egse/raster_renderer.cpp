// The CPU rasteriser: a visibility buffer filled with exact fixed-point coverage (pixel centres,
// top-left rule) and perspective-correct inverse depth, then one shading pass per covered pixel
// with the shading model documented in render.hpp. Deterministic: single-threaded, no
// dependence on timing; the same inputs give the same bits.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "cdff/egse/render.hpp"

namespace cdff::egse {

namespace {

constexpr std::uint32_t kNoSurface = 0xffffffffu;
constexpr double kGuardBand = 4096.0;  // pixels outside the image before clipping in 3D

struct ModelData {
  std::vector<Eigen::Vector3f> vertices, normals;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint16_t> material;
  std::vector<Material> materials;
  std::vector<float> specular_cutoff;  // per material: N.H below which the lobe is < 1e-6
  std::vector<std::uint8_t> flat;      // the three normals equal the face normal
  std::vector<Eigen::Vector3f> face_normal;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0;
};

// A triangle of the current frame in camera coordinates, set up for barycentric lookups.
struct FrameTriangle {
  Eigen::Vector3f a, e1, e2;
  float d00, d01, d11, inv_denom;
  Eigen::Vector3f normal;  // the face normal in camera coordinates
};

// Calls fragment(x, y) for every pixel centre inside the triangle (sx, sy) (pixel units, y
// down), with exact 24.8 fixed-point edge functions and the top-left rule.
template <typename Fragment>
inline void rasterise(const double sx[3], const double sy[3], int width, int height,
                      Fragment&& fragment) {
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
    for (std::int64_t i = lo; i <= hi; ++i) fragment(x0 + static_cast<int>(i), y);
    for (int k = 0; k < 3; ++k) row[k] += step_y[k];
  }
}

// One division per vector instead of three (Eigen's normalized() divides each coefficient).
inline Eigen::Vector3f unit(const Eigen::Vector3f& v) {
  return v * (1.0f / std::sqrt(v.squaredNorm()));
}

// A 3x3 product written out, so that it inlines in the shading loop.
inline Eigen::Vector3f rotate(const Eigen::Matrix3f& R, const Eigen::Vector3f& v) {
  return {R(0, 0) * v.x() + R(0, 1) * v.y() + R(0, 2) * v.z(),
          R(1, 0) * v.x() + R(1, 1) * v.y() + R(1, 2) * v.z(),
          R(2, 0) * v.x() + R(2, 1) * v.y() + R(2, 2) * v.z()};
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
    m.materials = model.materials;
    for (const Material& mat : m.materials)
      m.specular_cutoff.push_back(std::exp(-13.8f / std::max(mat.shininess, 1.0f)));
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

    // Camera-space vertices and per-triangle set-up of every object.
    frame_vertices_.resize(scene.objects.size());
    frame_triangles_.resize(scene.objects.size());
    for (std::size_t o = 0; o < scene.objects.size(); ++o) {
      const ModelData& m = models_[scene.objects[o].model];
      const Eigen::Matrix3f R = scene.objects[o].camera_T_object.linear().cast<float>();
      const Eigen::Vector3f t = scene.objects[o].camera_T_object.translation().cast<float>();
      auto& fv = frame_vertices_[o];
      fv.resize(m.vertices.size());
      for (std::size_t v = 0; v < m.vertices.size(); ++v) fv[v] = R * m.vertices[v] + t;
      auto& ft = frame_triangles_[o];
      ft.resize(m.triangles.size());
      for (std::size_t k = 0; k < m.triangles.size(); ++k) {
        const auto& tri = m.triangles[k];
        FrameTriangle& f = ft[k];
        f.a = fv[tri[0]];
        f.e1 = fv[tri[1]] - f.a;
        f.e2 = fv[tri[2]] - f.a;
        f.d00 = f.e1.dot(f.e1);
        f.d01 = f.e1.dot(f.e2);
        f.d11 = f.e2.dot(f.e2);
        const float denom = f.d00 * f.d11 - f.d01 * f.d01;
        f.inv_denom = denom != 0 ? 1.0f / denom : 0.0f;
        f.normal = R * m.face_normal[k];
      }
    }

    const bool lit = scene.sun_irradiance > 0;
    shadow_frame_ = ShadowFrame{};
    if (lit && scene.shadows) buildShadowMap(scene);
    rasteriseScene(scene, camera);
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
          rasterise(sx, sy, W, H, [&](int x, int y) {
            const float value = static_cast<float>(A * x + B * y + C);
            const std::size_t i = static_cast<std::size_t>(y) * W + x;
            if (value > ibuf[i]) {
              ibuf[i] = value;
              vis[i] = code;
            }
          });
        }
      }
    }
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
    sun_R_camera_ = shadow_frame_.sun_T_camera.linear().cast<float>();
    sun_t_camera_ = shadow_frame_.sun_T_camera.translation().cast<float>();
    shadow_scale_ = static_cast<float>(shadow_frame_.scale);
    shadow_offset_ = static_cast<float>(shadow_frame_.offset);
    shadow_bias_ = static_cast<float>(kShadowBiasTexels * shadow_frame_.texel);
    const int S = shadow_frame_.size;
    const float inf = std::numeric_limits<float>::infinity();
    if (shadow_.size() != static_cast<std::size_t>(S) * S) {
      shadow_.assign(static_cast<std::size_t>(S) * S, inf);
    } else if (shadow_dirty_.x0 <= shadow_dirty_.x1) {
      for (int y = shadow_dirty_.y0; y <= shadow_dirty_.y1; ++y)
        std::fill(shadow_.begin() + static_cast<std::ptrdiff_t>(y) * S + shadow_dirty_.x0,
                  shadow_.begin() + static_cast<std::ptrdiff_t>(y) * S + shadow_dirty_.x1 + 1, inf);
    }
    shadow_dirty_ = {S, S, -1, -1};
    Dirty& sd = shadow_dirty_;
    const Eigen::Matrix3d R = shadow_frame_.sun_T_camera.linear();
    const Eigen::Vector3d t = shadow_frame_.sun_T_camera.translation();
    float* map = shadow_.data();
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
        rasterise(sx, sy, S, S, [&](int x, int y) {
          const float depth = static_cast<float>(A * x + B * y + C);
          float& cell = map[static_cast<std::size_t>(y) * S + x];
          if (depth < cell) {
            cell = depth;
            sd.x0 = std::min(sd.x0, x);
            sd.x1 = std::max(sd.x1, x);
            sd.y0 = std::min(sd.y0, y);
            sd.y1 = std::max(sd.y1, y);
          }
        });
      }
    }
  }

  // Fraction of the 2x2 texel neighbourhood (bilinear weights) that sees the sun at point p
  // (camera frame).
  float shadowFactor(const Eigen::Vector3f& p) const {
    const ShadowFrame& f = shadow_frame_;
    const Eigen::Vector3f s = rotate(sun_R_camera_, p) + sun_t_camera_;
    const float tx = s.x() * shadow_scale_ + shadow_offset_,
                ty = s.y() * shadow_scale_ + shadow_offset_;
    const float fx = std::floor(tx), fy = std::floor(ty);
    const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
    const float wx = tx - fx, wy = ty - fy;
    const float depth = s.z() - shadow_bias_;
    auto lit = [&](int x, int y) -> float {
      if (x < 0 || y < 0 || x >= f.size || y >= f.size) return 1.0f;
      return depth <= shadow_[static_cast<std::size_t>(y) * f.size + x] ? 1.0f : 0.0f;
    };
    return (1 - wy) * ((1 - wx) * lit(ix, iy) + wx * lit(ix + 1, iy)) +
           wy * ((1 - wx) * lit(ix, iy + 1) + wx * lit(ix + 1, iy + 1));
  }

  void shade(const RenderScene& scene, const PinholeCamera& cam, RenderOutput& out) {
    const int W = cam.width, H = cam.height;
    const float inf = std::numeric_limits<float>::infinity();
    const Eigen::Vector3f L = scene.sun_direction.normalized().cast<float>();
    const float E = static_cast<float>(scene.sun_irradiance);
    const bool shadows = shadow_frame_.valid;
    const float offset =
        shadows ? static_cast<float>(kShadowNormalOffsetTexels * shadow_frame_.texel) : 0.0f;
    const std::uint8_t* crinkle_cells = crinkleCells().data();
    const float* crinkle_tilts = crinkleTilts().data();
    const float ifx = static_cast<float>(1.0 / cam.fx), ify = static_cast<float>(1.0 / cam.fy);
    const float cx = static_cast<float>(cam.cx), cy = static_cast<float>(cam.cy);
    std::vector<Eigen::Matrix3f> rotations;
    for (const RenderObject& o : scene.objects)
      rotations.push_back(o.camera_T_object.linear().cast<float>());
    float* rad = out.radiance.data();
    float* depth = out.depth.data();
    std::uint8_t* ids = out.id.data();
    // Outside the dirty box nothing was drawn: clear the outputs there in one go.
    const bool any = dirty_.x0 <= dirty_.x1 && dirty_.y0 <= dirty_.y1;
    auto clear = [&](std::size_t from, std::size_t to) {
      if (from >= to) return;
      std::fill(rad + 3 * from, rad + 3 * to, 0.0f);
      std::fill(depth + from, depth + to, inf);
      std::memset(ids + from, 0, to - from);
    };
    for (int y = 0; y < H; ++y) {
      const std::size_t row = static_cast<std::size_t>(y) * W;
      const bool row_dirty = any && y >= dirty_.y0 && y <= dirty_.y1;
      if (!row_dirty) {
        clear(row, row + W);
        continue;
      }
      clear(row, row + dirty_.x0);
      clear(row + dirty_.x1 + 1, row + W);
      for (int x = dirty_.x0; x <= dirty_.x1; ++x) {
        const std::size_t i = row + x;
        const std::uint32_t code = vis_[i];
        if (code == kNoSurface) {
          rad[3 * i] = rad[3 * i + 1] = rad[3 * i + 2] = 0.0f;
          depth[i] = inf;
          ids[i] = 0;
          continue;
        }
        const std::size_t o = code >> 24, k = code & 0xffffffu;
        const ModelData& m = models_[scene.objects[o].model];
        const float z = 1.0f / inv_depth_[i];
        const Eigen::Vector3f P(z * (x - cx) * ifx, z * (y - cy) * ify, z);
        const FrameTriangle& ft = frame_triangles_[o][k];
        const Eigen::Vector3f v2 = P - ft.a;
        const float d20 = v2.dot(ft.e1), d21 = v2.dot(ft.e2);
        const float beta = (ft.d11 * d20 - ft.d01 * d21) * ft.inv_denom;
        const float gamma = (ft.d00 * d21 - ft.d01 * d20) * ft.inv_denom;
        const float alpha = 1.0f - beta - gamma;
        const auto& tri = m.triangles[k];
        const Material& mat = m.materials[m.material[k]];
        Eigen::Vector3f n_o = m.flat[k]
                                  ? m.face_normal[k]
                                  : unit(alpha * m.normals[tri[0]] + beta * m.normals[tri[1]] +
                                         gamma * m.normals[tri[2]]);
        Eigen::Vector3f albedo = mat.diffuse;
        Eigen::Vector3f shading_n_o = n_o;
        if (mat.pattern != SurfacePattern::kNone) {
          const Eigen::Vector3f p_o =
              alpha * m.vertices[tri[0]] + beta * m.vertices[tri[1]] + gamma * m.vertices[tri[2]];
          // Triplanar projection on the plane of the normal's two smaller components.
          const Eigen::Vector3f an = n_o.cwiseAbs();
          const int axis = an.x() >= an.y() && an.x() >= an.z() ? 0 : (an.y() >= an.z() ? 1 : 2);
          const int a1 = axis == 0 ? 1 : 0, a2 = axis == 2 ? 1 : 2;
          if (mat.pattern == SurfacePattern::kCrinkle) {
            const float tile = kCrinkleTileFacets * mat.pattern_scale;
            const int tx =
                static_cast<int>(std::floor(p_o[a1] / tile * kCrinkleSize)) & (kCrinkleSize - 1);
            const int ty =
                static_cast<int>(std::floor(p_o[a2] / tile * kCrinkleSize)) & (kCrinkleSize - 1);
            const float* tilt = crinkle_tilts + 2 * crinkle_cells[ty * kCrinkleSize + tx];
            Eigen::Vector3f perturbed = n_o;
            perturbed[a1] += mat.pattern_strength * tilt[0];
            perturbed[a2] += mat.pattern_strength * tilt[1];
            shading_n_o = unit(perturbed);
          } else {
            const float cu = p_o[a1] / mat.pattern_scale, cv = p_o[a2] / mat.pattern_scale;
            if (cu - std::floor(cu) < kSolarCellGap || cv - std::floor(cv) < kSolarCellGap)
              albedo = albedo + Eigen::Vector3f::Constant(mat.pattern_strength);
          }
        }
        const Eigen::Matrix3f& R = rotations[o];
        Eigen::Vector3f Ng = m.flat[k] ? ft.normal : rotate(R, n_o);
        Eigen::Vector3f N = mat.pattern == SurfacePattern::kCrinkle ? rotate(R, shading_n_o) : Ng;
        const Eigen::Vector3f V = -unit(P);
        if (Ng.dot(V) < 0) {  // two-sided surfaces
          Ng = -Ng;
          N = -N;
        }
        Eigen::Vector3f colour = Eigen::Vector3f::Zero();
        const float ndl_geometric = Ng.dot(L);
        if (E > 0 && ndl_geometric > 0) {
          const float s = shadows ? shadowFactor(P + offset * Ng) : 1.0f;
          const float ndl = std::max(0.0f, N.dot(L));
          if (s > 0 && ndl > 0) {
            colour = albedo * ndl;
            const float ndh = std::max(0.0f, N.dot(unit(L + V)));
            if (ndh > m.specular_cutoff[m.material[k]]) {
              const float lobe = (mat.shininess + 8.0f) / 8.0f * std::pow(ndh, mat.shininess);
              colour += mat.specular * (lobe * ndl);
            }
            colour *= E * s;
          }
        }
        rad[3 * i] = colour.x();
        rad[3 * i + 1] = colour.y();
        rad[3 * i + 2] = colour.z();
        depth[i] = z;
        ids[i] = scene.objects[o].id;
      }
    }
    // Reset the visibility buffer where it was written.
    if (any && dirty_.x0 <= dirty_.x1)
      for (int y = dirty_.y0; y <= dirty_.y1; ++y) {
        std::fill(inv_depth_.begin() + static_cast<std::ptrdiff_t>(y) * W + dirty_.x0,
                  inv_depth_.begin() + static_cast<std::ptrdiff_t>(y) * W + dirty_.x1 + 1, 0.0f);
        std::fill(vis_.begin() + static_cast<std::ptrdiff_t>(y) * W + dirty_.x0,
                  vis_.begin() + static_cast<std::ptrdiff_t>(y) * W + dirty_.x1 + 1, kNoSurface);
      }
    dirty_ = {W, H, -1, -1};
  }

  struct Dirty {
    int x0, y0, x1, y1;
  };

  std::vector<ModelData> models_;
  std::vector<float> inv_depth_;
  std::vector<std::uint32_t> vis_;
  Dirty dirty_{0, 0, -1, -1};
  std::vector<std::vector<Eigen::Vector3f>> frame_vertices_;
  std::vector<std::vector<FrameTriangle>> frame_triangles_;
  std::vector<Eigen::Vector3d> sun_vertices_;
  std::vector<float> shadow_;
  Dirty shadow_dirty_{0, 0, -1, -1};
  ShadowFrame shadow_frame_;
  Eigen::Matrix3f sun_R_camera_ = Eigen::Matrix3f::Identity();
  Eigen::Vector3f sun_t_camera_ = Eigen::Vector3f::Zero();
  float shadow_scale_ = 1, shadow_offset_ = 0, shadow_bias_ = 0;
};

}  // namespace

std::unique_ptr<Renderer> createCpuRenderer() {
  return std::make_unique<CpuRenderer>();
}

}  // namespace cdff::egse
