// The OpenGL renderer: OpenGL 3.3 core on an EGL surfaceless context (Mesa's llvmpipe where
// there is no GPU, no X server needed), drawing into an offscreen framebuffer that is read back.
// The shading model mirrors raster_renderer.cpp line by line (render.hpp documents it). The only
// translation unit that includes EGL and OpenGL headers.
#define GL_GLEXT_PROTOTYPES 1
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/glcorearb.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>

#include <fmt/format.h>

#include "cdff/egse/render.hpp"

namespace cdff::egse {

namespace {

constexpr int kMaxMaterials = 32;

const char* kSceneVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
uniform mat4 camera_T_object;
uniform mat4 projection;
out vec3 p_object;
out vec3 n_object;
out vec3 p_camera;
void main() {
  p_object = position;
  n_object = normal;
  vec4 pc = camera_T_object * vec4(position, 1.0);
  p_camera = pc.xyz;
  gl_Position = projection * pc;
}
)";

// Mirrors CpuRenderer::shade.
const char* kSceneFragmentShader = R"(#version 330 core
in vec3 p_object;
in vec3 n_object;
in vec3 p_camera;
layout(location = 0) out vec4 out_radiance_depth;
layout(location = 1) out uint out_id;
uniform mat3 camera_R_object;
uniform vec3 sun_direction;
uniform float irradiance;
uniform uint object_id;
uniform usamplerBuffer triangle_material;
uniform vec3 diffuse[32];
uniform vec3 specular[32];
uniform float shininess[32];
uniform int pattern[32];
uniform float pattern_strength[32];
uniform float pattern_scale[32];
uniform float specular_cutoff[32];
uniform usampler2D crinkle;
uniform vec2 crinkle_tilts[256];
uniform int crinkle_size;
uniform float crinkle_tile_facets;
uniform float solar_cell_gap;
uniform bool shadows;
uniform sampler2D shadow_map;
uniform mat4 sun_T_camera;
uniform float shadow_scale;
uniform float shadow_offset;
uniform float shadow_texel;
uniform int shadow_size;
uniform float shadow_depth_range;
uniform float shadow_bias_texels;
uniform float shadow_normal_offset_texels;

float lit(int x, int y, float depth) {
  if (x < 0 || y < 0 || x >= shadow_size || y >= shadow_size) return 1.0;
  float stored = (texelFetch(shadow_map, ivec2(x, y), 0).r * 2.0 - 1.0) * shadow_depth_range;
  return depth <= stored ? 1.0 : 0.0;
}

float shadowFactor(vec3 p) {
  vec3 s = (sun_T_camera * vec4(p, 1.0)).xyz;
  float tx = s.x * shadow_scale + shadow_offset, ty = s.y * shadow_scale + shadow_offset;
  float fx = floor(tx), fy = floor(ty);
  int ix = int(fx), iy = int(fy);
  float wx = tx - fx, wy = ty - fy;
  float depth = s.z - shadow_bias_texels * shadow_texel;
  return (1.0 - wy) * ((1.0 - wx) * lit(ix, iy, depth) + wx * lit(ix + 1, iy, depth)) +
         wy * ((1.0 - wx) * lit(ix, iy + 1, depth) + wx * lit(ix + 1, iy + 1, depth));
}

void main() {
  int m = int(texelFetch(triangle_material, gl_PrimitiveID).r);
  vec3 n_o = normalize(n_object);
  vec3 albedo = diffuse[m];
  vec3 shading_n_o = n_o;
  if (pattern[m] != 0) {
    vec3 an = abs(n_o);
    int axis = (an.x >= an.y && an.x >= an.z) ? 0 : (an.y >= an.z ? 1 : 2);
    int a1 = axis == 0 ? 1 : 0;
    int a2 = axis == 2 ? 1 : 2;
    if (pattern[m] == 1) {
      float tile = crinkle_tile_facets * pattern_scale[m];
      int tx = int(floor(p_object[a1] / tile * float(crinkle_size))) & (crinkle_size - 1);
      int ty = int(floor(p_object[a2] / tile * float(crinkle_size))) & (crinkle_size - 1);
      vec2 tilt = crinkle_tilts[texelFetch(crinkle, ivec2(tx, ty), 0).r];
      vec3 perturbed = n_o;
      perturbed[a1] += pattern_strength[m] * tilt.x;
      perturbed[a2] += pattern_strength[m] * tilt.y;
      shading_n_o = normalize(perturbed);
    } else {
      float cu = p_object[a1] / pattern_scale[m], cv = p_object[a2] / pattern_scale[m];
      if (cu - floor(cu) < solar_cell_gap || cv - floor(cv) < solar_cell_gap)
        albedo = albedo + vec3(pattern_strength[m]);
    }
  }
  vec3 Ng = camera_R_object * n_o;
  vec3 N = camera_R_object * shading_n_o;
  vec3 V = -normalize(p_camera);
  if (dot(Ng, V) < 0.0) {
    Ng = -Ng;
    N = -N;
  }
  vec3 L = sun_direction;
  vec3 colour = vec3(0.0);
  float ndl_geometric = dot(Ng, L);
  if (irradiance > 0.0 && ndl_geometric > 0.0) {
    float s = shadows ? shadowFactor(p_camera + shadow_normal_offset_texels * shadow_texel * Ng) : 1.0;
    float ndl = max(0.0, dot(N, L));
    if (s > 0.0 && ndl > 0.0) {
      colour = albedo * ndl;
      float ndh = max(0.0, dot(N, normalize(L + V)));
      if (ndh > specular_cutoff[m]) {
        float lobe = (shininess[m] + 8.0) / 8.0 * pow(ndh, shininess[m]);
        colour += specular[m] * (lobe * ndl);
      }
      colour *= irradiance * s;
    }
  }
  out_radiance_depth = vec4(colour, p_camera.z);
  out_id = object_id;
}
)";

const char* kShadowVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 sun_T_object;
uniform float shadow_scale;
uniform float shadow_offset;
uniform int shadow_size;
uniform float shadow_depth_range;
void main() {
  vec3 s = (sun_T_object * vec4(position, 1.0)).xyz;
  // Texel (i, j) samples map coordinate (i, j), as the CPU rasteriser does.
  float tx = s.x * shadow_scale + shadow_offset, ty = s.y * shadow_scale + shadow_offset;
  gl_Position = vec4((tx + 0.5) * 2.0 / float(shadow_size) - 1.0,
                     (ty + 0.5) * 2.0 / float(shadow_size) - 1.0,
                     s.z / shadow_depth_range, 1.0);
}
)";

const char* kShadowFragmentShader = R"(#version 330 core
void main() {}
)";

struct GlModel {
  GLuint vao = 0, vbo = 0, ebo = 0, material_buffer = 0, material_texture = 0;
  GLsizei index_count = 0;
  std::vector<Material> materials;
  std::vector<float> cutoff;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0;
};

Eigen::Matrix4f toGl(const Eigen::Isometry3d& T) {
  return T.matrix().cast<float>();
}

class GlRenderer final : public Renderer {
 public:
  ~GlRenderer() override {
    if (display_ != EGL_NO_DISPLAY) {
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_);
      for (GlModel& m : models_) {
        glDeleteVertexArrays(1, &m.vao);
        glDeleteBuffers(1, &m.vbo);
        glDeleteBuffers(1, &m.ebo);
        glDeleteBuffers(1, &m.material_buffer);
        glDeleteTextures(1, &m.material_texture);
      }
      releaseTargets();
      if (shadow_fbo_) glDeleteFramebuffers(1, &shadow_fbo_);
      if (shadow_texture_) glDeleteTextures(1, &shadow_texture_);
      if (crinkle_texture_) glDeleteTextures(1, &crinkle_texture_);
      if (scene_program_) glDeleteProgram(scene_program_);
      if (shadow_program_) glDeleteProgram(shadow_program_);
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
      eglTerminate(display_);
    }
  }

  Status initialise() {
    // llvmpipe reads its thread count when the screen is created; one thread unless the user
    // chose otherwise (the figures in docs/benchmarks.md are for one core).
    setenv("LP_NUM_THREADS", "1", 0);
    const char* client_extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (client_extensions && std::strstr(client_extensions, "EGL_MESA_platform_surfaceless") &&
        get_platform_display)
      display_ = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display_ == EGL_NO_DISPLAY)
      return notFound(
          "opengl renderer: no EGL surfaceless display (EGL_MESA_platform_surfaceless missing; "
          "client extensions: {})",
          client_extensions ? client_extensions : "none");
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display_, &major, &minor)) {
      display_ = EGL_NO_DISPLAY;
      return notFound("opengl renderer: eglInitialize failed (EGL error 0x{:x})", eglGetError());
    }
    if (!eglBindAPI(EGL_OPENGL_API))
      return notFound("opengl renderer: EGL cannot bind desktop OpenGL");
    const EGLint config_attributes[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                                        EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint count = 0;
    eglChooseConfig(display_, config_attributes, &config, 1, &count);
    const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION,
                                         3,
                                         EGL_CONTEXT_MINOR_VERSION,
                                         3,
                                         EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                         EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                         EGL_NONE};
    context_ = eglCreateContext(display_, count > 0 ? config : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT,
                                context_attributes);
    if (context_ == EGL_NO_CONTEXT)
      return notFound(
          "opengl renderer: cannot create an OpenGL 3.3 core context (EGL error 0x{:x})",
          eglGetError());
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
      return notFound(
          "opengl renderer: cannot make the context current without a surface (EGL error 0x{:x})",
          eglGetError());
    const char* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    const char* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
    const char* threads = std::getenv("LP_NUM_THREADS");
    description_ = fmt::format("opengl: {} ({}), EGL {}.{} surfaceless, LP_NUM_THREADS={}",
                               renderer ? renderer : "?", version ? version : "?", major, minor,
                               threads ? threads : "unset");
    auto scene = link(kSceneVertexShader, kSceneFragmentShader);
    if (!scene) return scene.status();
    scene_program_ = *scene;
    auto shadow = link(kShadowVertexShader, kShadowFragmentShader);
    if (!shadow) return shadow.status();
    shadow_program_ = *shadow;
    // The crinkle texture, fetched texel by texel.
    glGenTextures(1, &crinkle_texture_);
    glBindTexture(GL_TEXTURE_2D, crinkle_texture_);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R8UI, kCrinkleSize, kCrinkleSize, 0, GL_RED_INTEGER,
                 GL_UNSIGNED_BYTE, crinkleCells().data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glGenFramebuffers(1, &shadow_fbo_);
    return checkGl("initialisation");
  }

  RendererBackend backend() const override { return RendererBackend::kOpenGl; }
  std::string description() const override { return description_; }

  Result<int> addModel(const TargetModel& model) override {
    CDFF_RETURN_IF_ERROR(model.validate());
    if (model.materials.size() > kMaxMaterials)
      return invalidInput("opengl renderer: model '{}' has {} materials; expected at most {}",
                          model.name, model.materials.size(), kMaxMaterials);
    makeCurrent();
    GlModel m;
    std::vector<float> interleaved;
    interleaved.reserve(model.mesh.vertices.size() * 6);
    for (std::size_t i = 0; i < model.mesh.vertices.size(); ++i) {
      for (int k = 0; k < 3; ++k) interleaved.push_back(model.mesh.vertices[i][k]);
      for (int k = 0; k < 3; ++k) interleaved.push_back(model.mesh.vertex_normals[i][k]);
    }
    std::vector<std::uint32_t> indices;
    indices.reserve(model.mesh.triangles.size() * 3);
    for (const auto& t : model.mesh.triangles) indices.insert(indices.end(), t.begin(), t.end());
    glGenVertexArrays(1, &m.vao);
    glBindVertexArray(m.vao);
    glGenBuffers(1, &m.vbo);
    glBindBuffer(GL_ARRAY_BUFFER, m.vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(interleaved.size() * sizeof(float)),
                 interleaved.data(), GL_STATIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                          reinterpret_cast<void*>(3 * sizeof(float)));
    glGenBuffers(1, &m.ebo);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.ebo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER,
                 static_cast<GLsizeiptr>(indices.size() * sizeof(std::uint32_t)), indices.data(),
                 GL_STATIC_DRAW);
    glBindVertexArray(0);
    m.index_count = static_cast<GLsizei>(indices.size());
    // Per-triangle material indices, fetched with gl_PrimitiveID.
    std::vector<std::uint16_t> materials(model.triangle_material.begin(),
                                         model.triangle_material.end());
    glGenBuffers(1, &m.material_buffer);
    glBindBuffer(GL_TEXTURE_BUFFER, m.material_buffer);
    glBufferData(GL_TEXTURE_BUFFER,
                 static_cast<GLsizeiptr>(materials.size() * sizeof(std::uint16_t)),
                 materials.data(), GL_STATIC_DRAW);
    glGenTextures(1, &m.material_texture);
    glBindTexture(GL_TEXTURE_BUFFER, m.material_texture);
    glTexBuffer(GL_TEXTURE_BUFFER, GL_R16UI, m.material_buffer);
    m.materials = model.materials;
    for (const Material& mat : m.materials)
      m.cutoff.push_back(std::exp(-13.8f / std::max(mat.shininess, 1.0f)));
    m.centre = model.boundingCentre();
    m.radius = model.boundingRadius();
    CDFF_RETURN_IF_ERROR(checkGl("model upload"));
    models_.push_back(std::move(m));
    return static_cast<int>(models_.size() - 1);
  }

  Status render(const RenderScene& scene, const PinholeCamera& cam, RenderOutput& out) override {
    if (cam.width <= 0 || cam.height <= 0 || !(cam.fx > 0) || !(cam.fy > 0))
      return invalidInput(
          "opengl renderer: camera {}x{} with fx = {}, fy = {}; expected a positive size and focal "
          "lengths",
          cam.width, cam.height, cam.fx, cam.fy);
    for (const RenderObject& o : scene.objects)
      if (o.model < 0 || o.model >= static_cast<int>(models_.size()))
        return invalidInput("opengl renderer: object uses model {}; {} models were added", o.model,
                            models_.size());
    makeCurrent();
    CDFF_RETURN_IF_ERROR(ensureTargets(cam.width, cam.height));
    ShadowFrame shadow;
    double depth_range = 1.0;
    CDFF_RETURN_IF_ERROR(shadowPass(scene, shadow, depth_range));
    const auto [near_plane, far_plane] = depthPlanes(scene, cam);
    beginScenePass(cam);
    setSceneUniforms(scene, cam, shadow, depth_range, near_plane, far_plane);
    for (const RenderObject& o : scene.objects) {
      const GlModel& m = models_[o.model];
      uniformMatrix4(scene_program_, "camera_T_object", toGl(o.camera_T_object));
      const Eigen::Matrix3f R = o.camera_T_object.linear().cast<float>();
      glUniformMatrix3fv(location(scene_program_, "camera_R_object"), 1, GL_FALSE, R.data());
      glUniform1ui(location(scene_program_, "object_id"), o.id);
      setMaterials(m);
      glActiveTexture(GL_TEXTURE2);
      glBindTexture(GL_TEXTURE_BUFFER, m.material_texture);
      glBindVertexArray(m.vao);
      glDrawElements(GL_TRIANGLES, m.index_count, GL_UNSIGNED_INT, nullptr);
    }
    glBindVertexArray(0);
    return readBack(cam, out);
  }

 private:
  // The shadow map, when the sun shines and the scene wants shadows (shadow.valid says whether
  // one was drawn), and the depth range it spans.
  Status shadowPass(const RenderScene& scene, ShadowFrame& shadow, double& depth_range) {
    const bool lit = scene.sun_irradiance > 0;
    if (!(lit && scene.shadows)) return Status::ok();
    std::vector<std::pair<Eigen::Vector3d, double>> casters;
    for (const RenderObject& o : scene.objects)
      if (o.casts_shadow)
        casters.emplace_back(o.camera_T_object * models_[o.model].centre, models_[o.model].radius);
    shadow = fitShadowFrame(scene.sun_direction, casters, scene.shadow_map_size);
    if (!shadow.valid) return Status::ok();
    depth_range = 0;
    for (const auto& [c, r] : casters)
      depth_range = std::max(depth_range, std::abs((shadow.sun_T_camera * c).z()) + r);
    depth_range = depth_range * 1.05 + 1.0;
    return renderShadow(scene, shadow, depth_range);
  }

  // Near and far planes tight around the objects keep the depth buffer precise at any range.
  std::pair<double, double> depthPlanes(const RenderScene& scene, const PinholeCamera& cam) const {
    double near_plane = std::numeric_limits<double>::infinity(), far_plane = cam.near_plane * 2;
    for (const RenderObject& o : scene.objects) {
      const double z = (o.camera_T_object * models_[o.model].centre).z(),
                   r = models_[o.model].radius;
      near_plane = std::min(near_plane, z - r);
      far_plane = std::max(far_plane, z + r);
    }
    near_plane = std::max(near_plane * 0.99, cam.near_plane);
    far_plane = std::min(far_plane * 1.01 + 1e-3, cam.far_plane);
    if (!(far_plane > near_plane)) far_plane = near_plane * 2;
    return {near_plane, far_plane};
  }

  // Binds and clears the scene framebuffer, with the scene program and its fixed state.
  void beginScenePass(const PinholeCamera& cam) {
    glBindFramebuffer(GL_FRAMEBUFFER, scene_fbo_);
    glViewport(0, 0, cam.width, cam.height);
    const GLenum buffers[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, buffers);
    const float clear_colour[4] = {0, 0, 0, 0};
    const GLuint clear_id[4] = {0, 0, 0, 0};
    glClearBufferfv(GL_COLOR, 0, clear_colour);
    glClearBufferuiv(GL_COLOR, 1, clear_id);
    glClearDepth(1.0);
    glClear(GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);
    glUseProgram(scene_program_);
  }

  // The scene program's uniforms and textures that hold for every object.
  void setSceneUniforms(const RenderScene& scene, const PinholeCamera& cam,
                        const ShadowFrame& shadow, double depth_range, double near_plane,
                        double far_plane) {
    // Optical frame (x right, y down, z forward) to clip space with pixel (u, v) centred at
    // window coordinate (u + 0.5, v + 0.5); framebuffer row v holds image row v.
    Eigen::Matrix4f P = Eigen::Matrix4f::Zero();
    P(0, 0) = static_cast<float>(2 * cam.fx / cam.width);
    P(0, 2) = static_cast<float>((2 * cam.cx + 1) / cam.width - 1);
    P(1, 1) = static_cast<float>(2 * cam.fy / cam.height);
    P(1, 2) = static_cast<float>((2 * cam.cy + 1) / cam.height - 1);
    P(2, 2) = static_cast<float>((far_plane + near_plane) / (far_plane - near_plane));
    P(2, 3) = static_cast<float>(-2 * far_plane * near_plane / (far_plane - near_plane));
    P(3, 2) = 1.0f;
    uniformMatrix4(scene_program_, "projection", P);
    const Eigen::Vector3f L = scene.sun_direction.normalized().cast<float>();
    glUniform3f(location(scene_program_, "sun_direction"), L.x(), L.y(), L.z());
    glUniform1f(location(scene_program_, "irradiance"), static_cast<float>(scene.sun_irradiance));
    glUniform1i(location(scene_program_, "crinkle_size"), kCrinkleSize);
    glUniform2fv(location(scene_program_, "crinkle_tilts"), kCrinkleCells, crinkleTilts().data());
    glUniform1f(location(scene_program_, "crinkle_tile_facets"), kCrinkleTileFacets);
    glUniform1f(location(scene_program_, "solar_cell_gap"), kSolarCellGap);
    glUniform1i(location(scene_program_, "shadows"), shadow.valid ? 1 : 0);
    glUniform1f(location(scene_program_, "shadow_bias_texels"), kShadowBiasTexels);
    glUniform1f(location(scene_program_, "shadow_normal_offset_texels"), kShadowNormalOffsetTexels);
    if (shadow.valid) {
      uniformMatrix4(scene_program_, "sun_T_camera", toGl(shadow.sun_T_camera));
      glUniform1f(location(scene_program_, "shadow_scale"), static_cast<float>(shadow.scale));
      glUniform1f(location(scene_program_, "shadow_offset"), static_cast<float>(shadow.offset));
      glUniform1f(location(scene_program_, "shadow_texel"), static_cast<float>(shadow.texel));
      glUniform1i(location(scene_program_, "shadow_size"), shadow.size);
      glUniform1f(location(scene_program_, "shadow_depth_range"), static_cast<float>(depth_range));
    }
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, crinkle_texture_);
    glUniform1i(location(scene_program_, "crinkle"), 0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, shadow_texture_);
    glUniform1i(location(scene_program_, "shadow_map"), 1);
    glUniform1i(location(scene_program_, "triangle_material"), 2);
  }

  // Reads radiance, depth and ids back into `out` (nothing drawn: 0, +inf and 0).
  Status readBack(const PinholeCamera& cam, RenderOutput& out) {
    const std::size_t pixels = static_cast<std::size_t>(cam.width) * cam.height;
    readback_.resize(4 * pixels);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glReadPixels(0, 0, cam.width, cam.height, GL_RGBA, GL_FLOAT, readback_.data());
    if (out.width != cam.width || out.height != cam.height || out.depth.size() != pixels)
      out.resize(cam.width, cam.height);
    glReadBuffer(GL_COLOR_ATTACHMENT1);
    glReadPixels(0, 0, cam.width, cam.height, GL_RED_INTEGER, GL_UNSIGNED_BYTE, out.id.data());
    CDFF_RETURN_IF_ERROR(checkGl("rendering"));
    const float inf = std::numeric_limits<float>::infinity();
    for (std::size_t i = 0; i < pixels; ++i) {
      const bool hit = out.id[i] != 0;
      out.radiance[3 * i] = hit ? readback_[4 * i] : 0.0f;
      out.radiance[3 * i + 1] = hit ? readback_[4 * i + 1] : 0.0f;
      out.radiance[3 * i + 2] = hit ? readback_[4 * i + 2] : 0.0f;
      out.depth[i] = hit ? readback_[4 * i + 3] : inf;
    }
    return Status::ok();
  }

  void makeCurrent() { eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_); }

  Status checkGl(const char* what) {
    const GLenum error = glGetError();
    if (error != GL_NO_ERROR)
      return {StatusCode::kInternal,
              fmt::format("opengl renderer: GL error 0x{:x} during {}", error, what)};
    return Status::ok();
  }

  GLint location(GLuint program, const char* name) { return glGetUniformLocation(program, name); }
  void uniformMatrix4(GLuint program, const char* name, const Eigen::Matrix4f& m) {
    glUniformMatrix4fv(location(program, name), 1, GL_FALSE, m.data());  // Eigen is column-major
  }

  void setMaterials(const GlModel& m) {
    float diffuse[3 * kMaxMaterials] = {}, specular[3 * kMaxMaterials] = {};
    float shininess[kMaxMaterials] = {}, strength[kMaxMaterials] = {}, scale[kMaxMaterials] = {},
          cutoff[kMaxMaterials] = {};
    GLint pattern[kMaxMaterials] = {};
    for (std::size_t i = 0; i < m.materials.size(); ++i) {
      const Material& mat = m.materials[i];
      for (int k = 0; k < 3; ++k) {
        diffuse[3 * i + k] = mat.diffuse[k];
        specular[3 * i + k] = mat.specular[k];
      }
      shininess[i] = mat.shininess;
      pattern[i] = static_cast<GLint>(mat.pattern);
      strength[i] = mat.pattern_strength;
      scale[i] = mat.pattern_scale;
      cutoff[i] = m.cutoff[i];
    }
    glUniform3fv(location(scene_program_, "diffuse"), kMaxMaterials, diffuse);
    glUniform3fv(location(scene_program_, "specular"), kMaxMaterials, specular);
    glUniform1fv(location(scene_program_, "shininess"), kMaxMaterials, shininess);
    glUniform1iv(location(scene_program_, "pattern"), kMaxMaterials, pattern);
    glUniform1fv(location(scene_program_, "pattern_strength"), kMaxMaterials, strength);
    glUniform1fv(location(scene_program_, "pattern_scale"), kMaxMaterials, scale);
    glUniform1fv(location(scene_program_, "specular_cutoff"), kMaxMaterials, cutoff);
  }

  Status renderShadow(const RenderScene& scene, const ShadowFrame& shadow, double depth_range) {
    if (shadow_size_ != shadow.size) {
      if (shadow_texture_) glDeleteTextures(1, &shadow_texture_);
      glGenTextures(1, &shadow_texture_);
      glBindTexture(GL_TEXTURE_2D, shadow_texture_);
      glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, shadow.size, shadow.size, 0,
                   GL_DEPTH_COMPONENT, GL_FLOAT, nullptr);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_NONE);
      glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo_);
      glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, shadow_texture_,
                             0);
      glDrawBuffer(GL_NONE);
      glReadBuffer(GL_NONE);
      if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        return {StatusCode::kInternal, "opengl renderer: the shadow framebuffer is incomplete"};
      shadow_size_ = shadow.size;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo_);
    glViewport(0, 0, shadow.size, shadow.size);
    glClearDepth(1.0);
    glClear(GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);
    glUseProgram(shadow_program_);
    glUniform1f(location(shadow_program_, "shadow_scale"), static_cast<float>(shadow.scale));
    glUniform1f(location(shadow_program_, "shadow_offset"), static_cast<float>(shadow.offset));
    glUniform1i(location(shadow_program_, "shadow_size"), shadow.size);
    glUniform1f(location(shadow_program_, "shadow_depth_range"), static_cast<float>(depth_range));
    for (const RenderObject& o : scene.objects) {
      if (!o.casts_shadow) continue;
      const GlModel& m = models_[o.model];
      uniformMatrix4(shadow_program_, "sun_T_object",
                     toGl(shadow.sun_T_camera * o.camera_T_object));
      glBindVertexArray(m.vao);
      glDrawElements(GL_TRIANGLES, m.index_count, GL_UNSIGNED_INT, nullptr);
    }
    glBindVertexArray(0);
    return checkGl("shadow pass");
  }

  Status ensureTargets(int width, int height) {
    if (width == width_ && height == height_) return Status::ok();
    releaseTargets();
    glGenFramebuffers(1, &scene_fbo_);
    glBindFramebuffer(GL_FRAMEBUFFER, scene_fbo_);
    glGenTextures(1, &colour_texture_);
    glBindTexture(GL_TEXTURE_2D, colour_texture_);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, width, height, 0, GL_RGBA, GL_FLOAT, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour_texture_, 0);
    glGenTextures(1, &id_texture_);
    glBindTexture(GL_TEXTURE_2D, id_texture_);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R8UI, width, height, 0, GL_RED_INTEGER, GL_UNSIGNED_BYTE,
                 nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, id_texture_, 0);
    glGenRenderbuffers(1, &depth_buffer_);
    glBindRenderbuffer(GL_RENDERBUFFER, depth_buffer_);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, width, height);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_buffer_);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      return {StatusCode::kInternal,
              fmt::format("opengl renderer: the {}x{} framebuffer is incomplete", width, height)};
    width_ = width;
    height_ = height;
    return checkGl("framebuffer set-up");
  }

  void releaseTargets() {
    if (scene_fbo_) glDeleteFramebuffers(1, &scene_fbo_);
    if (colour_texture_) glDeleteTextures(1, &colour_texture_);
    if (id_texture_) glDeleteTextures(1, &id_texture_);
    if (depth_buffer_) glDeleteRenderbuffers(1, &depth_buffer_);
    scene_fbo_ = colour_texture_ = id_texture_ = depth_buffer_ = 0;
    width_ = height_ = 0;
  }

  Result<GLuint> link(const char* vertex, const char* fragment) {
    auto compile = [](GLenum type, const char* source) -> Result<GLuint> {
      const GLuint shader = glCreateShader(type);
      glShaderSource(shader, 1, &source, nullptr);
      glCompileShader(shader);
      GLint ok = 0;
      glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
      if (!ok) {
        char log[4096] = {};
        glGetShaderInfoLog(shader, sizeof(log), nullptr, log);
        glDeleteShader(shader);
        return Status(StatusCode::kInternal,
                      fmt::format("opengl renderer: shader compilation failed: {}", log));
      }
      return shader;
    };
    auto vs = compile(GL_VERTEX_SHADER, vertex);
    if (!vs) return vs.status();
    auto fs = compile(GL_FRAGMENT_SHADER, fragment);
    if (!fs) return fs.status();
    const GLuint program = glCreateProgram();
    glAttachShader(program, *vs);
    glAttachShader(program, *fs);
    glLinkProgram(program);
    glDeleteShader(*vs);
    glDeleteShader(*fs);
    GLint ok = 0;
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (!ok) {
      char log[4096] = {};
      glGetProgramInfoLog(program, sizeof(log), nullptr, log);
      glDeleteProgram(program);
      return Status(StatusCode::kInternal,
                    fmt::format("opengl renderer: program link failed: {}", log));
    }
    return program;
  }

  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  std::string description_;
  GLuint scene_program_ = 0, shadow_program_ = 0;
  GLuint crinkle_texture_ = 0;
  GLuint shadow_fbo_ = 0, shadow_texture_ = 0;
  int shadow_size_ = 0;
  GLuint scene_fbo_ = 0, colour_texture_ = 0, id_texture_ = 0, depth_buffer_ = 0;
  int width_ = 0, height_ = 0;
  std::vector<GlModel> models_;
  std::vector<float> readback_;
};

}  // namespace

Result<std::unique_ptr<Renderer>> createOpenGlRenderer() {
  auto renderer = std::make_unique<GlRenderer>();
  CDFF_RETURN_IF_ERROR(renderer->initialise());
  return std::unique_ptr<Renderer>(std::move(renderer));
}

}  // namespace cdff::egse
