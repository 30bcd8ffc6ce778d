#pragma once
// Rendering of the spacecraft seen by a pinhole camera: linear radiance and depth.
//
// Two backends draw the same geometry with the same shading model:
//   - "opengl": OpenGL 3.3 core on an EGL surfaceless context (Mesa llvmpipe on a machine without
//     a GPU; no X server), offscreen framebuffer, read back to memory;
//   - "cpu": a small deterministic rasteriser (visibility buffer, then one shading pass).
// Projection follows cdff::CameraModel exactly: pixel (0, 0) is the centre of the top-left pixel,
// u = fx x / z + cx, v = fy y / z + cy in the optical frame (z forward, x right, y down); a pixel
// is covered when its centre is inside a triangle (top-left rule). Lens distortion, background,
// exposure and noise are applied afterwards by the camera model (camera_sensor.hpp), identically
// for both backends.
//
// Shading (docs/simulator.md): one directional sun, no ambient light; Lambert diffuse plus a
// normalised Blinn-Phong specular lobe; hard shadows from a sun-aligned orthographic shadow map
// (2x2 percentage-closer filter); procedural MLI crinkle (Voronoi facets tilting the normal) and
// solar-cell grids. Radiance is a reflectance factor: a white Lambertian plate facing the sun at
// 1 AU renders as 1.0.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/egse/model.hpp"
#include "cdff/types/status.hpp"

namespace cdff::egse {

struct PinholeCamera {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels
  double near_plane = 0.05;               // m
  double far_plane = 5000.0;              // m
};

struct RenderObject {
  int model = -1;                                                     // from Renderer::addModel
  Eigen::Isometry3d camera_T_object = Eigen::Isometry3d::Identity();  // optical frame <- body
  std::uint8_t id = 1;  // written to the id buffer (> 0)
  bool casts_shadow = true;
};

struct RenderScene {
  std::vector<RenderObject> objects;
  Eigen::Vector3d sun_direction = Eigen::Vector3d::UnitZ();  // unit, towards the sun, camera frame
  double sun_irradiance = 1.0;                               // 0 in eclipse
  bool shadows = true;
  int shadow_map_size = 1024;  // texels per side
};

/// Radiance (3 floats per pixel, linear RGB), depth (m along the optical axis; +inf where no
/// surface) and object id (0 where no surface), row-major from the top-left pixel.
struct RenderOutput {
  int width = 0, height = 0;
  std::vector<float> radiance;
  std::vector<float> depth;
  std::vector<std::uint8_t> id;
  void resize(int w, int h);
};

enum class RendererBackend { kAuto, kOpenGl, kCpu };
const char* toString(RendererBackend backend);

class Renderer {
 public:
  virtual ~Renderer() = default;
  /// "opengl" or "cpu".
  virtual RendererBackend backend() const = 0;
  /// What ran, for logs and recordings, e.g. "opengl: Mesa llvmpipe (LLVM 15.0.6, 256 bits), 4.5".
  virtual std::string description() const = 0;
  /// Uploads a model once; returns the handle RenderObject::model refers to.
  virtual Result<int> addModel(const TargetModel& model) = 0;
  virtual Status render(const RenderScene& scene, const PinholeCamera& camera,
                        RenderOutput& out) = 0;
};

/// The CPU rasteriser (always available).
std::unique_ptr<Renderer> createCpuRenderer();
/// The OpenGL renderer on an EGL surfaceless context; fails with a message when EGL or OpenGL
/// 3.3 is not available.
Result<std::unique_ptr<Renderer>> createOpenGlRenderer();
/// kAuto tries OpenGL first and falls back to the CPU rasteriser, logging which one runs and
/// why (the caller also records description() in its output).
Result<std::unique_ptr<Renderer>> createRenderer(RendererBackend backend);

// --- Shading model shared by both backends (render_shading.cpp) ---------------------------

/// The MLI crinkle texture: a Voronoi pattern of kCrinkleCells cells on a tileable square of
/// kCrinkleSize^2 texels (fixed seed). Each texel holds its cell's index (one byte, so that the
/// texture stays in cache); each cell has a facet tilt (2 floats, unit variance).
constexpr int kCrinkleSize = 256;
constexpr int kCrinkleCells = 256;
const std::vector<std::uint8_t>& crinkleCells();
const std::vector<float>& crinkleTilts();
/// One crinkle tile spans this many facet sizes (Material::pattern_scale).
constexpr float kCrinkleTileFacets = 16.0f;
/// Interconnect width of a solar cell grid, as a fraction of the cell pitch.
constexpr float kSolarCellGap = 0.06f;
/// Shadow-map bias in texels (constant) and along the normal (normal offset).
constexpr float kShadowBiasTexels = 1.5f;
constexpr float kShadowNormalOffsetTexels = 1.5f;

/// The orthographic sun view used for shadows: sun_T_camera maps camera-frame points to the sun
/// frame (z along the light, away from the sun); texel = (x, y) * scale + offset.
struct ShadowFrame {
  Eigen::Isometry3d sun_T_camera = Eigen::Isometry3d::Identity();
  double scale = 1.0;  // texels per metre
  double offset = 0.0;
  double texel = 1.0;  // metres per texel
  int size = 0;
  bool valid = false;
};
/// Fits the shadow map around the shadow-casting objects' bounding spheres (given in the camera
/// frame) that lie within `reach` metres of the first one.
ShadowFrame fitShadowFrame(const Eigen::Vector3d& sun_direction,
                           const std::vector<std::pair<Eigen::Vector3d, double>>& casters, int size,
                           double reach = 30.0);

}  // namespace cdff::egse
