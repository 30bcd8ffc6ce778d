#pragma once
// The scenes of ScanPosition's tests: the satellite-like target at a range, a random attitude
// and a random direction within the VLP-16's field of view, its scan, its model point cloud and
// a prediction drawn from the covariance it states.

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <random>
#include <string>

#include "ScanPosition.gen.hpp"
#include "cdff/types/mesh.hpp"
#include "support/dfn_testing.hpp"
#include "support/lidar.hpp"

namespace cdff::dfn::scan_position_testing {

inline constexpr double kDeg = M_PI / 180.0;
inline constexpr double kPredictionSigma = 0.3;  // m, per axis
inline constexpr Timestamp kStamp = 5'000'000;

inline std::unique_ptr<ScanPosition> make(const std::string& yaml = "{}") {
  return testing::makeDfn<ScanPosition>("ScanPosition", "VisibleCentroid", yaml);
}

/// The dense model the tests measure with: 20 000 points on the satellite mesh (about 2.6 cm
/// apart), in frame `target`.
inline const PointCloud& satelliteModel() {
  static const PointCloud model = [] {
    Result<PointCloud> cloud = sampleSurface(testing::satelliteMesh(), 20'000, 7);
    EXPECT_TRUE(cloud.isOk()) << cloud.status().toString();
    return std::move(cloud).value();
  }();
  return model;
}

/// R: the model's largest distance from its origin (the tip of a solar wing, about 2.8 m).
inline double modelRadius() {
  return std::sqrt(satelliteModel().xyzMatrix().colwise().squaredNorm().maxCoeff());
}

struct Draw {
  Eigen::Isometry3d truth;  // lidar_T_target, = servicer_T_target (the mounting is identity)
  testing::ScanOptions options;
  PointCloud scan;           // frame lidar, every return on the target
  Eigen::Vector3d centroid;  // of the scan: the naive position
  RigidBodyState prediction;
};

inline Eigen::Quaterniond randomAttitude(std::mt19937& rng) {
  std::normal_distribution<double> n;
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

/// The target at `range` m, azimuth within +-40 deg and elevation within +-5 deg of the
/// sensor's x axis (its top or bottom may leave the +-15 deg field at 15 m), at a uniformly
/// random attitude or, given `los_T_target`, at that attitude relative to the line of sight (x
/// along it, away from the sensor, z up across the rings: the same view from every direction);
/// drawn again until the scan has 5 returns (a target between two rings gives no measurement:
/// ScanPosition warns).
inline Draw drawScene(double range, std::mt19937& rng,
                      const std::optional<Eigen::Quaterniond>& los_T_target = std::nullopt) {
  std::uniform_real_distribution<double> azimuth(-40 * kDeg, 40 * kDeg),
      elevation(-5 * kDeg, 5 * kDeg);
  std::normal_distribution<double> n;
  Draw d;
  do {
    const double az = azimuth(rng), el = elevation(rng);
    const Eigen::Quaterniond los(Eigen::AngleAxisd(az, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(-el, Eigen::Vector3d::UnitY()));
    const Eigen::Quaterniond attitude = los_T_target ? los * *los_T_target : randomAttitude(rng);
    d.truth =
        Eigen::Translation3d(range * Eigen::Vector3d(std::cos(el) * std::cos(az),
                                                     std::cos(el) * std::sin(az), std::sin(el))) *
        attitude;
    const double half = std::asin(std::min(1.0, modelRadius() / range)) + 1 * kDeg;
    d.options.min_azimuth = az - half;
    d.options.max_azimuth = az + half;
    d.scan = testing::simulateScan(testing::satelliteMesh(), d.truth, d.options, rng(), "lidar");
  } while (d.scan.size() < 5);
  d.scan.stamp = kStamp;
  d.centroid = d.scan.xyzMatrix().cast<double>().rowwise().mean();
  d.prediction.pose = Transform::identity("servicer", "target", kStamp - 100'000);
  d.prediction.pose.translation =
      d.truth.translation() + kPredictionSigma * Eigen::Vector3d(n(rng), n(rng), n(rng));
  d.prediction.covariance = Matrix12d::Identity();
  d.prediction.covariance.topLeftCorner<3, 3>() *= kPredictionSigma * kPredictionSigma;
  return d;
}

inline Transform servicerTLidar() {
  return Transform::identity("servicer", "lidar");
}

/// A LIDAR mounted 1.2 m forward, 0.3 m left and 0.5 m up on the servicer, turned 20 deg left
/// and 5 deg down.
inline Transform mountedServicerTLidar() {
  return Transform::fromIsometry(Eigen::Translation3d(1.2, 0.3, 0.5) *
                                     Eigen::AngleAxisd(20 * kDeg, Eigen::Vector3d::UnitZ()) *
                                     Eigen::AngleAxisd(5 * kDeg, Eigen::Vector3d::UnitY()),
                                 "servicer", "lidar");
}

/// Sets every input of the scene; the sensor's description only `with_sensor`.
inline void setInputs(ScanPosition& node, const Draw& d, bool with_sensor = true) {
  node.in.cloud.set(d.scan);
  node.in.sensor_pose.set(servicerTLidar());
  node.in.prediction.set(d.prediction);
  node.in.model.set(satelliteModel());
  if (with_sensor) node.in.sensor.set(testing::lidarInfo(d.options, "lidar"));
}

}  // namespace cdff::dfn::scan_position_testing
