// The CPU rasteriser's shading stages (see raster_kernels.hpp).
#include "cdff/egse/raster_kernels.hpp"

#include <algorithm>
#include <cmath>

namespace cdff::egse::raster {

// The shading loops are also compiled for AVX2 (8 floats a vector), chosen at run time where
// the CPU has it; the baseline (SSE2) version runs everywhere else. Both do the same IEEE
// operations (AVX2 does not bring FMA, so nothing is contracted): the same bits either way.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define CDFF_SHADING_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define CDFF_SHADING_CLONES
#endif
// The steps of a cloned stage, compiled into each of its clones (as one function).
#define CDFF_SHADING_STEP [[gnu::always_inline]] inline

namespace {

// Stage 1 of a smooth triangle, step 1: the body-frame normal (unit) and point of each pixel.
CDFF_SHADING_STEP void smoothNormalsAndPoints(int n, int x_first, float fy, const SmoothTriangle& t,
                                              const float* __restrict z, float* __restrict onx,
                                              float* __restrict ony, float* __restrict onz,
                                              float* __restrict px, float* __restrict py,
                                              float* __restrict pz) {
  const float bkx = t.beta.kx, bky = t.beta.ky, bk0 = t.beta.k0, bc = t.beta.c;
  const float gkx = t.gamma.kx, gky = t.gamma.ky, gk0 = t.gamma.k0, gc = t.gamma.c;
  const float n00 = t.n[0].x(), n01 = t.n[0].y(), n02 = t.n[0].z();
  const float n10 = t.n[1].x(), n11 = t.n[1].y(), n12 = t.n[1].z();
  const float n20 = t.n[2].x(), n21 = t.n[2].y(), n22 = t.n[2].z();
  const float p00 = t.p[0].x(), p01 = t.p[0].y(), p02 = t.p[0].z();
  const float p10 = t.p[1].x(), p11 = t.p[1].y(), p12 = t.p[1].z();
  const float p20 = t.p[2].x(), p21 = t.p[2].y(), p22 = t.p[2].z();
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
}

// Step 2: the surface pattern at each pixel: the crinkle facet's tilts (t0, t1) and the
// triplanar axes they tilt (axis0, axis2), or the solar-cell interconnects' albedo boost; zeros
// where the material has no such pattern.
CDFF_SHADING_STEP void smoothPattern(
    int n, const SmoothTriangle& t, const std::uint8_t* __restrict cells,
    const float* __restrict tilts, const float* __restrict onx, const float* __restrict ony,
    const float* __restrict onz, const float* __restrict px, const float* __restrict py,
    const float* __restrict pz, float* __restrict t0, float* __restrict t1, int* __restrict texel,
    int* __restrict axis0, int* __restrict axis2, float* __restrict boost) {
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
}

// Step 3: the shading normal in the camera frame (tilted by the crinkle facet, turned towards
// the camera, 0 where the sun is below the surface) and the shadow-map point of each pixel.
CDFF_SHADING_STEP void smoothShading(
    int n, int x_first, const SmoothTriangle& t, const float* __restrict z,
    const float* __restrict vx, const float* __restrict vy, const float* __restrict vz,
    const float* __restrict onx, const float* __restrict ony, const float* __restrict onz,
    const float* __restrict t0, const float* __restrict t1, const int* __restrict axis0,
    const int* __restrict axis2, float* __restrict nx, float* __restrict ny, float* __restrict nz,
    float* __restrict sx, float* __restrict sy, float* __restrict sz) {
  const bool crinkle = t.pattern == SurfacePattern::kCrinkle;
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

}  // namespace

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

CDFF_SHADING_CLONES void smoothSpan(
    int n, int x_first, float fy, const SmoothTriangle& t, const float* __restrict z,
    const float* __restrict vx, const float* __restrict vy, const float* __restrict vz,
    const std::uint8_t* __restrict cells, const float* __restrict tilts, float* __restrict onx,
    float* __restrict ony, float* __restrict onz, float* __restrict px, float* __restrict py,
    float* __restrict pz, float* __restrict t0, float* __restrict t1, int* __restrict texel,
    int* __restrict axis0, int* __restrict axis2, float* __restrict nx, float* __restrict ny,
    float* __restrict nz, float* __restrict boost, float* __restrict sx, float* __restrict sy,
    float* __restrict sz) {
  smoothNormalsAndPoints(n, x_first, fy, t, z, onx, ony, onz, px, py, pz);
  smoothPattern(n, t, cells, tilts, onx, ony, onz, px, py, pz, t0, t1, texel, axis0, axis2, boost);
  smoothShading(n, x_first, t, z, vx, vy, vz, onx, ony, onz, t0, t1, axis0, axis2, nx, ny, nz, sx,
                sy, sz);
}

}  // namespace cdff::egse::raster
