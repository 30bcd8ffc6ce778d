// Simulator speed on one core: a 1024x1024 RGB + depth frame with each renderer, a VLP-16 scan,
// a ToF frame, the camera model (distortion, blur, noise) and a simulated IMU sample.
#include <benchmark/benchmark.h>

#include "bench_support.hpp"
#include "cdff/egse/camera_sensor.hpp"
#include "cdff/egse/imu.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/range_sensors.hpp"
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

// The benchmark scene: the procedural target side-lit, with shadows, in a 1024 x 1024 image
// behind a 35 mm-equivalent lens (the seed's Table 3 set-up). The argument is the distance in
// cm: 9 / 5 / 3 / 1.7 / 1.5 m cover 5 / 15 / 31 / 72 / 82 % of the image.
struct Scene {
  TargetModel model = *makeTargetSatellite();
  PinholeCamera camera;
  RenderScene scene;
  Scene(double distance) {
    camera.width = camera.height = 1024;
    camera.fx = camera.fy = 1100;
    camera.cx = camera.cy = 511.5;
    scene.objects.push_back(
        {0, lookAt(Eigen::Vector3d(-0.8, 0.35, 0.45).normalized() * distance, {0, 0, 0}), 1, true});
    scene.sun_direction =
        scene.objects[0].camera_T_object.linear() * Eigen::Vector3d(-0.5, -0.6, 0.6).normalized();
  }
};

void renderFrame(benchmark::State& state, RendererBackend backend) {
  Scene s(static_cast<double>(state.range(0)) / 100.0);  // cm
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

void BM_RenderCpu(benchmark::State& state) {
  renderFrame(state, RendererBackend::kCpu);
}
void BM_RenderOpenGl(benchmark::State& state) {
  renderFrame(state, RendererBackend::kOpenGl);
}
BENCHMARK(BM_RenderCpu)
    ->Arg(900)
    ->Arg(500)
    ->Arg(300)
    ->Arg(170)
    ->Arg(150)
    ->Unit(benchmark::kMillisecond);
// llvmpipe rasterises in its own thread (LP_NUM_THREADS=1): the process CPU time is the cost.
BENCHMARK(BM_RenderOpenGl)
    ->Arg(900)
    ->Arg(500)
    ->Arg(300)
    ->Arg(170)
    ->Arg(150)
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);

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
namespace {

// One revolution of the VLP-16 (28 928 firings) at a target 6 m ahead, tumbling during the scan.
void BM_LidarScanVlp16(benchmark::State& state) {
  const TargetModel model = *makeTargetSatellite();
  auto caster = RayCaster::create(model);
  auto lidar = LidarSensor::create(LidarSpec::vlp16(), "lidar");
  const RelativePose pose = [](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.1 * t + 2.4, Eigen::Vector3d(0.3, 0.5, 1).normalized())
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(6.0, -0.2, 0.3);
    return T;
  };
  std::size_t points = 0;
  for (auto _ : state) {
    Rng rng(1);
    auto cloud = lidar->scan(**caster, model, pose, 0.0, {}, rng);
    points = cloud->size();
    benchmark::DoNotOptimize(cloud->points.data());
  }
  state.counters["points"] = static_cast<double>(points);
}
BENCHMARK(BM_LidarScanVlp16)->Unit(benchmark::kMillisecond);

// The same scan with every one of the 28 928 rays cast (a target all around the sensor).
void BM_LidarScanVlp16AllRays(benchmark::State& state) {
  ModelBuilder b("room");
  b.addBox(Eigen::Isometry3d::Identity(), {20, 20, 20}, b.material(MaterialId::kRadiator));
  const TargetModel room = b.build();
  auto caster = RayCaster::create(room);
  auto lidar = LidarSensor::create(LidarSpec::vlp16(), "lidar");
  for (auto _ : state) {
    Rng rng(1);
    auto cloud = lidar->scan(
        **caster, room, [](double) { return Eigen::Isometry3d::Identity(); }, 0.0, {}, rng);
    benchmark::DoNotOptimize(cloud->points.data());
  }
}
BENCHMARK(BM_LidarScanVlp16AllRays)->Unit(benchmark::kMillisecond);

void BM_TofFrame(benchmark::State& state) {
  const TargetModel model = *makeTargetSatellite();
  auto caster = RayCaster::create(model);
  auto tof = TofSensor::create(TofSpec::defaults(), "tof");
  const Eigen::Isometry3d pose =
      lookAt(Eigen::Vector3d(-0.8, 0.35, 0.45).normalized() * 4.0, {0, 0, 0});
  for (auto _ : state) {
    Rng rng(1);
    auto depth = tof->capture(**caster, model, pose, 0.0, rng);
    benchmark::DoNotOptimize(depth->image.pixels.data());
  }
}
BENCHMARK(BM_TofFrame)->Unit(benchmark::kMillisecond);

// The camera model on a rendered Prosilica frame: background, distortion remap, blur, noise.
void BM_CameraExposeProsilica(benchmark::State& state) {
  Scene s(9);
  CameraSpec spec;
  spec.model.width = 1624;
  spec.model.height = 1234;
  spec.model.fx = spec.model.fy = 6e-3 / 4.4e-6;
  spec.model.cx = 811.5;
  spec.model.cy = 616.5;
  spec.model.distortion_model = DistortionModel::kRadialTangential;
  spec.model.distortion = {-0.12, 0.05, 0.0005, -0.0003, 0.0};
  auto sensor = CameraSensor::create(spec, "camera");
  auto renderer = createCpuRenderer();
  s.scene.objects[0].model = *renderer->addModel(s.model);
  std::vector<RenderOutput> renders(1);
  if (!renderer->render(s.scene, sensor->renderCamera(), renders[0]))
    state.SkipWithError("render failed");
  BackgroundView view;
  view.lvlh_R_camera = s.scene.objects[0].camera_T_object.linear().transpose();
  view.sun_direction = view.lvlh_R_camera * s.scene.sun_direction;
  for (auto _ : state) {
    Rng rng(1);
    auto frame = sensor->expose(renders, view, {}, rng);
    benchmark::DoNotOptimize(frame->image.pixels.data());
  }
}
BENCHMARK(BM_CameraExposeProsilica)->Unit(benchmark::kMillisecond);

void BM_ImuSample(benchmark::State& state) {
  Orbit orbit;
  auto fly = flyAroundTranslation({0, 0, 0}, {0, 0, 1}, {0, -1, 0}, 12.0, 0.0, 0.02, 0.0);
  const Translation* self = fly.get();
  World world(orbit, std::move(fly),
              pointingAttitude(orbit, self, nullptr, Eigen::Vector3d::UnitZ(), 0, 0),
              lvlhFixedAttitude(orbit, Eigen::Quaterniond::Identity()), Sun{});
  auto imu = ImuSensor::create(ImuSpec{}, "imu", Eigen::Isometry3d::Identity(), 1);
  double t = 0;
  for (auto _ : state) {
    t += 1.0 / 120;
    auto sample = imu->sample(world, t, {});
    benchmark::DoNotOptimize(sample->angular_velocity.data());
  }
}
BENCHMARK(BM_ImuSample)->Unit(benchmark::kMicrosecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
