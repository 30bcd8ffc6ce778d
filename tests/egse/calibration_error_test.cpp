// Calibration errors (calibration_error.hpp): the published calibrations differ from the true
// ones by errors of the stated size statistics over many seeds, the simulator renders with the
// true ones and keeps them as truth, and bad sizes are refused.
#include <gtest/gtest.h>

#include <cmath>

#include "cdff/egse/calibration_error.hpp"
#include "cdff/egse/simulator.hpp"
#include "cdff/types/geometry.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The issue's sizes: extrinsics 0.2 degrees and 2 mm, intrinsics 0.5 %.
CalibrationErrorSpec issueSizes(CalibrationErrorDistribution distribution) {
  CalibrationErrorSpec spec;
  spec.extrinsic_angle = 0.2 * kDeg;
  spec.extrinsic_position = 0.002;
  spec.intrinsics_fraction = 0.005;
  spec.distribution = distribution;
  return spec;
}

TEST(CalibrationError, GaussianErrorsHaveTheStatedRmsOverManySeeds) {
  const CalibrationErrorSpec spec = issueSizes(CalibrationErrorDistribution::kGaussian);
  constexpr int kSeeds = 4000;
  double angle2 = 0, position2 = 0, intrinsic2 = 0;
  Eigen::Vector3d rotation_sum = Eigen::Vector3d::Zero();
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const SensorCalibrationError e = drawCalibrationError(spec, seed, "lidar");
    angle2 += e.rotation.squaredNorm();
    position2 += e.translation.squaredNorm();
    intrinsic2 += e.intrinsics.squaredNorm() / 4;
    rotation_sum += e.rotation;
  }
  // The RMS of a chi-distributed magnitude over N draws has a relative standard error of about
  // sqrt(1 / (2 N k)) (k = 3 components: 0.6 %; k = 4 intrinsics: 0.6 %); 3 % is 5 of them.
  EXPECT_NEAR(std::sqrt(angle2 / kSeeds) / spec.extrinsic_angle, 1.0, 0.03);
  EXPECT_NEAR(std::sqrt(position2 / kSeeds) / spec.extrinsic_position, 1.0, 0.03);
  EXPECT_NEAR(std::sqrt(intrinsic2 / kSeeds) / spec.intrinsics_fraction, 1.0, 0.03);
  // Zero mean: each component's mean within 5 standard errors (sigma / sqrt(3 N)).
  const double sigma = spec.extrinsic_angle / std::sqrt(3.0);
  EXPECT_LT(rotation_sum.cwiseAbs().maxCoeff() / kSeeds, 5 * sigma / std::sqrt(kSeeds));
}

TEST(CalibrationError, FixedErrorsHaveExactlyTheStatedSize) {
  const CalibrationErrorSpec spec = issueSizes(CalibrationErrorDistribution::kFixed);
  Eigen::Vector3d direction_sum = Eigen::Vector3d::Zero();
  constexpr int kSeeds = 2000;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const SensorCalibrationError e = drawCalibrationError(spec, seed, "camera_left");
    EXPECT_NEAR(e.rotation.norm(), spec.extrinsic_angle, 1e-15);
    EXPECT_NEAR(e.translation.norm(), spec.extrinsic_position, 1e-15);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(std::abs(e.intrinsics[i]), spec.intrinsics_fraction);
    direction_sum += e.rotation.normalized();
  }
  // Uniform directions: the mean unit vector's components have a standard error 1/sqrt(3 N).
  EXPECT_LT(direction_sum.cwiseAbs().maxCoeff() / kSeeds, 5 / std::sqrt(3.0 * kSeeds));
}

TEST(CalibrationError, EachSensorDrawsItsOwnReproducibleError) {
  const CalibrationErrorSpec spec = issueSizes(CalibrationErrorDistribution::kGaussian);
  const auto left = drawCalibrationError(spec, 7, "camera_left");
  EXPECT_EQ(left.rotation, drawCalibrationError(spec, 7, "camera_left").rotation);
  EXPECT_NE(left.rotation, drawCalibrationError(spec, 7, "camera_right").rotation);
  EXPECT_NE(left.rotation, drawCalibrationError(spec, 8, "camera_left").rotation);
  // The spec's own seed replaces the run's.
  CalibrationErrorSpec seeded = spec;
  seeded.seed = 99;
  EXPECT_EQ(drawCalibrationError(seeded, 7, "lidar").translation,
            drawCalibrationError(seeded, 8, "lidar").translation);
  // A sensor the spec does not list, and no sizes: no error.
  seeded.sensors = {"lidar"};
  EXPECT_TRUE(drawCalibrationError(seeded, 7, "camera_left").rotation.isZero());
  EXPECT_TRUE(drawCalibrationError({}, 7, "lidar").translation.isZero());
}

TEST(CalibrationError, AppliesToTheMountingAndTheIntrinsics) {
  SensorCalibrationError e;
  e.rotation = Eigen::Vector3d(0, 0, 0.01);
  e.translation = Eigen::Vector3d(0.002, 0, 0);
  e.intrinsics = Eigen::Vector4d(0.01, -0.01, 0.02, 0);
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
  mount.translation() = Eigen::Vector3d(0.45, 0, -0.2);
  const Eigen::Isometry3d published = perturbedMounting(mount, e);
  EXPECT_NEAR(Eigen::AngleAxisd(published.linear() * mount.linear().transpose()).angle(), 0.01,
              1e-12);
  EXPECT_NEAR((published.translation() - mount.translation()).norm(), 0.002, 1e-12);
  CameraModel model;
  model.width = 100;
  model.height = 80;
  model.fx = 100;
  model.fy = 100;
  model.cx = 50;
  model.cy = 40;
  const CameraModel p = perturbedIntrinsics(model, e);
  EXPECT_DOUBLE_EQ(p.fx, 101);
  EXPECT_DOUBLE_EQ(p.fy, 99);
  EXPECT_DOUBLE_EQ(p.cx, 51);
  EXPECT_DOUBLE_EQ(p.cy, 40);
  EXPECT_EQ(p.width, 100);
}

Scenario library(const std::string& name, const std::vector<std::string>& overrides) {
  auto path = resolveScenario(name);
  EXPECT_TRUE(path.isOk()) << path.status().toString();
  auto scenario = loadScenario(*path, overrides);
  EXPECT_TRUE(scenario.isOk()) << scenario.status().toString();
  return std::move(scenario).value();
}

std::vector<std::string> smallLeftCamera(std::vector<std::string> extra) {
  for (const char* o : {"sensors.camera_left.width=160", "sensors.camera_left.height=120",
                        "sensors.camera_left.fx=150", "sensors.camera_left.fy=150",
                        "sensors.camera_right.enabled=false", "sensors.tof.enabled=false"})
    extra.push_back(o);
  return extra;
}

TEST(CalibrationError, TheSimulatorPublishesPerturbedCalibrationsAndKeepsTheTruth) {
  const std::vector<std::string> errors = {"calibration_error.extrinsic_angle_deg=0.2",
                                           "calibration_error.extrinsic_position=0.002",
                                           "calibration_error.intrinsics_fraction=0.005"};
  const Scenario with = library("mid_range_approach", smallLeftCamera(errors));
  const Scenario without = library("mid_range_approach", smallLeftCamera({}));
  MemorySink a, b;
  auto sim_a = Simulator::create(with, 5, 0.25);
  auto sim_b = Simulator::create(without, 5, 0.25);
  ASSERT_OK(sim_a.status());
  ASSERT_OK(sim_b.status());
  ASSERT_OK((*sim_a)->run(a));
  ASSERT_OK((*sim_b)->run(b));

  // Published: the true mounting moved by the sensor's drawn error.
  const SensorConfig& lidar = *with.sensor("lidar");
  const SensorCalibrationError e = drawCalibrationError(with.calibration_error, 5, "lidar");
  const auto tf = a.on<Transform>("/chaser/tf/lidar");
  ASSERT_EQ(tf.size(), 1u);
  const Eigen::Isometry3d expected = perturbedMounting(lidar.servicerTframe(), e);
  EXPECT_LT((tf[0].isometry().matrix() - expected.matrix()).norm(), 1e-12);
  const auto truth_tf = a.on<Transform>("/truth/tf/lidar");
  ASSERT_EQ(truth_tf.size(), 1u);
  EXPECT_LT((truth_tf[0].isometry().matrix() - lidar.servicerTframe().matrix()).norm(), 1e-12);
  EXPECT_GT((tf[0].isometry().matrix() - lidar.servicerTframe().matrix()).norm(), 1e-5);

  // The camera's intrinsics: on its calibration channel and on its images.
  const CameraModel truth = with.sensor("camera_left")->camera.model;
  const auto info = a.on<CameraInfo>("/chaser/camera/left/calibration");
  const auto images = a.on<Image>("/chaser/camera/left/image");
  ASSERT_FALSE(info.empty());
  ASSERT_FALSE(images.empty());
  const CameraModel published =
      perturbedIntrinsics(truth, drawCalibrationError(with.calibration_error, 5, "camera_left"));
  EXPECT_DOUBLE_EQ(info[0].model.fx, published.fx);
  EXPECT_NE(info[0].model.fx, truth.fx);
  EXPECT_DOUBLE_EQ(images[0].camera->cy, published.cy);
  const auto truth_info = a.on<CameraInfo>("/truth/camera_left/calibration");
  ASSERT_EQ(truth_info.size(), 1u);
  EXPECT_EQ(truth_info[0].model.fx, truth.fx);

  // Rendered and cast with the true calibration: the same scans and images as without the error,
  // the same truth.
  const auto scans_a = a.on<PointCloud>("/chaser/lidar/points");
  const auto scans_b = b.on<PointCloud>("/chaser/lidar/points");
  ASSERT_EQ(scans_a.size(), scans_b.size());
  ASSERT_FALSE(scans_a.empty());
  ASSERT_EQ(scans_a[0].size(), scans_b[0].size());
  for (std::size_t i = 0; i < scans_a[0].size(); ++i)
    ASSERT_EQ(scans_a[0].points[i].x, scans_b[0].points[i].x);
  const auto images_b = b.on<Image>("/chaser/camera/left/image");
  ASSERT_EQ(images_b.size(), images.size());
  EXPECT_TRUE(
      std::equal(images[0].pixels.begin(), images[0].pixels.end(), images_b[0].pixels.begin()));
  const auto truth_a = a.on<PoseWithCovariance>("/truth/lidar/target_pose");
  const auto truth_b = b.on<PoseWithCovariance>("/truth/lidar/target_pose");
  ASSERT_EQ(truth_a.size(), truth_b.size());
  EXPECT_EQ(truth_a[0].pose.translation, truth_b[0].pose.translation);
  // Without the error, no truth calibration channels and the true mounting published.
  EXPECT_EQ(b.count("/truth/tf/lidar"), 0u);
  EXPECT_LT(
      (b.on<Transform>("/chaser/tf/lidar")[0].isometry().matrix() - lidar.servicerTframe().matrix())
          .norm(),
      1e-12);
}

TEST(CalibrationError, BadSizesAndUnknownSensorsAreRefused) {
  auto path = resolveScenario("mid_range_approach");
  ASSERT_OK(path.status());
  auto refused = [&](const std::string& set, const std::string& fragment) {
    auto s = loadScenario(*path, {set});
    ASSERT_FALSE(s.isOk()) << set;
    EXPECT_NE(s.status().message().find(fragment), std::string::npos) << s.status().message();
  };
  refused("calibration_error.extrinsic_angle_deg=-0.2", "extrinsic_angle_deg = -0.2");
  refused("calibration_error.extrinsic_position=.nan", "extrinsic_position");
  refused("calibration_error.intrinsics_fraction=0.7", "intrinsics_fraction = 0.7");
  refused("calibration_error.distribution=uniform", "distribution");
  refused("calibration_error.sensors=[lidar,sonar]", "no sensor 'sonar'");
  auto ok = loadScenario(
      *path, {"calibration_error.sensors=[lidar]", "calibration_error.extrinsic_angle_deg=0.2",
              "calibration_error.seed=3"});
  ASSERT_OK(ok.status());
  EXPECT_TRUE(ok->calibration_error.active());
  EXPECT_EQ(ok->calibration_error.seed, 3u);
  EXPECT_NEAR(ok->calibration_error.extrinsic_angle, 0.2 * kDeg, 1e-15);
}

}  // namespace
}  // namespace cdff::egse
