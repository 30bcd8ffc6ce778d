// Rendering against ground truth: silhouettes against OpenCV's projection of the mesh, depth
// against ray-plane intersections through OpenCV's undistortion, both backends against each
// other, shadows against ray casting, and the look of space imagery (no ambient light, saturated
// highlights, exposure).
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "cdff/egse/camera_sensor.hpp"
#include "cdff/egse/lens.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/raycaster.hpp"
#include "cdff/egse/render.hpp"
#include "cdff/egse/scenario.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

// The seed's Prosilica GC1600H behind a 6 mm lens (4.4 um pixels), optionally distorted.
CameraModel prosilica(bool distorted) {
  CameraModel c = prosilicaGc1600h();
  if (!distorted) {
    c.distortion_model = DistortionModel::kNone;
    c.distortion.clear();
  }
  return c;
}

// camera_T_target for a camera at `eye` (target frame) looking at `at`, image up ~ `up`.
Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& at,
                         const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (at - eye).normalized();
  const Eigen::Vector3d x = z.cross(up).normalized();  // right
  const Eigen::Vector3d y = z.cross(x);                // down
  Eigen::Matrix3d target_R_camera;
  target_R_camera << x, y, z;
  Eigen::Isometry3d target_T_camera = Eigen::Isometry3d::Identity();
  target_T_camera.linear() = target_R_camera;
  target_T_camera.translation() = eye;
  return target_T_camera.inverse();
}

TargetModel target() {
  auto model = makeTargetSatellite();
  EXPECT_TRUE(model.isOk()) << model.status().toString();
  return std::move(model).value();
}

std::unique_ptr<Renderer> makeRenderer(RendererBackend backend) {
  if (backend == RendererBackend::kCpu) return createCpuRenderer();
  auto gl = createOpenGlRenderer();
  EXPECT_TRUE(gl.isOk()) << "the OpenGL backend must be available (Mesa EGL surfaceless): "
                         << gl.status().toString();
  return gl ? std::move(gl).value() : nullptr;
}

struct Shot {
  RenderOutput render;
  CameraFrame frame;
  PinholeCamera canvas;
};

Shot shoot(Renderer& renderer, int model, const CameraSpec& spec,
           const Eigen::Isometry3d& camera_T_target, const Eigen::Vector3d& sun_in_target,
           CameraFaults faults = {}) {
  auto sensor = CameraSensor::create(spec, "camera");
  EXPECT_TRUE(sensor.isOk()) << sensor.status().toString();
  RenderScene scene;
  scene.objects.push_back({model, camera_T_target, 1, true});
  scene.sun_direction = camera_T_target.linear() * sun_in_target.normalized();
  scene.shadow_map_size = spec.shadow_map_size;
  Shot shot;
  shot.canvas = sensor->renderCamera();
  EXPECT_OK(renderer.render(scene, sensor->renderCamera(), shot.render));
  BackgroundView view;
  view.lvlh_R_camera = camera_T_target.linear().transpose();
  view.sun_direction = sun_in_target.normalized();
  view.stars = false;
  Rng rng(1);
  auto frame = sensor->expose({shot.render}, view, faults, rng);
  EXPECT_TRUE(frame.isOk()) << frame.status().toString();
  shot.frame = std::move(frame).value();
  return shot;
}

// The analytic silhouette: every triangle projected by cv::projectPoints (edges subdivided so
// that distortion bends them); a pixel is in when its centre is inside one of the projected
// triangles (cv::pointPolygonTest), the sampling rule of a pinhole camera model.
cv::Mat analyticMask(const TargetModel& model, const CameraModel& camera,
                     const Eigen::Isometry3d& camera_T_target) {
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  const cv::Mat K =
      (cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  cv::Mat D = camera.distortion.empty() ? cv::Mat::zeros(1, 5, CV_64F)
                                        : cv::Mat(camera.distortion).clone().reshape(1, 1);
  constexpr int kSplit = 6;
  std::vector<cv::Point3d> points;
  for (const auto& t : model.mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      const Eigen::Vector3d a = camera_T_target * model.mesh.vertices[t[e]].cast<double>();
      const Eigen::Vector3d b =
          camera_T_target * model.mesh.vertices[t[(e + 1) % 3]].cast<double>();
      for (int s = 0; s < kSplit; ++s) {
        const Eigen::Vector3d p = a + (b - a) * (static_cast<double>(s) / kSplit);
        points.emplace_back(p.x(), p.y(), p.z());
      }
    }
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, pixels);
  for (std::size_t t = 0; t < model.mesh.triangles.size(); ++t) {
    std::vector<cv::Point2f> polygon;
    for (int k = 0; k < 3 * kSplit; ++k) polygon.emplace_back(pixels[t * 3 * kSplit + k]);
    const cv::Rect box = cv::boundingRect(polygon) & cv::Rect(0, 0, camera.width, camera.height);
    for (int y = box.y; y < box.y + box.height; ++y)
      for (int x = box.x; x < box.x + box.width; ++x)
        if (!mask.at<std::uint8_t>(y, x) &&
            cv::pointPolygonTest(polygon, cv::Point2f(x, y), false) >= 0)
          mask.at<std::uint8_t>(y, x) = 1;
  }
  return mask;
}

double iou(const std::vector<std::uint8_t>& labels, const cv::Mat& analytic,
           std::uint8_t label = 1) {
  std::size_t both = 0, either = 0;
  for (int y = 0; y < analytic.rows; ++y)
    for (int x = 0; x < analytic.cols; ++x) {
      const bool a = labels[static_cast<std::size_t>(y) * analytic.cols + x] == label;
      const bool b = analytic.at<std::uint8_t>(y, x) != 0;
      both += a && b;
      either += a || b;
    }
  return either ? static_cast<double>(both) / either : 0.0;
}

class Backends : public ::testing::TestWithParam<RendererBackend> {};

TEST_P(Backends, SilhouetteMatchesTheAnalyticProjection) {
  const TargetModel model = target();
  auto renderer = makeRenderer(GetParam());
  ASSERT_NE(renderer, nullptr);
  auto handle = renderer->addModel(model);
  ASSERT_OK(handle.status());
  // Mid range (10 m, the whole target in view) and close range (3 m, the bus fills the image).
  const std::vector<std::pair<Eigen::Vector3d, bool>> views = {
      {Eigen::Vector3d(-8.0, 3.0, 4.0), false},
      {Eigen::Vector3d(-8.0, 3.0, 4.0), true},
      {Eigen::Vector3d(-2.6, -0.8, 1.1), true}};
  for (const auto& [eye, distorted] : views) {
    CameraSpec spec;
    spec.model = prosilica(distorted);
    const Eigen::Isometry3d camera_T_target =
        lookAt(eye, Eigen::Vector3d(-0.2, 0, 0.1), Eigen::Vector3d::UnitZ());
    const Shot shot =
        shoot(*renderer, *handle, spec, camera_T_target, Eigen::Vector3d(-1, 0.5, 0.8));
    const double value = iou(shot.frame.labels, analyticMask(model, spec.model, camera_T_target));
    RecordProperty(fmt::format("iou_{}_{}", eye.norm() > 5 ? "10m" : "3m",
                               distorted ? "distorted" : "pinhole"),
                   std::to_string(value));
    EXPECT_GE(value, 0.98) << "view from " << eye.transpose() << (distorted ? " (distorted)" : "");
    // Beyond the requirement: only edge pixels may differ (the distortion remap picks the nearest
    // canvas pixel, so a silhouette may move by half a pixel).
    EXPECT_GE(value, 0.99);
  }
}

TEST_P(Backends, DepthIsTheDistanceAlongTheOpticalAxis) {
  // A tilted 6 x 6 m plate 5 m in front of a distorted camera: every pixel's depth is the ray's
  // intersection with the plane, the ray coming from OpenCV's undistortion (not ours).
  ModelBuilder b("plate");
  const auto m = b.material(MaterialId::kRadiator);
  b.addPolygon({{-3, -3, 0}, {3, -3, 0}, {3, 3, 0}, {-3, 3, 0}}, m);
  const TargetModel plate = b.build();
  auto renderer = makeRenderer(GetParam());
  ASSERT_NE(renderer, nullptr);
  auto handle = renderer->addModel(plate);
  ASSERT_OK(handle.status());
  CameraSpec spec;
  spec.model = prosilica(true);
  Eigen::Isometry3d camera_T_plate = Eigen::Isometry3d::Identity();
  camera_T_plate.linear() = (Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  camera_T_plate.translation() = Eigen::Vector3d(0.2, -0.1, 5.0);
  const Shot shot = shoot(*renderer, *handle, spec, camera_T_plate, Eigen::Vector3d(0, 0, 1));
  const Eigen::Vector3d n = camera_T_plate.linear().col(2), p0 = camera_T_plate.translation();
  const cv::Mat K = (cv::Mat_<double>(3, 3) << spec.model.fx, 0, spec.model.cx, 0, spec.model.fy,
                     spec.model.cy, 0, 0, 1);
  std::vector<cv::Point2d> pixels, rays;
  std::vector<std::size_t> index;
  const int W = spec.model.width, H = spec.model.height;
  for (int y = 3; y < H - 3; y += 7)
    for (int x = 3; x < W - 3; x += 7) {
      bool interior = true;  // away from the plate's edges
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx)
          interior =
              interior && shot.frame.labels[static_cast<std::size_t>(y + dy) * W + x + dx] == 1;
      if (!interior) continue;
      pixels.emplace_back(x, y);
      index.push_back(static_cast<std::size_t>(y) * W + x);
    }
  ASSERT_GT(pixels.size(), 10000u);
  cv::undistortPoints(
      pixels, rays, K, cv::Mat(spec.model.distortion), cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-14));
  double worst = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const Eigen::Vector3d ray(rays[i].x, rays[i].y, 1.0);
    const double z = n.dot(p0) / n.dot(ray);  // the intersection's z (ray has z = 1)
    const float rendered =
        reinterpret_cast<const float*>(shot.frame.depth.image.pixels.data())[index[i]];
    worst = std::max(worst, std::abs(rendered - z));
  }
  RecordProperty("depth_max_error_m", std::to_string(worst));
  EXPECT_LT(worst, 1e-3) << "depth off by up to " << worst << " m on a plate 5 m away";
}

INSTANTIATE_TEST_SUITE_P(Renderers, Backends,
                         ::testing::Values(RendererBackend::kCpu, RendererBackend::kOpenGl),
                         [](const auto& info) { return std::string(toString(info.param)); });

TEST(Lens, MatchesOpenCvProjectionAndUndistortion) {
  for (const auto& [model, coefficients] :
       std::vector<std::pair<DistortionModel, std::vector<double>>>{
           {DistortionModel::kRadialTangential, {-0.12, 0.05, 0.0005, -0.0003, 0.01}},
           {DistortionModel::kRadialTangential,
            {-0.2, 0.1, 0.001, 0.002, 0.0, 0.01, 0.002, 0.001}}}) {
    CameraModel c = prosilica(false);
    c.distortion_model = model;
    c.distortion = coefficients;
    const cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
    std::vector<cv::Point3d> points;
    Rng rng(4);
    for (int i = 0; i < 500; ++i)
      points.emplace_back(rng.uniform(-0.6, 0.6), rng.uniform(-0.45, 0.45), 1.0);
    std::vector<cv::Point2d> expected;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, cv::Mat(coefficients),
                      expected);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d p =
          projectWithDistortion(c, Eigen::Vector3d(points[i].x, points[i].y, points[i].z));
      EXPECT_NEAR(p.x(), expected[i].x, 1e-8);
      EXPECT_NEAR(p.y(), expected[i].y, 1e-8);
      // And back: the pixel's ray goes through the point.
      const Eigen::Vector3d ray = pixelRay(c, expected[i].x, expected[i].y);
      EXPECT_NEAR(ray.x() / ray.z(), points[i].x, 1e-9);
      EXPECT_NEAR(ray.y() / ray.z(), points[i].y, 1e-9);
    }
  }
}

TEST(Renderers, BackendsAgree) {
  const TargetModel model = target();
  auto cpu = makeRenderer(RendererBackend::kCpu), gl = makeRenderer(RendererBackend::kOpenGl);
  ASSERT_TRUE(cpu && gl);
  const int a = *cpu->addModel(model), b = *gl->addModel(model);
  PinholeCamera cam;
  cam.width = 800;
  cam.height = 600;
  cam.fx = cam.fy = 700;
  cam.cx = 399.5;
  cam.cy = 299.5;
  RenderScene scene;
  scene.objects.push_back({a, lookAt({-6, 2.5, 3}, {0, 0, 0}, Eigen::Vector3d::UnitZ()), 1, true});
  scene.sun_direction =
      scene.objects[0].camera_T_object.linear() * Eigen::Vector3d(-0.6, -0.3, 0.75).normalized();
  RenderOutput x, y;
  ASSERT_OK(cpu->render(scene, cam, x));
  scene.objects[0].model = b;
  ASSERT_OK(gl->render(scene, cam, y));
  std::size_t both = 0, either = 0, close = 0, shaded = 0;
  double depth_error = 0;
  for (std::size_t i = 0; i < x.id.size(); ++i) {
    const bool hx = x.id[i] != 0, hy = y.id[i] != 0;
    both += hx && hy;
    either += hx || hy;
    if (!(hx && hy)) continue;
    depth_error =
        std::max(depth_error, static_cast<double>(std::abs(x.depth[i] - y.depth[i]) / x.depth[i]));
    ++shaded;
    bool near = true;
    for (int c = 0; c < 3; ++c)
      near = near && std::abs(x.radiance[3 * i + c] - y.radiance[3 * i + c]) <
                         0.01 + 0.02 * x.radiance[3 * i + c];
    close += near;
  }
  const double overlap = static_cast<double>(both) / either,
               agree = static_cast<double>(close) / shaded;
  RecordProperty("silhouette_iou", std::to_string(overlap));
  RecordProperty("shading_agreement", std::to_string(agree));
  EXPECT_GE(overlap, 0.998);
  EXPECT_LT(depth_error, 1e-4);
  // Shading agrees except on a few pixels where a shadow edge or a crinkle facet boundary falls
  // on the other side of a pixel centre.
  EXPECT_GE(agree, 0.98);
}

TEST(Renderers, SpaceImageryHasNoAmbientLightHardShadowsAndSaturatedHighlights) {
  const TargetModel model = target();
  auto renderer = createCpuRenderer();
  const int handle = *renderer->addModel(model);
  auto caster = RayCaster::create(model);
  ASSERT_OK(caster.status());
  CameraSpec spec;
  spec.model = prosilica(false);
  spec.noise = false;
  const Eigen::Isometry3d camera_T_target =
      lookAt({-6, 3, 3.5}, {0, 0, 0.1}, Eigen::Vector3d::UnitZ());
  const Eigen::Vector3d sun = Eigen::Vector3d(-0.3, -0.9, 0.5).normalized();  // side-lit
  const Shot shot = shoot(*renderer, handle, spec, camera_T_target, sun);
  const PinholeCamera& cam = shot.canvas;
  const Eigen::Isometry3d target_T_camera = camera_T_target.inverse();
  std::size_t target_pixels = 0, black = 0, facing_sun = 0, shadow_agrees = 0, lit_but_dark = 0;
  for (int y = 0; y < cam.height; y += 2)
    for (int x = 0; x < cam.width; x += 2) {
      const std::size_t i = static_cast<std::size_t>(y) * cam.width + x;
      if (shot.render.id[i] != 1) continue;
      ++target_pixels;
      const float r = shot.render.radiance[3 * i] + shot.render.radiance[3 * i + 1] +
                      shot.render.radiance[3 * i + 2];
      black += r == 0.0f;
      // Ground truth by ray casting: the surface point, its normal and a shadow ray to the sun.
      const Eigen::Vector3d dir =
          target_T_camera.linear() *
          Eigen::Vector3d((x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1).normalized();
      const RayHit hit = (*caster)->intersect(
          {target_T_camera.translation().cast<float>(), dir.cast<float>(), 0.0f, 1e4f});
      if (!hit.hit) continue;
      // (Curved parts are shaded with smooth normals, up to 6 degrees off their facets.)
      if (hit.normal.cast<double>().dot(sun) < -0.15) {
        EXPECT_EQ(r, 0.0f) << "a face turned away from the sun is lit at pixel " << x << "," << y;
        continue;
      }
      if (hit.normal.cast<double>().dot(sun) < 0.1) continue;  // grazing: shadow acne territory
      ++facing_sun;
      const Eigen::Vector3f p =
          target_T_camera.translation().cast<float>() + hit.distance * dir.cast<float>();
      const bool in_shadow =
          (*caster)->occluded({p + 0.01f * hit.normal, sun.cast<float>(), 0.0f, 1e4f});
      shadow_agrees += in_shadow == (r == 0.0f);
      lit_but_dark += !in_shadow && r == 0.0f;
    }
  ASSERT_GT(target_pixels, 20000u);
  const double agreement = static_cast<double>(shadow_agrees) / facing_sun;
  RecordProperty("shadow_agreement", std::to_string(agreement));
  EXPECT_GE(agreement, 0.97) << "shadows against ray-cast truth";
  EXPECT_GT(static_cast<double>(black) / target_pixels, 0.15)
      << "no ambient light: unlit parts are black";
  EXPECT_LT(static_cast<double>(lit_but_dark) / facing_sun, 0.02);

  // A solar wing mirroring the sun into the camera saturates; a short exposure underexposes.
  const Eigen::Vector3d to_camera =
      (target_T_camera.translation() - Eigen::Vector3d(0, 2, 0)).normalized();
  const Eigen::Vector3d mirrored =
      (2 * to_camera.z() * Eigen::Vector3d::UnitZ() - to_camera).normalized();
  const Shot glint = shoot(*renderer, handle, spec, camera_T_target, mirrored);
  float peak = 0;
  for (float v : glint.render.radiance) peak = std::max(peak, v);
  EXPECT_GT(peak, 10.0f) << "specular highlight on the cover glass";
  const auto& bytes = glint.frame.image.pixels;
  EXPECT_GT(std::count(bytes.begin(), bytes.end(), 255), 100)
      << "the highlight saturates the sensor";

  auto target_mean = [](const Shot& s) {
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < s.frame.labels.size(); ++i)
      if (s.frame.labels[i] == 1) {
        sum += s.frame.image.pixels[i];
        ++n;
      }
    return sum / n;
  };
  CameraSpec dim = spec;
  dim.exposure_time = spec.exposure_time / 40;
  CameraSpec bright = spec;
  bright.exposure_time = spec.exposure_time * 20;
  const double normal_mean = target_mean(shot);
  const double dim_mean = target_mean(shoot(*renderer, handle, dim, camera_T_target, sun));
  const Shot over = shoot(*renderer, handle, bright, camera_T_target, sun);
  std::size_t saturated = 0, lit = 0;
  for (std::size_t i = 0; i < over.frame.labels.size(); ++i)
    if (over.frame.labels[i] == 1 && over.render.radiance[3 * i + 1] > 0.05f) {
      ++lit;
      saturated += over.frame.image.pixels[i] == 255;
    }
  EXPECT_GT(normal_mean, 15.0);
  EXPECT_LT(dim_mean, 0.1 * normal_mean + 1.0);
  EXPECT_GT(static_cast<double>(saturated) / lit, 0.9)
      << "20x the exposure burns out the lit parts";
}

TEST(Renderers, AreDeterministic) {
  const TargetModel model = target();
  for (RendererBackend backend : {RendererBackend::kCpu, RendererBackend::kOpenGl}) {
    auto first = makeRenderer(backend), second = makeRenderer(backend);
    ASSERT_TRUE(first && second);
    CameraSpec spec;
    spec.model = prosilica(true);
    const Eigen::Isometry3d pose = lookAt({-5, 2, 2}, {0, 0, 0}, Eigen::Vector3d::UnitZ());
    const Shot a = shoot(*first, *first->addModel(model), spec, pose, {-1, -1, 1});
    const Shot b = shoot(*second, *second->addModel(model), spec, pose, {-1, -1, 1});
    EXPECT_EQ(a.render.radiance, b.render.radiance) << toString(backend);
    EXPECT_EQ(a.render.depth, b.render.depth) << toString(backend);
    EXPECT_TRUE(std::equal(a.frame.image.pixels.begin(), a.frame.image.pixels.end(),
                           b.frame.image.pixels.begin()));
  }
}

}  // namespace
}  // namespace cdff::egse
