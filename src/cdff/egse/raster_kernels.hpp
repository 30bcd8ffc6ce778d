#pragma once
// The CPU rasteriser's shading stages (raster_renderer.cpp): plain loops over the arrays of a
// row's pixels, which GCC vectorises (sqrtps, divps: the same IEEE results as scalar code), and
// the per-material and per-triangle constants they take.
//
// Most stages work on runs of pixels of one row that show the same triangle: everything that
// depends on the triangle or its material is then a constant of the loop; the table look-ups
// (crinkle facets, shadow-map texels, specular lobe) are separate loops of loads between them.
// raster_kernels.cpp compiles the loops for AVX2 too, chosen at run time.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>

#include <Eigen/Core>

#include "cdff/egse/material.hpp"
#include "cdff/egse/render.hpp"

namespace cdff::egse::raster {

// Samples of the specular lobe between its cut-off and N.H = 1. Linear interpolation between
// them is within 3.6e-4 of the lobe's peak for any exponent, and within 1.5e-3 of pow() itself
// (relative) for exponents from 10 up: far below the 1 % the renderers agree to.
constexpr int kLobeSamples = 256;

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

// A quantity that is affine on a triangle in 3D, as a function of the pixel (x, y) and of the
// depth z there: f = z (kx x + ky y + k0) + c (P = z * ray(x, y) with an affine ray).
struct PixelAffine {
  float kx = 0, ky = 0, k0 = 0, c = 0;
  float at(float z, float x, float y) const { return z * (kx * x + ky * y + k0) + c; }
};

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

// Selects written as bit masks: GCC turns a conditional expression in a loop into a branch
// (jump threading runs before if-conversion), and a loop with a branch stays scalar.
inline std::uint32_t mask(bool condition) {
  return 0u - static_cast<std::uint32_t>(condition);
}
inline float select(std::uint32_t m, float if_set, float otherwise) {
  return std::bit_cast<float>((std::bit_cast<std::uint32_t>(if_set) & m) |
                              (std::bit_cast<std::uint32_t>(otherwise) & ~m));
}

inline void fillSpan(int n, float value, float* __restrict out) {
  for (int j = 0; j < n; ++j) out[j] = value;
}

// The shadow map's border, in texels at infinity on each side (see shadowFactors).
constexpr int kShadowBorder = 2;

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

// The depth test of pixels first..last of a row: inverse depth A x + row_c, nearer wins.
// Without branches: depth order is random.
void depthTestSpan(int first, int last, double A, double row_c, std::uint32_t code,
                   float* __restrict inv_depth, std::uint32_t* __restrict vis);

// Stage 0 over a row of n pixels: depth z, view vector V = -unit(P) and half vector
// H = unit(L + V), with the ray's x per pixel in rx and its y in ry.
void viewAndHalfVectors(int n, const float* __restrict inv_depth, const float* __restrict rx,
                        float ry, const Eigen::Vector3f& sun, float* __restrict z,
                        float* __restrict vx, float* __restrict vy, float* __restrict vz,
                        float* __restrict hx, float* __restrict hy, float* __restrict hz);

// Stage 2 over a row of n pixels: N.L and N.H with the normal N normalised (0 where N = 0).
void normalDotProducts(int n, const float* __restrict nx, const float* __restrict ny,
                       const float* __restrict nz, const float* __restrict hx,
                       const float* __restrict hy, const float* __restrict hz,
                       const Eigen::Vector3f& sun, float* __restrict ndl, float* __restrict ndh);

// Shadow-map points z * ray(x, y) + offset of n pixels from column x_first, with
// ray(x, y) = dx x + row (row = dy y + d0).
void shadowPoints(int n, int x_first, const float* __restrict z, const Eigen::Vector3f& dx,
                  const Eigen::Vector3f& row, const Eigen::Vector3f& offset, float* __restrict sx,
                  float* __restrict sy, float* __restrict sz);

// Crinkle texels (row-major index in the tile) of n pixels of a flat triangle.
void crinkleTexels(int n, int x_first, float fy, const float* __restrict z, const PixelAffine& pu,
                   const PixelAffine& pv, int* __restrict texel);

// The facet tilts of the texels (two loads per pixel, through the cell index).
void facetTilts(int n, const int* __restrict texel, const std::uint8_t* __restrict cells,
                const float* __restrict tilts, float* __restrict t0, float* __restrict t1);

// N = normal + t0 tilt_u + t1 tilt_v (not normalised).
void tiltedNormals(int n, const Eigen::Vector3f& normal, const Eigen::Vector3f& tu,
                   const Eigen::Vector3f& tv, const float* __restrict t0,
                   const float* __restrict t1, float* __restrict nx, float* __restrict ny,
                   float* __restrict nz);

// Solar-cell interconnects: the albedo boost of n pixels of a flat triangle.
void solarCellBoost(int n, int x_first, float fy, const float* __restrict z, const PixelAffine& pu,
                    const PixelAffine& pv, float strength, float* __restrict boost);

// Fraction of the 2x2 texel neighbourhood (bilinear weights) that sees the sun, for n points
// in shadow-map coordinates (texel x, texel y, biased depth). The map has a border of
// kShadowBorder texels at infinity on each side (stride size + 2 kShadowBorder, `map` at
// texel (0, 0)), so that points at or beyond the edge need no test: outside is lit.
void shadowFactors(int n, const float* __restrict sx, const float* __restrict sy,
                   const float* __restrict sz, const float* __restrict map, int size,
                   int* __restrict index, float* __restrict wx, float* __restrict wy,
                   float* __restrict t00, float* __restrict t10, float* __restrict t01,
                   float* __restrict t11, float* __restrict factor);

// The radiance of n pixels of one material: Lambert plus the specular lobe, times the sun's
// irradiance and the shadow factor; 0 where the sun is below the surface (ndl <= 0, which
// includes the pixels the set-up left unlit with N = 0).
void radianceSpan(int n, const ShadeMaterial& mat, float E, const float* __restrict ndl,
                  const float* __restrict ndh, const float* __restrict shadow,
                  const float* __restrict boost, int* __restrict index, float* __restrict frac,
                  float* __restrict l0, float* __restrict l1, float* __restrict red,
                  float* __restrict green, float* __restrict blue, float* __restrict rad);

// Stage 1 of n pixels of a smooth triangle, from column x_first: each pixel's normal, pattern,
// shading normal and shadow-map point, with every pixel's operations in a fixed order and no
// branches (selects as bit masks), so that GCC vectorises the loops and the result does not
// depend on the vector width. onx..axis2 are scratch arrays of n entries.
void smoothSpan(int n, int x_first, float fy, const SmoothTriangle& t, const float* __restrict z,
                const float* __restrict vx, const float* __restrict vy, const float* __restrict vz,
                const std::uint8_t* __restrict cells, const float* __restrict tilts,
                float* __restrict onx, float* __restrict ony, float* __restrict onz,
                float* __restrict px, float* __restrict py, float* __restrict pz,
                float* __restrict t0, float* __restrict t1, int* __restrict texel,
                int* __restrict axis0, int* __restrict axis2, float* __restrict nx,
                float* __restrict ny, float* __restrict nz, float* __restrict boost,
                float* __restrict sx, float* __restrict sy, float* __restrict sz);

}  // namespace cdff::egse::raster
