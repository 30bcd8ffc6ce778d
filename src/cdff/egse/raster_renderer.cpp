// The CPU rasteriser: a visibility buffer filled with exact fixed-point coverage (pixel centres,
// top-left rule) and perspective-correct inverse depth, then one shading pass per covered pixel
// with the shading model documented in render.hpp. Deterministic: single-threaded, no
// dependence on timing; the same inputs give the same bits.
//
// The shading pass is the cost at high coverage, so everything that is constant over a
// triangle is set up once per frame (FrameTriangle): flat triangles (boxes, panels: most of
// a spacecraft) need no barycentrics per pixel, only a few affine functions of the pixel, and
// the specular lobe comes from a per-material table instead of pow(). Each row is then shaded
// in runs of pixels that show the same triangle, with loops the compiler vectorises (see
// PixelRun; figures in docs/simulator.md).
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "cdff/egse/render.hpp"

namespace cdff::egse {

namespace {

// The shading loops are also compiled for AVX2 (8 floats a vector), chosen at run time where
// the CPU has it; the baseline (SSE2) version runs everywhere else. Both do the same IEEE
// operations (AVX2 does not bring FMA, so nothing is contracted): the same bits either way.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define CDFF_SHADING_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define CDFF_SHADING_CLONES
#endif

constexpr std::uint32_t kNoSurface = 0xffffffffu;
constexpr double kGuardBand = 4096.0;  // pixels outside the image before clipping in 3D
// Samples of the specular lobe between its cut-off and N.H = 1. Linear interpolation between
// them is within 3.6e-4 of the lobe's peak for any exponent, and within 1.5e-3 of pow() itself
// (relative) for exponents from 10 up: far below the 1 % the renderers agree to.
constexpr int kLobeSamples = 256;
// Pixels per pass of the shading stages.
constexpr int kShadeChunk = 128;

// The per-material constants of the shading pass.
struct ShadeMaterial {
  Eigen::Vector3f diffuse = Eigen::Vector3f::Zero(), specular = Eigen::Vector3f::Zero();
  SurfacePattern pattern = SurfacePattern::kNone;
  float pattern_strength = 0;
  float pattern_frequency = 0;  // crinkle texels, or solar cells, per metre
  float lobe_cutoff = 0;        // N.H below which the lobe is < 1e-6 of its peak: no specular
  float lobe_step = 0;          // table samples per unit of N.H
  std::array<float, kLobeSamples + 2> lobe{};

  explicit ShadeMaterial(const Material& m) {
    diffuse = m.diffuse;
    specular = m.specular;
    pattern = m.pattern;
    pattern_strength = m.pattern_strength;
    pattern_frequency = m.pattern == SurfacePattern::kCrinkle
                            ? kCrinkleSize / (kCrinkleTileFacets * m.pattern_scale)
                            : 1.0f / m.pattern_scale;
    // Normalised Blinn-Phong: (n + 8) / 8 * (N.H)^n, sampled in double.
    const double n = m.shininess;
    const double cutoff = std::exp(-13.8 / std::max(n, 1.0));
    lobe_cutoff = static_cast<float>(cutoff);
    lobe_step = static_cast<float>(kLobeSamples / (1.0 - cutoff));
    for (int i = 0; i <= kLobeSamples; ++i)
      lobe[i] = static_cast<float>((n + 8.0) / 8.0 *
                                   std::pow(cutoff + (1.0 - cutoff) * i / kLobeSamples, n));
    lobe[kLobeSamples + 1] = lobe[kLobeSamples];  // so that N.H = 1 needs no special case
  }

  // Without branches: N.H against the cut-off is a coin toss on crinkled foil.
  float specularLobe(float ndh) const {
    const float t =
        std::clamp((ndh - lobe_cutoff) * lobe_step, 0.0f, static_cast<float>(kLobeSamples));
    const int i = static_cast<int>(t);
    const float f = t - static_cast<float>(i);
    const float value = lobe[i] + f * (lobe[i + 1] - lobe[i]);
    return ndh > lobe_cutoff ? value : 0.0f;
  }
};

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

// A quantity that is affine on a triangle in 3D, as a function of the pixel (x, y) and of the
// depth z there: f = z (kx x + ky y + k0) + c (P = z * ray(x, y) with an affine ray).
struct PixelAffine {
  float kx = 0, ky = 0, k0 = 0, c = 0;
  float at(float z, float x, float y) const { return z * (kx * x + ky * y + k0) + c; }
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

// floor() to an int without SSE4.1's roundss (the x86-64 baseline): the same value as
// static_cast<int>(std::floor(v)) for any v in the int range, in three instructions.
inline int floorToInt(float v) {
  const int i = static_cast<int>(v);
  return i - (v < static_cast<float>(i) ? 1 : 0);
}
// The fractional part v - floor(v).
inline float fraction(float v) {
  return v - static_cast<float>(floorToInt(v));
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

// Selects written as bit masks: GCC turns a conditional expression in a loop into a branch
// (jump threading runs before if-conversion), and a loop with a branch stays scalar.
inline std::uint32_t mask(bool condition) {
  return 0u - static_cast<std::uint32_t>(condition);
}
inline float select(std::uint32_t m, float if_set, float otherwise) {
  return std::bit_cast<float>((std::bit_cast<std::uint32_t>(if_set) & m) |
                              (std::bit_cast<std::uint32_t>(otherwise) & ~m));
}

// The depth test of pixels first..last of a row: inverse depth A x + row_c, nearer wins.
// Without branches: depth order is random.
CDFF_SHADING_CLONES void depthTestSpan(int first, int last, double A, double row_c,
                                       std::uint32_t code, float* __restrict inv_depth,
                                       std::uint32_t* __restrict vis) {
  for (int x = first; x <= last; ++x) {
    const float value = static_cast<float>(A * x + row_c);
    const float old = inv_depth[x];
    const std::uint32_t nearer = mask(value > old);
    inv_depth[x] = select(nearer, value, old);
    vis[x] = (code & nearer) | (vis[x] & ~nearer);
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

// Shading stages over a row of n pixels (see CpuRenderer::shade), as plain loops over arrays:
// GCC vectorises them (sqrtps, divps: the same IEEE results as scalar code).
CDFF_SHADING_CLONES void viewAndHalfVectors(int n, const float* __restrict inv_depth,
                                            const float* __restrict rx, float ry,
                                            const Eigen::Vector3f& sun, float* __restrict z,
                                            float* __restrict vx, float* __restrict vy,
                                            float* __restrict vz, float* __restrict hx,
                                            float* __restrict hy, float* __restrict hz) {
  const float ry2 = ry * ry + 1.0f, lx = sun.x(), ly = sun.y(), lz = sun.z();
  for (int j = 0; j < n; ++j) {
    z[j] = 1.0f / inv_depth[j];                              // inf where nothing was drawn (unused)
    const float v = -1.0f / std::sqrt(rx[j] * rx[j] + ry2);  // V = -unit(P)
    vx[j] = rx[j] * v;
    vy[j] = ry * v;
    vz[j] = v;
    const float h0 = vx[j] + lx, h1 = vy[j] + ly, h2 = v + lz;
    const float h = 1.0f / std::sqrt(h0 * h0 + h1 * h1 + h2 * h2);  // H = unit(L + V)
    hx[j] = h0 * h;
    hy[j] = h1 * h;
    hz[j] = h2 * h;
  }
}

CDFF_SHADING_CLONES void normalDotProducts(int n, const float* __restrict nx,
                                           const float* __restrict ny, const float* __restrict nz,
                                           const float* __restrict hx, const float* __restrict hy,
                                           const float* __restrict hz, const Eigen::Vector3f& sun,
                                           float* __restrict ndl, float* __restrict ndh) {
  const float lx = sun.x(), ly = sun.y(), lz = sun.z();
  for (int j = 0; j < n; ++j) {
    // Unlit pixels have N = 0: the tiny term keeps them at 0 instead of NaN (and changes no
    // unit-length normal's bits).
    const float inv = 1.0f / std::sqrt(nx[j] * nx[j] + ny[j] * ny[j] + nz[j] * nz[j] + 1e-30f);
    ndl[j] = (nx[j] * lx + ny[j] * ly + nz[j] * lz) * inv;
    ndh[j] = (nx[j] * hx[j] + ny[j] * hy[j] + nz[j] * hz[j]) * inv;
  }
}

// The stages below work on runs of pixels of one row that show the same triangle: everything
// that depends on the triangle or its material is then a constant of the loop, and the loops
// are plain arithmetic over arrays that GCC vectorises; the table look-ups (crinkle facets,
// shadow-map texels, specular lobe) are separate loops of loads between them.
struct PixelRun {
  int first, last;                // [first, last) in the chunk
  std::uint32_t code;             // the visibility buffer's entry
  const ShadeMaterial* material;  // null where nothing was drawn
};

// Shadow-map points z * ray(x, y) + offset of n pixels from column x_first, with
// ray(x, y) = dx x + row (row = dy y + d0).
CDFF_SHADING_CLONES void shadowPoints(int n, int x_first, const float* __restrict z,
                                      const Eigen::Vector3f& dx, const Eigen::Vector3f& row,
                                      const Eigen::Vector3f& offset, float* __restrict sx,
                                      float* __restrict sy, float* __restrict sz) {
  const float dx0 = dx.x(), dx1 = dx.y(), dx2 = dx.z();
  const float r0 = row.x(), r1 = row.y(), r2 = row.z();
  const float o0 = offset.x(), o1 = offset.y(), o2 = offset.z();
  for (int j = 0; j < n; ++j) {
    const float fx = static_cast<float>(x_first + j);
    sx[j] = z[j] * (dx0 * fx + r0) + o0;
    sy[j] = z[j] * (dx1 * fx + r1) + o1;
    sz[j] = z[j] * (dx2 * fx + r2) + o2;
  }
}

inline void fillSpan(int n, float value, float* __restrict out) {
  for (int j = 0; j < n; ++j) out[j] = value;
}

// Crinkle texels (row-major index in the tile) of n pixels of a flat triangle.
CDFF_SHADING_CLONES void crinkleTexels(int n, int x_first, float fy, const float* __restrict z,
                                       const PixelAffine& pu, const PixelAffine& pv,
                                       int* __restrict texel) {
  const float ux = pu.kx, uy = pu.ky, u0 = pu.k0, uc = pu.c;
  const float vx = pv.kx, vy = pv.ky, v0 = pv.k0, vc = pv.c;
  for (int j = 0; j < n; ++j) {
    const float fx = static_cast<float>(x_first + j);
    // The same operations, in the same order, as PixelAffine::at.
    const int tx = floorToInt(z[j] * (ux * fx + uy * fy + u0) + uc) & (kCrinkleSize - 1);
    const int ty = floorToInt(z[j] * (vx * fx + vy * fy + v0) + vc) & (kCrinkleSize - 1);
    texel[j] = ty * kCrinkleSize + tx;
  }
}

// The facet tilts of the texels (two loads per pixel, through the cell index).
CDFF_SHADING_CLONES void facetTilts(int n, const int* __restrict texel,
                                    const std::uint8_t* __restrict cells,
                                    const float* __restrict tilts, float* __restrict t0,
                                    float* __restrict t1) {
  for (int j = 0; j < n; ++j) {
    const float* t = tilts + 2 * cells[texel[j]];
    t0[j] = t[0];
    t1[j] = t[1];
  }
}

// N = normal + t0 tilt_u + t1 tilt_v (not normalised).
CDFF_SHADING_CLONES void tiltedNormals(int n, const Eigen::Vector3f& normal,
                                       const Eigen::Vector3f& tu, const Eigen::Vector3f& tv,
                                       const float* __restrict t0, const float* __restrict t1,
                                       float* __restrict nx, float* __restrict ny,
                                       float* __restrict nz) {
  const float n0 = normal.x(), n1 = normal.y(), n2 = normal.z();
  const float u0 = tu.x(), u1 = tu.y(), u2 = tu.z(), v0 = tv.x(), v1 = tv.y(), v2 = tv.z();
  for (int j = 0; j < n; ++j) {
    nx[j] = n0 + (t0[j] * u0 + t1[j] * v0);
    ny[j] = n1 + (t0[j] * u1 + t1[j] * v1);
    nz[j] = n2 + (t0[j] * u2 + t1[j] * v2);
  }
}

// Solar-cell interconnects: the albedo boost of n pixels of a flat triangle.
CDFF_SHADING_CLONES void solarCellBoost(int n, int x_first, float fy, const float* __restrict z,
                                        const PixelAffine& pu, const PixelAffine& pv,
                                        float strength, float* __restrict boost) {
  const float ux = pu.kx, uy = pu.ky, u0 = pu.k0, uc = pu.c;
  const float vx = pv.kx, vy = pv.ky, v0 = pv.k0, vc = pv.c;
  for (int j = 0; j < n; ++j) {
    const float fx = static_cast<float>(x_first + j);
    const float cu = z[j] * (ux * fx + uy * fy + u0) + uc;
    const float cv = z[j] * (vx * fx + vy * fy + v0) + vc;
    boost[j] = (fraction(cu) < kSolarCellGap) | (fraction(cv) < kSolarCellGap) ? strength : 0.0f;
  }
}

// Fraction of the 2x2 texel neighbourhood (bilinear weights) that sees the sun, for n points
// in shadow-map coordinates (texel x, texel y, biased depth). The map has a border of
// kShadowBorder texels at infinity on each side (stride size + 2 kShadowBorder, `map` at
// texel (0, 0)), so that points at or beyond the edge need no test: outside is lit.
constexpr int kShadowBorder = 2;
CDFF_SHADING_CLONES void shadowFactors(int n, const float* __restrict sx,
                                       const float* __restrict sy, const float* __restrict sz,
                                       const float* __restrict map, int size, int* __restrict index,
                                       float* __restrict wx, float* __restrict wy,
                                       float* __restrict t00, float* __restrict t10,
                                       float* __restrict t01, float* __restrict t11,
                                       float* __restrict factor) {
  const int stride = size + 2 * kShadowBorder;
  // Clamped first: far outside the map is outside (lit), and the conversion stays defined.
  const float lo = -2.0f, hi = static_cast<float>(size + 1);
  for (int j = 0; j < n; ++j) {
    const float tx = std::min(std::max(sx[j], lo), hi);
    const float ty = std::min(std::max(sy[j], lo), hi);
    const int ix = floorToInt(tx), iy = floorToInt(ty);
    wx[j] = tx - static_cast<float>(ix);
    wy[j] = ty - static_cast<float>(iy);
    index[j] = iy * stride + ix;
  }
  for (int j = 0; j < n; ++j) {
    const float* t = map + index[j];
    t00[j] = t[0];
    t10[j] = t[1];
    t01[j] = t[stride];
    t11[j] = t[stride + 1];
  }
  for (int j = 0; j < n; ++j) {
    const float depth = sz[j];
    const float l00 = depth <= t00[j] ? 1.0f : 0.0f, l10 = depth <= t10[j] ? 1.0f : 0.0f;
    const float l01 = depth <= t01[j] ? 1.0f : 0.0f, l11 = depth <= t11[j] ? 1.0f : 0.0f;
    const float x = wx[j], y = wy[j];
    factor[j] = (1 - y) * ((1 - x) * l00 + x * l10) + y * ((1 - x) * l01 + x * l11);
  }
}

// The radiance of n pixels of one material: Lambert plus the specular lobe, times the sun's
// irradiance and the shadow factor; 0 where the sun is below the surface (ndl <= 0, which
// includes the pixels the set-up left unlit with N = 0).
CDFF_SHADING_CLONES void radianceSpan(int n, const ShadeMaterial& mat, float E,
                                      const float* __restrict ndl, const float* __restrict ndh,
                                      const float* __restrict shadow, const float* __restrict boost,
                                      int* __restrict index, float* __restrict frac,
                                      float* __restrict l0, float* __restrict l1,
                                      float* __restrict red, float* __restrict green,
                                      float* __restrict blue, float* __restrict rad) {
  const float cutoff = mat.lobe_cutoff, step = mat.lobe_step;
  const float top = static_cast<float>(kLobeSamples);
  for (int j = 0; j < n; ++j) {
    const float h = ndh[j], u = select(mask(0.0f < h), h, 0.0f);  // std::max(0, h)
    const float v = (u - cutoff) * step;
    const float w = select(mask(v < 0.0f), 0.0f, v);  // std::clamp(v, 0, top)
    const float t = select(mask(top < w), top, w);
    const int i = static_cast<int>(t);
    index[j] = i;
    frac[j] = t - static_cast<float>(i);
  }
  const float* lobe = mat.lobe.data();
  for (int j = 0; j < n; ++j) {
    l0[j] = lobe[index[j]];
    l1[j] = lobe[index[j] + 1];
  }
  const float d0 = mat.diffuse.x(), d1 = mat.diffuse.y(), d2 = mat.diffuse.z();
  const float s0 = mat.specular.x(), s1 = mat.specular.y(), s2 = mat.specular.z();
  for (int j = 0; j < n; ++j) {
    const float value = l0[j] + frac[j] * (l1[j] - l0[j]);
    const float h = ndh[j], u = select(mask(0.0f < h), h, 0.0f);
    const float lobe_value = select(mask(u > cutoff), value, 0.0f) * ndl[j];
    const float scale = E * shadow[j];
    const std::uint32_t on = mask(ndl[j] > 0);
    const float b = boost[j];
    red[j] = select(on, ((d0 + b) * ndl[j] + s0 * lobe_value) * scale, 0.0f);
    green[j] = select(on, ((d1 + b) * ndl[j] + s1 * lobe_value) * scale, 0.0f);
    blue[j] = select(on, ((d2 + b) * ndl[j] + s2 * lobe_value) * scale, 0.0f);
  }
  for (int j = 0; j < n; ++j) {  // interleaved stores do not vectorise: a loop of its own
    rad[3 * j] = red[j];
    rad[3 * j + 1] = green[j];
    rad[3 * j + 2] = blue[j];
  }
}

// The constants of a smooth triangle for stage 1 (see smoothSpan): its normal (and the
// pattern's projection) varies over the triangle, and so does the side the camera sees.
struct SmoothTriangle {
  PixelAffine beta, gamma;
  Eigen::Vector3f n[3], p[3];       // vertex normals and positions, body frame
  Eigen::Matrix3f R;                // camera <- body
  Eigen::Vector3f L;                // towards the sun
  Eigen::Vector3f ray_dx, ray_row;  // the shadow-map ray (ShadowLookup) at this row
  bool shadows = false;
  Eigen::Matrix3f S;  // to shadow-map coordinates
  Eigen::Vector3f s0;
  float normal_offset = 0;
  SurfacePattern pattern = SurfacePattern::kNone;
  float frequency = 0, strength = 0;
};

// Stage 1 of n pixels of a smooth triangle, from column x_first: the same operations, in the
// same order, as the scalar code they replace, in loops without branches.
CDFF_SHADING_CLONES void smoothSpan(
    int n, int x_first, float fy, const SmoothTriangle& t, const float* __restrict z,
    const float* __restrict vx, const float* __restrict vy, const float* __restrict vz,
    const std::uint8_t* __restrict cells, const float* __restrict tilts, float* __restrict onx,
    float* __restrict ony, float* __restrict onz, float* __restrict px, float* __restrict py,
    float* __restrict pz, float* __restrict t0, float* __restrict t1, int* __restrict texel,
    int* __restrict axis0, int* __restrict axis2, float* __restrict nx, float* __restrict ny,
    float* __restrict nz, float* __restrict boost, float* __restrict sx, float* __restrict sy,
    float* __restrict sz) {
  const float bkx = t.beta.kx, bky = t.beta.ky, bk0 = t.beta.k0, bc = t.beta.c;
  const float gkx = t.gamma.kx, gky = t.gamma.ky, gk0 = t.gamma.k0, gc = t.gamma.c;
  const float n00 = t.n[0].x(), n01 = t.n[0].y(), n02 = t.n[0].z();
  const float n10 = t.n[1].x(), n11 = t.n[1].y(), n12 = t.n[1].z();
  const float n20 = t.n[2].x(), n21 = t.n[2].y(), n22 = t.n[2].z();
  const float p00 = t.p[0].x(), p01 = t.p[0].y(), p02 = t.p[0].z();
  const float p10 = t.p[1].x(), p11 = t.p[1].y(), p12 = t.p[1].z();
  const float p20 = t.p[2].x(), p21 = t.p[2].y(), p22 = t.p[2].z();
  // The body-frame normal (unit) and point.
  for (int j = 0; j < n; ++j) {
    const float fx = static_cast<float>(x_first + j);
    const float beta = z[j] * (bkx * fx + bky * fy + bk0) + bc;
    const float gamma = z[j] * (gkx * fx + gky * fy + gk0) + gc;
    const float alpha = 1.0f - beta - gamma;
    const float a = alpha * n00 + beta * n10 + gamma * n20;
    const float b = alpha * n01 + beta * n11 + gamma * n21;
    const float c = alpha * n02 + beta * n12 + gamma * n22;
    const float inv = 1.0f / std::sqrt(a * a + b * b + c * c);
    onx[j] = a * inv;
    ony[j] = b * inv;
    onz[j] = c * inv;
    px[j] = alpha * p00 + beta * p10 + gamma * p20;
    py[j] = alpha * p01 + beta * p11 + gamma * p21;
    pz[j] = alpha * p02 + beta * p12 + gamma * p22;
  }
  const bool crinkle = t.pattern == SurfacePattern::kCrinkle;
  if (t.pattern != SurfacePattern::kNone) {
    // Triplanar projection on the plane of the normal's two smaller components: (y, z) when
    // x is the largest, (x, y) when z is, (x, z) otherwise.
    const float frequency = t.frequency, strength = t.strength;
    for (int j = 0; j < n; ++j) {
      const float ax = std::abs(onx[j]), ay = std::abs(ony[j]), az = std::abs(onz[j]);
      const bool x_axis = (ax >= ay) & (ax >= az);
      const bool z_axis = !x_axis & !(ay >= az);
      axis0[j] = x_axis;
      axis2[j] = z_axis;
      const float cu = select(mask(x_axis), py[j], px[j]) * frequency;
      const float cv = select(mask(z_axis), py[j], pz[j]) * frequency;
      texel[j] = (floorToInt(cv) & (kCrinkleSize - 1)) * kCrinkleSize +
                 (floorToInt(cu) & (kCrinkleSize - 1));
      const bool gap = (fraction(cu) < kSolarCellGap) | (fraction(cv) < kSolarCellGap);
      boost[j] = gap && !crinkle ? strength : 0.0f;
    }
    if (crinkle) {
      for (int j = 0; j < n; ++j) {
        const float* tilt = tilts + 2 * cells[texel[j]];
        t0[j] = tilt[0];
        t1[j] = tilt[1];
      }
    }
  } else {
    for (int j = 0; j < n; ++j) boost[j] = 0.0f;
  }
  if (!crinkle) {
    for (int j = 0; j < n; ++j) {
      t0[j] = t1[j] = 0.0f;
      axis0[j] = axis2[j] = 0;
    }
  }
  const float r00 = t.R(0, 0), r01 = t.R(0, 1), r02 = t.R(0, 2);
  const float r10 = t.R(1, 0), r11 = t.R(1, 1), r12 = t.R(1, 2);
  const float r20 = t.R(2, 0), r21 = t.R(2, 1), r22 = t.R(2, 2);
  const float s00 = t.S(0, 0), s01 = t.S(0, 1), s02 = t.S(0, 2);
  const float s10 = t.S(1, 0), s11 = t.S(1, 1), s12 = t.S(1, 2);
  const float s20 = t.S(2, 0), s21 = t.S(2, 1), s22 = t.S(2, 2);
  const float o0 = t.s0.x(), o1 = t.s0.y(), o2 = t.s0.z();
  const float lx = t.L.x(), ly = t.L.y(), lz = t.L.z();
  const float dx0 = t.ray_dx.x(), dx1 = t.ray_dx.y(), dx2 = t.ray_dx.z();
  const float w0 = t.ray_row.x(), w1 = t.ray_row.y(), w2 = t.ray_row.z();
  const float offset = t.normal_offset, strength = t.strength;
  const std::uint32_t tilted = mask(crinkle), shadows = mask(t.shadows);
  for (int j = 0; j < n; ++j) {
    const float a = onx[j], b = ony[j], c = onz[j];
    // The crinkle facet tilts the shading normal's two in-plane components.
    const std::uint32_t first_is_y = mask(axis0[j] != 0), second_is_y = mask(axis2[j] != 0);
    const float ta = select(first_is_y, a, a + strength * t0[j]);
    const float tb =
        select(first_is_y, b + strength * t0[j], select(second_is_y, b + strength * t1[j], b));
    const float tc = select(second_is_y, c, c + strength * t1[j]);
    float gx = r00 * a + r01 * b + r02 * c;
    float gy = r10 * a + r11 * b + r12 * c;
    float gz = r20 * a + r21 * b + r22 * c;
    float sx_ = select(tilted, r00 * ta + r01 * tb + r02 * tc, gx);
    float sy_ = select(tilted, r10 * ta + r11 * tb + r12 * tc, gy);
    float sz_ = select(tilted, r20 * ta + r21 * tb + r22 * tc, gz);
    const std::uint32_t back = mask(gx * vx[j] + gy * vy[j] + gz * vz[j] < 0);  // two-sided
    gx = select(back, -gx, gx);
    gy = select(back, -gy, gy);
    gz = select(back, -gz, gz);
    sx_ = select(back, -sx_, sx_);
    sy_ = select(back, -sy_, sy_);
    sz_ = select(back, -sz_, sz_);
    const std::uint32_t sunlit = mask(gx * lx + gy * ly + gz * lz > 0);
    nx[j] = select(sunlit, sx_, 0.0f);
    ny[j] = select(sunlit, sy_, 0.0f);
    nz[j] = select(sunlit, sz_, 0.0f);
    const float fx = static_cast<float>(x_first + j);
    const float qx = offset * gx, qy = offset * gy, qz = offset * gz;
    const float ex = select(shadows, (s00 * qx + s01 * qy + s02 * qz) + o0, 0.0f);
    const float ey = select(shadows, (s10 * qx + s11 * qy + s12 * qz) + o1, 0.0f);
    const float ez = select(shadows, (s20 * qx + s21 * qy + s22 * qz) + o2, 0.0f);
    sx[j] = select(sunlit, z[j] * (dx0 * fx + w0) + ex, 0.0f);
    sy[j] = select(sunlit, z[j] * (dx1 * fx + w1) + ey, 0.0f);
    sz[j] = select(sunlit, z[j] * (dx2 * fx + w2) + ez, 0.0f);
  }
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
    const double ifx = 1.0 / cam.fx, ify = 1.0 / cam.fy;
    // f = g . P + c on the triangle's plane, with P = z (ifx (x - cx), ify (y - cy), 1).
    auto affine = [&](const Eigen::Vector3d& g, double c) {
      PixelAffine a;
      a.kx = static_cast<float>(g.x() * ifx);
      a.ky = static_cast<float>(g.y() * ify);
      a.k0 = static_cast<float>(g.z() - g.x() * ifx * cam.cx - g.y() * ify * cam.cy);
      a.c = static_cast<float>(c);
      return a;
    };
    // Shadow-map coordinates: texel x, y and the biased depth, of camera-frame points.
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    Eigen::Vector3d s0 = Eigen::Vector3d::Zero();
    double normal_offset = 0;
    if (shadow_frame_.valid) {
      const ShadowFrame& sf = shadow_frame_;
      S = sf.sun_T_camera.linear();
      S.row(0) *= sf.scale;
      S.row(1) *= sf.scale;
      s0 = sf.sun_T_camera.translation();
      s0.x() = s0.x() * sf.scale + sf.offset;
      s0.y() = s0.y() * sf.scale + sf.offset;
      s0.z() -= kShadowBiasTexels * sf.texel;
      normal_offset = kShadowNormalOffsetTexels * sf.texel;
      shadow_ray_.dx = (S.col(0) * ifx).cast<float>();
      shadow_ray_.dy = (S.col(1) * ify).cast<float>();
      shadow_ray_.d0 = (S.col(2) - S.col(0) * ifx * cam.cx - S.col(1) * ify * cam.cy).cast<float>();
    }
    sun_S_camera_ = S.cast<float>();
    sun_s0_ = s0.cast<float>();
    shadow_normal_offset_ = static_cast<float>(normal_offset);

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
      const auto& fv = frame_vertices_[o];
      FrameTriangle* out = frame_triangles_.data() + triangle_base_[o];
      for (std::size_t k = 0; k < m.triangles.size(); ++k) {
        const auto& tri = m.triangles[k];
        FrameTriangle& f = out[k];
        f = FrameTriangle{};
        f.material = m.material[k];
        f.flat = m.flat[k];
        const Eigen::Vector3d a = fv[tri[0]].cast<double>();
        const Eigen::Vector3d e1 = fv[tri[1]].cast<double>() - a;
        const Eigen::Vector3d e2 = fv[tri[2]].cast<double>() - a;
        const double d00 = e1.dot(e1), d01 = e1.dot(e2), d11 = e2.dot(e2);
        const double denom = d00 * d11 - d01 * d01;
        if (!(denom > 0)) continue;  // degenerate: covers no pixel centre
        // In-plane gradients of the barycentric coordinates of vertices 1 and 2.
        const Eigen::Vector3d gb = (d11 * e1 - d01 * e2) / denom;
        const Eigen::Vector3d gg = (d00 * e2 - d01 * e1) / denom;
        f.beta = affine(gb, -gb.dot(a));
        f.gamma = affine(gg, -gg.dot(a));
        if (!f.flat) continue;
        const Eigen::Vector3f& n_o = m.face_normal[k];
        Eigen::Vector3d n = R * n_o.cast<double>();
        // Two-sided surfaces: seen from behind when the camera is on the back of the plane.
        const double side = n.dot(a) > 0 ? -1.0 : 1.0;
        n *= side;
        f.normal = n.cast<float>();
        f.ndl = static_cast<float>(n.dot(L));
        if (shadow_frame_.valid) f.shadow = (S * (normal_offset * n) + s0).cast<float>();
        const ShadeMaterial& mat = m.materials[f.material];
        if (mat.pattern == SurfacePattern::kNone) continue;
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

  void shade(const RenderScene& scene, const PinholeCamera& cam, RenderOutput& out) {
    const int W = cam.width, H = cam.height;
    const float inf = std::numeric_limits<float>::infinity();
    const Eigen::Vector3f L = scene.sun_direction.normalized().cast<float>();
    const float E = static_cast<float>(scene.sun_irradiance);
    const bool lit = E > 0;
    const bool shadows = shadow_frame_.valid;
    const std::uint8_t* crinkle_cells = crinkleCells().data();
    const float* crinkle_tilts = crinkleTilts().data();
    const float* shadow_map = shadows ? shadowTexel(0, 0) : nullptr;
    const float ify = static_cast<float>(1.0 / cam.fy);
    const float cx = static_cast<float>(cam.cx), cy = static_cast<float>(cam.cy);
    const float ifx = static_cast<float>(1.0 / cam.fx);
    std::vector<Eigen::Matrix3f> rotations;
    for (const RenderObject& o : scene.objects)
      rotations.push_back(o.camera_T_object.linear().cast<float>());
    float* rad = out.radiance.data();
    float* depth = out.depth.data();
    std::uint8_t* ids = out.id.data();
    float* ibuf = inv_depth_.data();
    std::uint32_t* vis = vis_.data();
    const FrameTriangle* triangles = frame_triangles_.data();
    // Outside the dirty box nothing was drawn: clear the outputs there in one go.
    const bool any = dirty_.x0 <= dirty_.x1 && dirty_.y0 <= dirty_.y1;
    auto clear = [&](std::size_t from, std::size_t to) {
      if (from >= to) return;
      std::fill(rad + 3 * from, rad + 3 * to, 0.0f);
      std::fill(depth + from, depth + to, inf);
      std::memset(ids + from, 0, to - from);
    };
    const int x0 = dirty_.x0;
    const int n = any ? dirty_.x1 - dirty_.x0 + 1 : 0;
    row_.resize(kShadeChunk);
    column_rx_.resize(static_cast<std::size_t>(std::max(n, 0)));
    for (int j = 0; j < n; ++j) column_rx_[j] = (static_cast<float>(x0 + j) - cx) * ifx;
    RowBuffers& b = row_;
    for (int y = 0; y < H; ++y) {
      const std::size_t row = static_cast<std::size_t>(y) * W;
      const bool row_dirty = any && y >= dirty_.y0 && y <= dirty_.y1;
      if (!row_dirty) {
        clear(row, row + W);
        continue;
      }
      clear(row, row + dirty_.x0);
      clear(row + dirty_.x1 + 1, row + W);
      const float fy = static_cast<float>(y);
      const float ry = (fy - cy) * ify;
      const Eigen::Vector3f shadow_row = shadow_ray_.dy * fy + shadow_ray_.d0;
      for (int c0 = 0; c0 < n; c0 += kShadeChunk) {
        const int cn = std::min(kShadeChunk, n - c0), xs = x0 + c0;
        const std::size_t i0 = row + xs;
        // Stage 0. (Where nothing was drawn the inverse depth is 0: z = inf, unused.)
        viewAndHalfVectors(cn, ibuf + i0, column_rx_.data() + c0, ry, L, b.z.data(), b.vx.data(),
                           b.vy.data(), b.vz.data(), b.hx.data(), b.hy.data(), b.hz.data());
        // The runs of equal visibility-buffer entries; the buffer is reset as it is read.
        int run_count = 0;
        for (int j = 0; j < cn;) {
          const std::uint32_t code = vis[i0 + j];
          int e = j + 1;
          while (e < cn && vis[i0 + e] == code) ++e;
          b.runs[run_count++] = {j, e, code, nullptr};
          j = e;
        }
        std::fill(vis + i0, vis + i0 + cn, kNoSurface);
        std::fill(ibuf + i0, ibuf + i0 + cn, 0.0f);
        // Stage 1.
        for (int r = 0; r < run_count; ++r) {
          const auto [first, last, code, material] = b.runs[r];
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
            std::fill(depth + i0 + first, depth + i0 + last, inf);
            std::memset(ids + i0 + first, 0, static_cast<std::size_t>(len));
            unlit();
            continue;
          }
          const std::size_t o = code >> 24, k = code & 0xffffffu;
          std::copy(z, z + len, depth + i0 + first);
          std::memset(ids + i0 + first, scene.objects[o].id, static_cast<std::size_t>(len));
          const FrameTriangle& f = triangles[triangle_base_[o] + k];
          const ModelData& m = models_[scene.objects[o].model];
          const ShadeMaterial& mat = m.materials[f.material];
          b.runs[r].material = &mat;
          if (!lit || (f.flat && !(f.ndl > 0))) {
            unlit();
            continue;
          }
          if (!f.flat) {
            const auto& tri = m.triangles[k];
            SmoothTriangle t;
            t.beta = f.beta;
            t.gamma = f.gamma;
            for (int v = 0; v < 3; ++v) {
              t.n[v] = m.normals[tri[v]];
              t.p[v] = m.vertices[tri[v]];
            }
            t.R = rotations[o];
            t.L = L;
            t.ray_dx = shadow_ray_.dx;
            t.ray_row = shadow_row;
            t.shadows = shadows;
            t.S = sun_S_camera_;
            t.s0 = sun_s0_;
            t.normal_offset = shadow_normal_offset_;
            t.pattern = mat.pattern;
            t.frequency = mat.pattern_frequency;
            t.strength = mat.pattern_strength;
            smoothSpan(len, xs + first, fy, t, z, b.vx.data() + first, b.vy.data() + first,
                       b.vz.data() + first, crinkle_cells, crinkle_tilts, b.f0.data(), b.f1.data(),
                       b.f2.data(), b.f3.data(), b.f4.data(), b.f5.data(), b.f6.data(), b.f7.data(),
                       b.index.data(), b.index2.data(), b.index3.data(), nx, ny, nz, boost, sx, sy,
                       sz);
            continue;
          }
          const int x_first = xs + first;
          if (mat.pattern == SurfacePattern::kCrinkle) {
            crinkleTexels(len, x_first, fy, z, f.pattern_u, f.pattern_v, b.index.data());
            facetTilts(len, b.index.data(), crinkle_cells, crinkle_tilts, b.f0.data(), b.f1.data());
            tiltedNormals(len, f.normal, f.tilt_u, f.tilt_v, b.f0.data(), b.f1.data(), nx, ny, nz);
          } else {
            fillSpan(len, f.normal.x(), nx);
            fillSpan(len, f.normal.y(), ny);
            fillSpan(len, f.normal.z(), nz);
          }
          if (mat.pattern == SurfacePattern::kSolarCell)
            solarCellBoost(len, x_first, fy, z, f.pattern_u, f.pattern_v, mat.pattern_strength,
                           boost);
          else
            fillSpan(len, 0.0f, boost);
          shadowPoints(len, x_first, z, shadow_ray_.dx, shadow_row, f.shadow, sx, sy, sz);
        }
        // Stage 2.
        normalDotProducts(cn, b.nx.data(), b.ny.data(), b.nz.data(), b.hx.data(), b.hy.data(),
                          b.hz.data(), L, b.ndl.data(), b.ndh.data());
        if (shadows)
          shadowFactors(cn, b.sx.data(), b.sy.data(), b.sz.data(), shadow_map, shadow_frame_.size,
                        b.index.data(), b.f0.data(), b.f1.data(), b.f2.data(), b.f3.data(),
                        b.f4.data(), b.f5.data(), b.shadow.data());
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
          float* c = rad + 3 * (i0 + first);
          if (mat == nullptr) {
            std::fill(c, c + 3 * (last - first), 0.0f);
            continue;
          }
          radianceSpan(last - first, *mat, E, b.ndl.data() + first, b.ndh.data() + first,
                       b.shadow.data() + first, b.albedo_boost.data() + first, b.index.data(),
                       b.f0.data(), b.f1.data(), b.f2.data(), b.f3.data(), b.f4.data(), b.f5.data(),
                       c);
        }
      }
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

std::unique_ptr<Renderer> createCpuRenderer() {
  return std::make_unique<CpuRenderer>();
}

}  // namespace cdff::egse
