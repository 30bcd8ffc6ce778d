// Whole runs: every stream is there in order, the truth is consistent, runs are deterministic,
// and the configured faults show in the data.
#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "cdff/egse/simulator.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

// Small cameras keep the tests fast; everything else is the library scenario.
std::vector<std::string> smallCameras(std::vector<std::string> extra = {}) {
  for (const char* camera : {"camera_left", "camera_right"}) {
    extra.push_back(fmt::format("sensors.{}.width=320", camera));
    extra.push_back(fmt::format("sensors.{}.height=240", camera));
    extra.push_back(fmt::format("sensors.{}.fx=300", camera));
    extra.push_back(fmt::format("sensors.{}.fy=300", camera));
  }
  return extra;
}

Scenario library(const std::string& name, const std::vector<std::string>& overrides) {
  auto path = resolveScenario(name);
  EXPECT_TRUE(path.isOk()) << path.status().toString();
  auto scenario = loadScenario(*path, overrides);
  EXPECT_TRUE(scenario.isOk()) << scenario.status().toString();
  return std::move(scenario).value();
}

double meanPixel(const Image& image) {
  double sum = 0;
  for (std::uint8_t v : image.pixels.span()) sum += v;
  return sum / image.pixels.size();
}

int maxPixel(const Image& image) {
  int best = 0;
  for (std::uint8_t v : image.pixels.span()) best = std::max<int>(best, v);
  return best;
}

TEST(Simulator, ShortRunHasEveryStreamInLogTimeOrder) {
  const Scenario scenario =
      library("mid_range_approach", smallCameras({"sensors.radar.enabled=true"}));
  auto sim = Simulator::create(scenario, 3, 1.0);
  ASSERT_OK(sim.status());
  MemorySink sink;
  std::vector<double> progress;
  ASSERT_OK((*sim)->run(sink, [&](double t, double) { progress.push_back(t); }));
  EXPECT_EQ(sink.metadata().seed, 3u);
  EXPECT_EQ(sink.metadata().renderer.rfind("cpu:", 0), 0u) << sink.metadata().renderer;
  EXPECT_NE(sink.metadata().scenario_yaml.find("radar"), std::string::npos);
  // 1 s: cameras, LIDAR and ToF at 10 Hz (t = 0 .. 0.9 and 1.0), IMU at 120 Hz, truth at 50 Hz.
  EXPECT_EQ(sink.count("/chaser/camera/left/image"), 11u);
  EXPECT_EQ(sink.count("/chaser/camera/right/image"), 11u);
  EXPECT_EQ(sink.count("/chaser/camera/left/calibration"), 11u);
  EXPECT_EQ(sink.count("/chaser/lidar/points"), 11u);
  EXPECT_EQ(sink.count("/chaser/tof/depth"), 11u);
  EXPECT_EQ(sink.count("/chaser/imu"), 121u);
  EXPECT_EQ(sink.count("/chaser/radar/range"), 2u);
  EXPECT_EQ(sink.count("/truth/target_pose"), 51u);
  EXPECT_EQ(sink.count("/truth/target_state"), 51u);
  ASSERT_EQ(sink.count("/truth/target_mesh"), 1u);
  EXPECT_EQ(sink.on<TriangleMesh>("/truth/target_mesh")[0].frame_id, "target");
  EXPECT_EQ(sink.count("/truth/camera_left/target_pose"), 11u);
  std::size_t mounts = 0;
  for (const SimMessage& m : sink.messages()) mounts += m.channel.rfind("/chaser/tf/", 0) == 0;
  EXPECT_EQ(mounts, 6u);
  EXPECT_EQ(sink.count("/chaser/tf/camera_left_optical"), 1u);
  Timestamp last = -1;
  for (const SimMessage& m : sink.messages()) {
    EXPECT_GE(m.log_time, last) << m.channel;
    last = m.log_time;
  }
  ASSERT_FALSE(progress.empty());
  EXPECT_DOUBLE_EQ(progress.back(), 1.0);
  // The images are what the camera model says: size, format, frame and calibration.
  const auto images = sink.on<Image>("/chaser/camera/left/image");
  EXPECT_EQ(images[3].width, 320);
  EXPECT_EQ(images[3].format, PixelFormat::kGray8);
  EXPECT_EQ(images[3].frame_id, "camera_left_optical");
  EXPECT_EQ(images[3].stamp, 300000);
  ASSERT_TRUE(images[3].camera.has_value());
  EXPECT_EQ(images[3].camera->fx, 300.0);
  EXPECT_GT(maxPixel(images[3]), 60) << "the target is in view and lit";
  const auto clouds = sink.on<PointCloud>("/chaser/lidar/points");
  EXPECT_GT(clouds[0].size(), 20u)
      << "a VLP-16's beams are 2 degrees apart: at 17 m a few dozen hit";
  EXPECT_EQ(clouds[0].frame_id, "lidar");
  ASSERT_OK(clouds[0].validate());
  // Each scan comes just after the LIDAR's description, of the same stamp and frame: the
  // scenario's lasers (the VLP-16's, in firing order), rate, range limits and noise.
  ASSERT_EQ(sink.count("/chaser/lidar/info"), 11u);
  for (std::size_t k = 1; k < sink.messages().size(); ++k) {
    const SimMessage& m = sink.messages()[k];
    if (m.channel != "/chaser/lidar/points") continue;
    const SimMessage& before = sink.messages()[k - 1];
    ASSERT_EQ(before.channel, "/chaser/lidar/info") << "at log time " << m.log_time;
    EXPECT_EQ(std::get<LidarInfo>(before.payload).stamp, std::get<PointCloud>(m.payload).stamp);
  }
  const LidarInfo info = sink.on<LidarInfo>("/chaser/lidar/info")[0];
  ASSERT_OK(info.validate());
  EXPECT_EQ(info.frame_id, "lidar");
  EXPECT_EQ(info.elevations, LidarSpec::vlp16().elevations);
  EXPECT_EQ(info.rotation_rate, 10.0);
  EXPECT_EQ(info.min_range, 0.5);
  EXPECT_EQ(info.max_range, 100.0);
  EXPECT_EQ(info.range_noise, 0.03);
  const auto ranges = sink.on<RangeMeasurement>("/chaser/radar/range");
  ASSERT_TRUE(ranges[0].valid);
  EXPECT_NEAR(ranges[0].range, 17.0 - 0.45 - 0.72, 1.0);
}

TEST(Simulator, TheAhrsReportsTheServicerAttitudeWithItsNoise) {
  // Off by default; on, it reports eci_T_servicer (attitude only) with 0.2 deg per axis.
  EXPECT_EQ(library("tumbling_target", {}).sensor("ahrs")->enabled, false);
  const double sigma = 0.0035;
  const Scenario scenario = library(
      "tumbling_target", {"sensors.ahrs.enabled=true", "sensors.ahrs.rate=20",
                          "sensors.camera_left.enabled=false", "sensors.camera_right.enabled=false",
                          "sensors.lidar.enabled=false", "sensors.tof.enabled=false"});
  auto sim = Simulator::create(scenario, 5, 10.0);
  ASSERT_OK(sim.status());
  MemorySink sink;
  ASSERT_OK((*sim)->run(sink));
  std::map<Timestamp, Transform> lvlh, servicer;
  for (const SimMessage& m : sink.messages()) {
    if (m.channel == "/truth/tf/lvlh") lvlh[m.log_time] = std::get<Transform>(m.payload);
    if (m.channel == "/truth/tf/servicer") servicer[m.log_time] = std::get<Transform>(m.payload);
  }
  const auto samples = sink.on<PoseWithCovariance>("/chaser/ahrs/attitude");
  EXPECT_EQ(samples.size(), 201u);
  double sum_sq = 0;
  std::size_t compared = 0;
  for (const PoseWithCovariance& a : samples) {
    EXPECT_EQ(a.pose.parent_frame, "eci");
    EXPECT_EQ(a.pose.child_frame, "servicer");
    EXPECT_NEAR(a.covariance(3, 3), sigma * sigma, 1e-15);
    EXPECT_EQ(a.covariance(0, 0), 0.0);
    if (!lvlh.count(a.pose.stamp) || !servicer.count(a.pose.stamp)) continue;
    const Eigen::Quaterniond truth =
        lvlh.at(a.pose.stamp).rotation * servicer.at(a.pose.stamp).rotation;
    sum_sq += logSO3(a.pose.rotation * truth.conjugate()).squaredNorm();
    ++compared;
  }
  ASSERT_GE(compared, 90u);
  // The per-axis RMS of the attitude error is the configured sigma (within the sampling spread
  // of ~300 values, about 4 %).
  const double rms_per_axis = std::sqrt(sum_sq / (3.0 * static_cast<double>(compared)));
  EXPECT_GT(rms_per_axis, 0.85 * sigma);
  EXPECT_LT(rms_per_axis, 1.15 * sigma);
}

TEST(Simulator, FarRangeSensorsJitterTheAttitudeAndLoseRadarMeasurements) {
  // far_range_approach: the AHRS in the orbital frame (lvlh_T_servicer, 5 arcsec), 0.01 deg RMS
  // of pointing jitter, 5 % of the radar's measurements lost. Without jitter the target-pointing
  // attitude is smooth; with it, the AHRS (noise off) differs from the smooth one by the jitter.
  const std::vector<std::string> common = {"sensors.camera_far.enabled=false",
                                           "sensors.ahrs.noise=false", "sensors.radar.rate=20"};
  auto run = [&](const std::vector<std::string>& extra) {
    std::vector<std::string> o = common;
    o.insert(o.end(), extra.begin(), extra.end());
    auto sim = Simulator::create(library("far_range_approach", o), 3, 60.0);
    EXPECT_TRUE(sim.isOk()) << sim.status().toString();
    MemorySink sink;
    EXPECT_TRUE((*sim)->run(sink).isOk());
    return sink;
  };
  const MemorySink jittered = run({});
  const MemorySink smooth = run({"servicer.attitude.jitter_deg=0"});
  const auto a = jittered.on<PoseWithCovariance>("/chaser/ahrs/attitude");
  const auto b = smooth.on<PoseWithCovariance>("/chaser/ahrs/attitude");
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 500u);
  double sum_sq = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].pose.parent_frame, "lvlh");
    sum_sq += logSO3(b[i].pose.rotation.conjugate() * a[i].pose.rotation).squaredNorm();
  }
  // RMS per axis within the spread of three sinusoids per axis over a minute (about 30 %).
  const double rms = std::sqrt(sum_sq / (3.0 * static_cast<double>(a.size())));
  EXPECT_GT(rms, 0.6 * 0.01 * M_PI / 180);
  EXPECT_LT(rms, 1.4 * 0.01 * M_PI / 180);
  // Radar: about 5 % of 1 201 measurements lost (binomial sigma 0.6 %).
  std::size_t lost = 0, all = 0;
  for (const RangeMeasurement& m : jittered.on<RangeMeasurement>("/chaser/radar/range")) {
    ++all;
    lost += m.valid ? 0 : 1;
  }
  ASSERT_GT(all, 1000u);
  EXPECT_NEAR(static_cast<double>(lost) / static_cast<double>(all), 0.05, 0.02);
}

TEST(Simulator, ASensorMeasuresOnlyWithinItsActiveRange) {
  // far_range_approach's first minute closes from 2000 m to about 1996 m; the radar is switched
  // on between 1997 and 1999 m only, and measures at the truth's times (both 10 Hz).
  const std::vector<std::string> o = {"sensors.camera_far.enabled=false", "sensors.radar.rate=10",
                                      "sensors.radar.dropout_probability=0",
                                      "sensors.radar.active_range=[1997, 1999]"};
  auto sim = Simulator::create(library("far_range_approach", o), 3, 60.0);
  ASSERT_TRUE(sim.isOk()) << sim.status().toString();
  MemorySink sink;
  ASSERT_TRUE((*sim)->run(sink).isOk());
  std::map<Timestamp, double> truth_range;
  std::size_t in_band = 0;
  for (const PoseWithCovariance& p : sink.on<PoseWithCovariance>("/truth/target_pose")) {
    const double range = p.pose.translation.norm();
    truth_range[p.pose.stamp] = range;
    in_band += range >= 1997 && range <= 1999;
  }
  const auto radar = sink.on<RangeMeasurement>("/chaser/radar/range");
  ASSERT_GT(in_band, 10u);
  EXPECT_EQ(radar.size(), in_band);
  for (const RangeMeasurement& m : radar) {
    ASSERT_TRUE(truth_range.count(m.stamp)) << m.stamp;
    EXPECT_GE(truth_range[m.stamp], 1997.0);
    EXPECT_LE(truth_range[m.stamp], 1999.0);
  }
  // Bad input: a band whose minimum is not below its maximum names the key and the values.
  auto bad =
      loadScenario(*resolveScenario("far_range_approach"), {"sensors.radar.active_range=[20, 10]"});
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find("active_range"), std::string::npos)
      << bad.status().message();
  EXPECT_NE(bad.status().message().find("min is not below max"), std::string::npos);
}

TEST(Simulator, TruthTransformsAreConsistent) {
  const Scenario scenario = library("tumbling_target", smallCameras());
  auto sim = Simulator::create(scenario, 1, 0.5);
  ASSERT_OK(sim.status());
  MemorySink sink;
  ASSERT_OK((*sim)->run(sink));
  std::map<Timestamp, RigidBodyState> servicer_truth;
  for (const auto& s : sink.on<RigidBodyState>("/truth/target_state"))
    servicer_truth[s.pose.stamp] = s;
  // The pose channel holds the same transform as the state channel, for the evaluation.
  const auto poses = sink.on<PoseWithCovariance>("/truth/target_pose");
  ASSERT_EQ(poses.size(), servicer_truth.size());
  for (const auto& p : poses) {
    EXPECT_EQ(p.pose.parent_frame, "servicer");
    EXPECT_EQ(p.pose.child_frame, "target");
    EXPECT_LT(
        (p.pose.isometry().matrix() - servicer_truth.at(p.pose.stamp).pose.isometry().matrix())
            .norm(),
        1e-12);
  }
  std::map<std::string, Transform> mounts;
  for (const SimMessage& m : sink.messages())
    if (m.channel.rfind("/chaser/tf/", 0) == 0) {
      const Transform& t = std::get<Transform>(m.payload);
      EXPECT_EQ(m.channel, "/chaser/tf/" + t.child_frame);
      mounts[t.child_frame] = t;
    }
  ASSERT_TRUE(mounts.count("camera_left_optical"));
  std::size_t checked = 0;
  for (const auto& s : sink.on<PoseWithCovariance>("/truth/camera_left/target_pose")) {
    auto it = servicer_truth.find(s.pose.stamp);
    if (it == servicer_truth.end()) continue;
    // camera_T_target = (servicer_T_camera)^-1 servicer_T_target.
    const Eigen::Isometry3d expected =
        mounts["camera_left_optical"].isometry().inverse() * it->second.pose.isometry();
    EXPECT_LT((s.pose.isometry().matrix() - expected.matrix()).norm(), 1e-9);
    EXPECT_EQ(s.pose.parent_frame, "camera_left_optical");
    EXPECT_EQ(s.pose.child_frame, "target");
    ++checked;
  }
  EXPECT_GE(checked, 5u);
  // /tf: lvlh_T_servicer^-1 lvlh_T_target = servicer_T_target; the tumbling target turns at 5
  // deg/s.
  std::map<Timestamp, std::map<std::string, Transform>> tf;
  for (const char* channel : {"/truth/tf/servicer", "/truth/tf/target", "/truth/tf/lvlh"})
    for (const auto& t : sink.on<Transform>(channel)) tf[t.stamp][t.child_frame] = t;
  for (const auto& [stamp, frames] : tf) {
    const Eigen::Isometry3d s_T_t =
        frames.at("servicer").isometry().inverse() * frames.at("target").isometry();
    EXPECT_LT((s_T_t.matrix() - servicer_truth.at(stamp).pose.isometry().matrix()).norm(), 1e-9);
    EXPECT_TRUE(frames.count("lvlh")) << "eci_T_lvlh with an orbit";
  }
  const double rate = servicer_truth.begin()->second.twist.angular.norm() * 180 / M_PI;
  EXPECT_GT(rate, 4.5);  // the target's 5 deg/s, give or take the servicer's own turning
  EXPECT_LT(rate, 5.5);
}

TEST(Simulator, SameSeedGivesIdenticalOutputAndAnotherSeedDoesNot) {
  const Scenario scenario = library("sensor_faults", smallCameras());
  std::uint64_t digests[3];
  const std::uint64_t seeds[3] = {11, 11, 12};
  for (int i = 0; i < 3; ++i) {
    auto sim = Simulator::create(scenario, seeds[i], 0.6);
    ASSERT_OK(sim.status());
    DigestSink sink;
    ASSERT_OK((*sim)->run(sink));
    EXPECT_GT(sink.messages(), 100u);
    digests[i] = sink.digest();
  }
  EXPECT_EQ(digests[0], digests[1]);
  EXPECT_NE(digests[0], digests[2]);
}

TEST(Simulator, FaultsShowInTheData) {
  // The fault scenario, with its windows moved close together to keep the run short.
  const Scenario scenario = library(
      "sensor_faults",
      smallCameras(
          {"sensors.tof.enabled=false", "faults.0.start=0.5",
           "faults.0.end=1.5",                               // camera_right dark
           "faults.1.start=1.5",        "faults.1.end=2.0",  // camera_left glare
           "faults.2.start=2.0",        "faults.2.end=2.5",  // occlusion 25 %
           "faults.3.start=2.5",        "faults.3.end=3.0",  // 50 %
           "faults.4.start=3.0",        "faults.4.end=3.5",  // 75 % (shadow)
           "faults.5.start=3.5",        "faults.5.end=6.5",  // dropped frames, 30 %
           "faults.6.start=6.5",        "faults.6.end=9.5",  // late frames, 50 %, 0.25 s
           "faults.7.start=0.0",        "faults.7.end=1.0",  // LIDAR dropouts, 50 %
           "faults.8.start=1.0",        "faults.8.end=2.0",  // LIDAR spurious returns, 300 per scan
           "faults.9.time=5.0",                              // IMU bias jump
           "sensors.imu.noise=false"}));                     // (seen exactly without the noise)
  auto sim = Simulator::create(scenario, 5, 10.0);
  ASSERT_OK(sim.status());
  MemorySink sink;
  ASSERT_OK((*sim)->run(sink));
  auto in = [](Timestamp stamp, double a, double b) {
    return stamp >= fromSeconds(a) && stamp < fromSeconds(b);
  };

  // Camera failure: the right camera is dark (read noise only) while the left one is not.
  const auto right = sink.on<Image>("/chaser/camera/right/image");
  for (const Image& image : right) {
    if (in(image.stamp, 0.5, 1.5)) {
      EXPECT_LE(maxPixel(image), 2);
    } else if (image.stamp < fromSeconds(2.0)) {
      EXPECT_GT(maxPixel(image), 20);
    }
  }
  // Glare brightens the left image.
  const auto left = sink.on<Image>("/chaser/camera/left/image");
  double glare = 0, clear = 0;
  for (const Image& image : left) {
    if (in(image.stamp, 1.5, 2.0)) glare = std::max(glare, meanPixel(image));
    if (in(image.stamp, 0.5, 1.5)) clear = std::max(clear, meanPixel(image));
  }
  EXPECT_GT(glare, clear + 20.0);
  // Occlusion: the recorded fractions are the seed's 25 / 50 / 75 %.
  std::vector<double> fractions;
  for (const FaultEvent& e : sink.on<FaultEvent>("/truth/faults"))
    if (e.fault == "occlusion" && e.sensor == "camera_left")
      fractions.push_back(std::stod(e.detail));
  ASSERT_EQ(fractions.size(), 15u);
  for (std::size_t i = 0; i < fractions.size(); ++i)
    EXPECT_NEAR(fractions[i], 0.25 * (1 + i / 5), 0.01);
  // Dropped frames: about 30 % of the 30 frames in the window are missing.
  std::size_t kept = 0;
  for (const Image& image : left) kept += in(image.stamp, 3.5, 6.5);
  EXPECT_GE(kept, 12u);
  EXPECT_LE(kept, 28u);
  // Late frames: some arrive 0.25 s after their stamp, out of order with the other streams.
  std::size_t late = 0;
  for (const SimMessage& m : sink.messages())
    if (m.channel == "/chaser/camera/left/image") {
      const Timestamp stamp = std::get<Image>(m.payload).stamp;
      if (m.log_time - stamp == 250000)
        ++late;
      else
        EXPECT_EQ(m.log_time, stamp);
    }
  EXPECT_GE(late, 7u);
  EXPECT_LE(late, 23u);
  // LIDAR: half the points dropped, then spurious returns added.
  const auto clouds = sink.on<PointCloud>("/chaser/lidar/points");
  double dropout = 0, normal = 0, spurious = 0;
  int nd = 0, nn = 0, ns = 0;
  for (const PointCloud& c : clouds) {
    if (in(c.stamp, 0.0, 1.0))
      dropout += c.size(), ++nd;
    else if (in(c.stamp, 1.0, 2.0))
      spurious += c.size(), ++ns;
    else if (in(c.stamp, 2.0, 3.0))
      normal += c.size(), ++nn;
  }
  EXPECT_NEAR(dropout / nd / (normal / nn), 0.5, 0.1);
  EXPECT_NEAR(spurious / ns - normal / nn, 300.0, 60.0);
  // IMU bias jump at 5 s: from one sample to the next the gyro jumps by [0.5, 0, -0.3] deg/s and
  // the accelerometer by [0, 0.05, 0] m/s^2 (in the IMU frame); the motion itself changes the
  // readings by far less in 1/120 s.
  const auto imu = sink.on<ImuSample>("/chaser/imu");
  for (std::size_t i = 1; i < imu.size(); ++i) {
    const Eigen::Vector3d dw = (imu[i].angular_velocity - imu[i - 1].angular_velocity) * 180 / M_PI;
    const Eigen::Vector3d da = imu[i].linear_acceleration - imu[i - 1].linear_acceleration;
    if (imu[i - 1].stamp < fromSeconds(5.0) && imu[i].stamp >= fromSeconds(5.0)) {
      EXPECT_LT((dw - Eigen::Vector3d(0.5, 0, -0.3)).norm(), 1e-3);
      EXPECT_LT((da - Eigen::Vector3d(0, 0.05, 0)).norm(), 1e-3);
    } else {
      EXPECT_LT(dw.norm(), 1e-3);
    }
  }
}

TEST(Simulator, OcclusionHidesThatShareOfTheTargetInTheImages) {
  // Only the occlusion faults, on the left camera, front-lit. The occluder covers the target
  // from the image's left: the target's pixels (finite truth depth: the target, or the occluder
  // in front of it) left of the first lit target pixel must be about 25 / 50 / 75 % of them,
  // and about none in the clear frames before.
  std::vector<std::string> overrides =
      smallCameras({"lighting.sun.preset=front_lit", "truth.camera_depth=true",
                    "sensors.camera_right.enabled=false", "sensors.lidar.enabled=false",
                    "sensors.tof.enabled=false", "sensors.imu.enabled=false", "faults.2.start=0.5",
                    "faults.2.end=1.0", "faults.3.start=1.0", "faults.3.end=1.5",
                    "faults.4.start=1.5", "faults.4.end=2.0"});
  for (int f : {0, 1, 5, 6, 7, 8}) {
    overrides.push_back(fmt::format("faults.{}.start=100", f));
    overrides.push_back(fmt::format("faults.{}.end=101", f));
  }
  overrides.push_back("faults.9.time=100");
  const Scenario scenario = library("sensor_faults", overrides);
  auto sim = Simulator::create(scenario, 2, 2.0);
  ASSERT_OK(sim.status());
  MemorySink sink;
  ASSERT_OK((*sim)->run(sink));
  const auto images = sink.on<Image>("/chaser/camera/left/image");
  const auto depths = sink.on<DepthMap>("/truth/camera_left/depth");
  ASSERT_EQ(images.size(), depths.size());
  std::array<int, 4> frames{};
  for (std::size_t i = 0; i < images.size(); ++i) {
    const Image& image = images[i];
    const Image& depth = depths[i].image;
    ASSERT_EQ(depth.stamp, image.stamp);
    ASSERT_EQ(depth.format, PixelFormat::kFloat32);
    const int quarter = static_cast<int>(toSeconds(image.stamp) / 0.5 + 1e-9);
    if (quarter < 0 || quarter > 3) continue;
    auto on_target = [&](int x, int y) {
      const float d = depth.at<float>(x, y);
      return std::isfinite(d) && d > 0;
    };
    int first_lit = image.width;
    std::vector<std::size_t> per_column(image.width, 0);
    std::size_t target = 0;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) {
        if (!on_target(x, y)) continue;
        ++target;
        ++per_column[x];
        if (image.at<std::uint8_t>(x, y) > 8) first_lit = std::min(first_lit, x);
      }
    ASSERT_GT(target, 200u) << "the target is in view";
    std::size_t hidden = 0;
    for (int x = 0; x < first_lit; ++x) hidden += per_column[x];
    const double share = static_cast<double>(hidden) / static_cast<double>(target);
    RecordProperty(fmt::format("hidden_share_{}", i), std::to_string(share));
    EXPECT_NEAR(share, 0.25 * quarter, 0.05)
        << "t = " << toSeconds(image.stamp) << " s: " << 25 * quarter << " % hidden";
    ++frames[quarter];
  }
  for (int q = 0; q <= 3; ++q) EXPECT_EQ(frames[q], 5);
}

TEST(Simulator, TheTargetLeavesTheFieldOfView) {
  const Scenario scenario =
      library("leaving_field_of_view",
              smallCameras({"truth.camera_depth=true", "sensors.lidar.enabled=false",
                            "sensors.tof.enabled=false", "sensors.camera_right.enabled=false"}));
  auto sim = Simulator::create(scenario, 1);
  ASSERT_OK(sim.status());
  MemorySink sink;
  ASSERT_OK((*sim)->run(sink));
  auto coverage = [](const DepthMap& d) {
    const float* z = reinterpret_cast<const float*>(d.image.pixels.data());
    std::size_t n = 0;
    for (int i = 0; i < d.image.width * d.image.height; ++i) n += z[i] > 0;
    return static_cast<double>(n) / (d.image.width * d.image.height);
  };
  const auto depth = sink.on<DepthMap>("/truth/camera_left/depth");
  ASSERT_EQ(depth.size(), 451u);
  EXPECT_GT(coverage(depth[0]), 0.01);     // in view at the start
  EXPECT_GT(coverage(depth[200]), 0.01);   // crossing
  EXPECT_EQ(coverage(depth.back()), 0.0);  // gone at the end
}

}  // namespace
}  // namespace cdff::egse
