// Simulator speed on one core: a 1024x1024 RGB + depth frame with each renderer, a VLP-16 scan,
// a ToF frame, the camera model (distortion, blur, noise) and a simulated IMU sample.
#include <benchmark/benchmark.h>

#include "bench_support.hpp"
#include "cdff/egse/camera_sensor.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/render.hpp"

namespace {

using namespace cdff;
using namespace cdff::egse;

Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& at) {
  const Eigen::Vector3d z = (at - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() << x, y, z;
  T.translation() = eye;
  return T.inverse();
}

// The benchmark scene: the procedural target 9 m away, side-lit, with shadows, filling about a
// third of a 1024 x 1024 image behind a 35 mm-equivalent lens (the seed's Table 3 set-up).
struct Scene {
  TargetModel model = *makeTargetSatellite();
  PinholeCamera camera;
  RenderScene scene;
  Scene(double distance) {
    camera.width = camera.height = 1024;
    camera.fx = camera.fy = 1100;
    camera.cx = camera.cy = 511.5;
    scene.objects.push_back({0, lookAt(Eigen::Vector3d(-0.8, 0.35, 0.45).normalized() * distance, {0, 0, 0}), 1, true});
    scene.sun_direction = scene.objects[0].camera_T_object.linear() * Eigen::Vector3d(-0.5, -0.6, 0.6).normalized();
  }
};

void renderFrame(benchmark::State& state, RendererBackend backend) {
  Scene s(static_cast<double>(state.range(0)));
  std::unique_ptr<Renderer> renderer;
  if (backend == RendererBackend::kCpu) {
    renderer = createCpuRenderer();
  } else {
    auto gl = createOpenGlRenderer();
    if (!gl) {
      state.SkipWithError(gl.status().toString().c_str());
      return;
    }
    renderer = std::move(gl).value();
  }
  s.scene.objects[0].model = *renderer->addModel(s.model);
  RenderOutput out;
  for (auto _ : state) {
    if (!renderer->render(s.scene, s.camera, out)) state.SkipWithError("render failed");
    benchmark::DoNotOptimize(out.radiance.data());
  }
  std::size_t covered = 0;
  for (auto id : out.id) covered += id != 0;
  state.counters["coverage"] = static_cast<double>(covered) / out.id.size();
  state.SetLabel(renderer->description());
}

void BM_RenderCpu(benchmark::State& state) { renderFrame(state, RendererBackend::kCpu); }
void BM_RenderOpenGl(benchmark::State& state) { renderFrame(state, RendererBackend::kOpenGl); }
BENCHMARK(BM_RenderCpu)->Arg(9)->Arg(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RenderOpenGl)->Arg(9)->Arg(5)->Unit(benchmark::kMillisecond);

}  // namespace


namespace {
void BM_RenderCpuEmpty(benchmark::State& state) {
  Scene s(9);
  auto renderer = createCpuRenderer();
  s.scene.objects[0].model = *renderer->addModel(s.model);
  s.scene.objects[0].camera_T_object.translation().z() = -100;  // behind the camera
  RenderOutput out;
  for (auto _ : state) {
    if (!renderer->render(s.scene, s.camera, out)) state.SkipWithError("render failed");
    benchmark::DoNotOptimize(out.radiance.data());
  }
}
BENCHMARK(BM_RenderCpuEmpty)->Unit(benchmark::kMillisecond);
}  // namespace
CDFF_BENCHMARK_MAIN();
