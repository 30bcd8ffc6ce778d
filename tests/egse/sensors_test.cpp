// LIDAR, ToF and radar against brute-force ray casting of the model at the truth pose.
#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "cdff/egse/procedural.hpp"
#include "cdff/egse/range_sensors.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

// Nearest intersection by testing every triangle (Moller-Trumbore): independent of Embree.
std::optional<double> bruteForceRay(const TargetModel& model, const Eigen::Vector3d& o,
                                    const Eigen::Vector3d& d) {
  std::optional<double> best;
  for (const auto& t : model.mesh.triangles) {
    const Eigen::Vector3d a = model.mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d e1 = model.mesh.vertices[t[1]].cast<double>() - a;
    const Eigen::Vector3d e2 = model.mesh.vertices[t[2]].cast<double>() - a;
    const Eigen::Vector3d p = d.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-14) continue;
    const Eigen::Vector3d s = o - a;
    const double u = s.dot(p) / det;
    if (u < 0 || u > 1) continue;
    const Eigen::Vector3d q = s.cross(e1);
    const double v = d.dot(q) / det;
    if (v < 0 || u + v > 1) continue;
    const double dist = e2.dot(q) / det;
    if (dist > 0 && (!best || dist < *best)) best = dist;
  }
  return best;
}

TargetModel target() {
  return std::move(makeTargetSatellite()).value();
}

// A target 6 m ahead of the LIDAR, tilted; optionally tumbling at `rate` rad/s about an oblique
// axis and drifting at `speed` m/s sideways.
RelativePose movingTarget(double rate, double speed) {
  return [rate, speed](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(rate * t, Eigen::Vector3d(0.3, 0.5, 1).normalized()) *
                  Eigen::AngleAxisd(2.4, Eigen::Vector3d::UnitZ()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(6.0, speed * t - 0.2, 0.3);
    return T;
  };
}

TEST(Lidar, Vlp16PatternTimingAndRings) {
  // Inside a 40 m box every beam returns: the full pattern is visible.
  ModelBuilder b("room");
  b.addBox(Eigen::Isometry3d::Identity(), {20, 20, 20}, b.material(MaterialId::kRadiator));
  const TargetModel room = b.build();
  auto caster = RayCaster::create(room);
  ASSERT_OK(caster.status());
  LidarSpec spec = LidarSpec::vlp16();
  spec.range_noise = 0;
  auto lidar = LidarSensor::create(spec, "lidar");
  ASSERT_OK(lidar.status());
  Rng rng(1);
  auto cloud = lidar->scan(
      **caster, room, [](double) { return Eigen::Isometry3d::Identity(); }, 0.0, {}, rng);
  ASSERT_OK(cloud.status());
  // 100 ms / 55.296 us = 1808 firing sequences of 16 lasers: ~28.9k points per revolution.
  EXPECT_EQ(cloud->size(), 1808u * 16u);
  ASSERT_OK(cloud->validate());
  std::map<int, int> per_ring;
  std::int32_t last = -1;
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    const Eigen::Vector3f p = cloud->points[i].vec();
    const int ring = cloud->ring[i];
    ++per_ring[ring];
    // Ring r is the r-th lowest beam: elevation -15 + 2 r degrees.
    const double elevation = std::atan2(p.z(), std::hypot(p.x(), p.y())) * 180 / M_PI;
    EXPECT_NEAR(elevation, -15.0 + 2 * ring, 1e-3);
    EXPECT_GE(cloud->time_offset_us[i], last);
    last = cloud->time_offset_us[i];
  }
  EXPECT_EQ(per_ring.size(), 16u);
  for (const auto& [ring, count] : per_ring) EXPECT_EQ(count, 1808);
  EXPECT_LT(cloud->time_offset_us[cloud->size() - 1], 100000);
  // Azimuth step between two sequences of one laser: 0.2 degrees at 10 Hz.
  const Eigen::Vector3f a = cloud->points[0].vec(), c = cloud->points[16].vec();
  const double step =
      std::acos(a.head<2>().normalized().dot(c.head<2>().normalized())) * 180 / M_PI;
  EXPECT_NEAR(step, 0.199, 0.001);
  // Azimuth turns clockwise seen from above: from +x towards -y.
  EXPECT_LT(c.y(), 0.0f);
}

TEST(Lidar, PointsLieOnTheModelAtTheTruthPoseWithinTheNoise) {
  const TargetModel model = target();
  auto caster = RayCaster::create(model);
  ASSERT_OK(caster.status());
  for (double sigma : {0.0, 0.03}) {
    LidarSpec spec = LidarSpec::vlp16();
    spec.range_noise = sigma;
    auto lidar = LidarSensor::create(spec, "lidar");
    const RelativePose pose = movingTarget(0.0, 0.0);
    Rng rng(7);
    auto cloud = lidar->scan(**caster, model, pose, 0.0, {}, rng);
    ASSERT_OK(cloud.status());
    ASSERT_GT(cloud->size(), 300u);
    const Eigen::Isometry3d target_T_sensor = pose(0).inverse();
    double sum = 0, sum2 = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < cloud->size(); i += 3) {
      const Eigen::Vector3d p = cloud->points[i].vec().cast<double>();
      const Eigen::Vector3d d = (target_T_sensor.linear() * p).normalized();
      const auto truth = bruteForceRay(model, target_T_sensor.translation(), d);
      ASSERT_TRUE(truth.has_value()) << "point " << i << " is not on the target";
      const double error = p.norm() - *truth;
      sum += error;
      sum2 += error * error;
      ++n;
    }
    const double mean = sum / n, rms = std::sqrt(sum2 / n);
    RecordProperty(fmt::format("range_error_rms_sigma_{}", sigma), fmt::format("{:.3g}", rms));
    if (sigma == 0) {
      EXPECT_LT(rms, 1e-5);
    } else {
      EXPECT_NEAR(mean, 0.0, 4 * sigma / std::sqrt(n));
      EXPECT_NEAR(rms, sigma, 0.15 * sigma);
    }
  }
}

TEST(Lidar, PointsFollowTheTargetDuringTheScan) {
  // 60 deg/s tumbling and 2 m/s drift: over the 100 ms scan the target turns 6 degrees and moves
  // 20 cm, so a scan assembled at one pose would be visibly smeared.
  const TargetModel model = target();
  auto caster = RayCaster::create(model);
  LidarSpec spec = LidarSpec::vlp16();
  spec.range_noise = 0;
  auto lidar = LidarSensor::create(spec, "lidar");
  const RelativePose pose = movingTarget(60.0 * M_PI / 180.0, 2.0);
  Rng rng(2);
  const double start = 3.0;
  auto cloud = lidar->scan(**caster, model, pose, start, {}, rng);
  ASSERT_OK(cloud.status());
  ASSERT_GT(cloud->size(), 300u);
  std::size_t on_surface = 0, off_at_start_pose = 0, n = 0;
  for (std::size_t i = 0; i < cloud->size(); i += 3, ++n) {
    const double t = start + cloud->time_offset_us[i] * 1e-6;
    const Eigen::Vector3d p = cloud->points[i].vec().cast<double>();
    for (int which = 0; which < 2; ++which) {
      const Eigen::Isometry3d target_T_sensor = pose(which == 0 ? t : start).inverse();
      const Eigen::Vector3d d = (target_T_sensor.linear() * p).normalized();
      const auto truth = bruteForceRay(model, target_T_sensor.translation(), d);
      const double error = truth ? std::abs(p.norm() - *truth) : 1e9;
      if (which == 0)
        on_surface += error < 2e-4;  // the keyframe interpolation: ~1e-5 m
      else
        off_at_start_pose += error > 0.01;
    }
  }
  EXPECT_EQ(on_surface, n) << "every point is on the target at its own time";
  EXPECT_GT(static_cast<double>(off_at_start_pose) / n, 0.5) << "but not at the scan's start";
}

TEST(Lidar, DropoutsAndSpuriousReturns) {
  const TargetModel model = target();
  auto caster = RayCaster::create(model);
  LidarSpec spec = LidarSpec::vlp16();
  auto lidar = LidarSensor::create(spec, "lidar");
  Rng rng(3);
  const std::size_t full = lidar->scan(**caster, model, movingTarget(0, 0), 0.0, {}, rng)->size();
  Rng rng2(3);
  LidarFaults faults;
  faults.extra_dropout = 0.4;
  const std::size_t kept =
      lidar->scan(**caster, model, movingTarget(0, 0), 0.0, faults, rng2)->size();
  EXPECT_NEAR(static_cast<double>(kept) / full, 0.6, 4 * std::sqrt(0.24 / full));
  // Spurious returns anywhere in the pattern, at ranges up to 100 m.
  Rng rng3(4);
  faults = {};
  faults.extra_spurious = 400;
  auto noisy = lidar->scan(**caster, model, movingTarget(0, 0), 0.0, faults, rng3);
  ASSERT_OK(noisy.status());
  EXPECT_NEAR(static_cast<double>(noisy->size() - full), 400.0, 5 * 20.0);
  std::size_t far = 0;
  for (const auto& p : noisy->points.span()) far += p.vec().norm() > 20.0f;
  EXPECT_GT(far, 200u);
  LidarSpec bad = spec;
  bad.dropout_probability = 1.5;
  EXPECT_FALSE(LidarSensor::create(bad, "lidar").isOk());
}

TEST(Tof, DepthIsThePlaneDistanceWithTheConfiguredNoise) {
  ModelBuilder b("plate");
  b.addPolygon({{-3, -3, 0}, {3, -3, 0}, {3, 3, 0}, {-3, 3, 0}}, b.material(MaterialId::kRadiator));
  const TargetModel plate = b.build();
  auto caster = RayCaster::create(plate);
  Eigen::Isometry3d camera_T_plate = Eigen::Isometry3d::Identity();
  camera_T_plate.linear() =
      Eigen::AngleAxisd(M_PI + 0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  camera_T_plate.translation() = Eigen::Vector3d(0, 0, 2.5);
  for (double constant : {0.0, 0.004}) {
    TofSpec spec = TofSpec::defaults();
    spec.noise_constant = constant;
    spec.noise_quadratic = 0;
    auto tof = TofSensor::create(spec, "tof");
    ASSERT_OK(tof.status());
    Rng rng(5);
    auto depth = tof->capture(**caster, plate, camera_T_plate, 0.0, rng);
    ASSERT_OK(depth.status());
    ASSERT_OK(depth->validate());
    const Eigen::Vector3d n = camera_T_plate.linear().col(2), p0 = camera_T_plate.translation();
    const float* z = reinterpret_cast<const float*>(depth->image.pixels.data());
    double sum2 = 0;
    std::size_t valid = 0;
    for (int y = 0; y < spec.model.height; ++y)
      for (int x = 0; x < spec.model.width; ++x) {
        const float measured = z[y * spec.model.width + x];
        if (measured == 0) continue;
        const Eigen::Vector3d ray((x - spec.model.cx) / spec.model.fx,
                                  (y - spec.model.cy) / spec.model.fy, 1.0);
        const double truth_z = n.dot(p0) / n.dot(ray);
        const double range_error = (measured - truth_z) * ray.norm();
        sum2 += range_error * range_error;
        ++valid;
      }
    ASSERT_GT(valid, 40000u);
    const double rms = std::sqrt(sum2 / valid);
    if (constant == 0)
      EXPECT_LT(rms, 1e-5);
    else
      EXPECT_NEAR(rms, constant, 0.05 * constant);
  }
}

TEST(Radar, RangeAndRangeRateToTheTarget) {
  const TargetModel model = target();
  auto caster = RayCaster::create(model);
  RadarSpec spec;
  spec.range_noise = spec.range_rate_noise = spec.angle_noise = 0;
  // Approaching along the target's -x axis (facing the adapter ring) at 0.5 m/s from 200 m.
  const RelativePose pose = [](double t) {
    Eigen::Isometry3d T =
        Eigen::Isometry3d::Identity();  // the target's -x (aft) face looks at the radar
    T.translation() = Eigen::Vector3d(200.0 - 0.5 * t, 0, 0);
    return T;
  };
  Rng rng(1);
  auto m = measureRadar(spec, **caster, pose, 10.0, rng);
  ASSERT_OK(m.status());
  ASSERT_TRUE(m->valid);
  // The line of sight through the centre hits the adapter ring's hole and the aft deck at x = -0.6.
  EXPECT_NEAR(m->range, 195.0 - 0.6, 1e-3);
  EXPECT_NEAR(m->range_rate, -0.5, 1e-6);
  EXPECT_LT((m->direction - Eigen::Vector3d::UnitX()).norm(), 1e-9);
  // Outside the beam: no detection.
  const RelativePose aside = [](double) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(10, 10, 0);
    return T;
  };
  EXPECT_FALSE(measureRadar(spec, **caster, aside, 0.0, rng)->valid);
}

}  // namespace
}  // namespace cdff::egse
