// What both renderers share: the crinkle texture, the shadow-map fit, backend selection.
#include <cmath>
#include <limits>

#include <spdlog/spdlog.h>

#include "cdff/egse/render.hpp"
#include "cdff/egse/rng.hpp"

namespace cdff::egse {

void RenderOutput::resize(int w, int h) {
  width = w;
  height = h;
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  radiance.assign(3 * n, 0.0f);
  depth.assign(n, std::numeric_limits<float>::infinity());
  id.assign(n, 0);
}

const char* toString(RendererBackend backend) {
  switch (backend) {
    case RendererBackend::kAuto:
      return "auto";
    case RendererBackend::kOpenGl:
      return "opengl";
    case RendererBackend::kCpu:
      return "cpu";
  }
  return "?";
}

namespace {

struct Crinkle {
  std::vector<std::uint8_t> cells;
  std::vector<float> tilts;
  Crinkle() {
    // Voronoi cells on a torus: each cell is a flat facet of the wrinkled foil with its own tilt.
    Rng rng(0x4d4c49ULL);  // fixed: the pattern is part of the model, not of a run
    std::vector<Eigen::Vector2d> seeds(kCrinkleCells);
    tilts.resize(2 * kCrinkleCells);
    for (int i = 0; i < kCrinkleCells; ++i) {
      seeds[i] = {rng.uniform(), rng.uniform()};
      tilts[2 * i] = static_cast<float>(rng.normal());
      tilts[2 * i + 1] = static_cast<float>(rng.normal());
    }
    cells.resize(kCrinkleSize * kCrinkleSize);
    for (int y = 0; y < kCrinkleSize; ++y)
      for (int x = 0; x < kCrinkleSize; ++x) {
        const Eigen::Vector2d p((x + 0.5) / kCrinkleSize, (y + 0.5) / kCrinkleSize);
        int best = 0;
        double best_d = 1e9;
        for (int i = 0; i < kCrinkleCells; ++i) {
          Eigen::Vector2d d = (p - seeds[i]).cwiseAbs();
          d = d.cwiseMin(Eigen::Vector2d::Ones() - d);  // wrap around
          const double dd = d.squaredNorm();
          if (dd < best_d) {
            best_d = dd;
            best = i;
          }
        }
        cells[y * kCrinkleSize + x] = static_cast<std::uint8_t>(best);
      }
  }
};

const Crinkle& crinkle() {
  static const Crinkle c;
  return c;
}

}  // namespace

const std::vector<std::uint8_t>& crinkleCells() {
  return crinkle().cells;
}
const std::vector<float>& crinkleTilts() {
  return crinkle().tilts;
}

ShadowFrame fitShadowFrame(const Eigen::Vector3d& sun_direction,
                           const std::vector<std::pair<Eigen::Vector3d, double>>& casters, int size,
                           double reach) {
  ShadowFrame f;
  if (casters.empty() || size < 2 || sun_direction.norm() < 1e-12) return f;
  const Eigen::Vector3d z = -sun_direction.normalized();  // along the light
  const Eigen::Vector3d helper =
      std::abs(z.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d x = helper.cross(z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  const Eigen::Vector3d c = casters.front().first;
  double radius = casters.front().second;
  for (const auto& [centre, r] : casters)
    if ((centre - c).norm() <= reach) radius = std::max(radius, (centre - c).norm() + r);
  Eigen::Matrix3d R;
  R.row(0) = x;
  R.row(1) = y;
  R.row(2) = z;
  f.sun_T_camera.linear() = R;
  f.sun_T_camera.translation() = -R * c;
  f.size = size;
  f.scale = (size - 1) / (2.0 * radius * 1.02);
  f.offset = 0.5 * (size - 1);
  f.texel = 1.0 / f.scale;
  f.valid = true;
  return f;
}

Result<std::unique_ptr<Renderer>> createRenderer(RendererBackend backend) {
  if (backend == RendererBackend::kCpu) return createCpuRenderer();
  auto gl = createOpenGlRenderer();
  if (gl || backend == RendererBackend::kOpenGl) {
    if (gl) spdlog::info("renderer: {}", gl.value()->description());
    return gl;
  }
  spdlog::warn("renderer: OpenGL is not available ({}); using the CPU rasteriser",
               gl.status().message());
  return createCpuRenderer();
}

}  // namespace cdff::egse
