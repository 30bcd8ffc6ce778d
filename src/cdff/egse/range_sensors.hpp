#pragma once
// Active range sensors by ray casting against the target: a spinning multi-beam LIDAR
// (default: the seed's Velodyne VLP-16), a time-of-flight camera and a radar.
//
// Rays are cast in the target's body frame (raycaster.hpp): each ray is moved by the pose of the
// sensor relative to the target at the ray's own time, so a scan taken while the target tumbles
// shows the target where it was when each point was measured, as a real spinning LIDAR does.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/egse/model.hpp"
#include "cdff/egse/raycaster.hpp"
#include "cdff/egse/rng.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/lidar_info.hpp"
#include "cdff/types/point_cloud.hpp"

namespace cdff::egse {

/// sensor_T_target at time t (s): what a range sensor needs from the world.
using RelativePose = std::function<Eigen::Isometry3d(double t)>;

struct LidarSpec {
  /// Laser elevations (rad) in firing order. Default: the VLP-16's 16 lasers, -15..+15 deg in
  /// 2 deg steps, fired interleaved (-15, 1, -13, 3, ... , -1, 15).
  std::vector<double> elevations;
  double rotation_rate = 10.0;                // Hz
  double firing_cycle = 55.296e-6;            // s between firing sequences of all lasers
  double laser_interval = 2.304e-6;           // s between two lasers of a sequence
  double min_range = 0.5, max_range = 100.0;  // m
  double range_noise = 0.03;                  // m, 1 sigma
  double dropout_probability = 0.0;           // per point
  double spurious_rate = 0.0;                 // spurious returns per scan (Poisson mean)
  bool motion_during_scan = true;             // false: every point at the scan start's pose

  static LidarSpec vlp16();
  Status validate(const std::string& name) const;
  /// The description a LIDAR publishes beside its scans (elevations in firing order).
  LidarInfo info(const std::string& frame_id, Timestamp stamp) const;
};

/// Per-scan fault effects.
struct LidarFaults {
  double extra_dropout = 0.0;   // added to dropout_probability
  double extra_spurious = 0.0;  // added to spurious_rate
};

class LidarSensor {
 public:
  static Result<LidarSensor> create(const LidarSpec& spec, const std::string& name);
  const LidarSpec& spec() const { return spec_; }
  /// Seconds per revolution.
  double period() const { return 1.0 / spec_.rotation_rate; }
  /// Firings per revolution (all lasers).
  std::size_t firingsPerScan() const { return cycles_ * spec_.elevations.size(); }

  /// One revolution starting at `start` (s); points in the sensor frame (x forward, y left,
  /// z up) at their own firing time, with ring (0 = lowest beam), time offset from the stamp
  /// (the scan start) and intensity (reflectivity x cos(incidence) x 100). Times are set, the
  /// stamp is left for the caller (it knows the epoch).
  Result<PointCloud> scan(const RayCaster& target, const TargetModel& model,
                          const RelativePose& sensor_T_target, double start,
                          const LidarFaults& faults, Rng& rng) const;

 private:
  LidarSpec spec_;
  std::string name_;
  std::size_t cycles_ = 0;
  std::vector<std::uint16_t> ring_;  // per laser in firing order
};

struct TofSpec {
  CameraModel model;                         // pinhole (distortion allowed)
  double min_range = 0.1, max_range = 10.0;  // m
  double noise_constant = 0.004;             // m, 1 sigma at zero range
  double noise_quadratic = 0.0015;           // m per m^2: sigma = constant + quadratic r^2
  double min_amplitude = 0.002;  // reflectivity x cos / r^2 below which a pixel is invalid
  double dropout_probability = 0.0;

  static TofSpec defaults();
  Status validate(const std::string& name) const;
};

class TofSensor {
 public:
  /// Precomputes the pixel rays.
  static Result<TofSensor> create(const TofSpec& spec, const std::string& name);
  const TofSpec& spec() const { return spec_; }
  /// A depth image (Float32, metres along the optical axis, 0 = no measurement) of the target,
  /// with the camera model attached.
  Result<DepthMap> capture(const RayCaster& target, const TargetModel& model,
                           const Eigen::Isometry3d& sensor_T_target, double extra_dropout,
                           Rng& rng) const;

 private:
  TofSpec spec_;
  std::string name_;
  std::vector<Eigen::Vector3f> rays_;  // unit, camera frame, per pixel
};

struct RadarSpec {
  double min_range = 1.0, max_range = 5000.0;  // m
  double beam_half_angle = 0.35;               // rad: the target must be inside this cone
  double range_noise = 0.05;                   // m
  double range_rate_noise = 0.005;             // m/s
  double angle_noise = 0.003;                  // rad, per axis
  double dropout_probability = 0.0;            // each measurement lost (no detection) with it

  Status validate(const std::string& name) const;
};

/// A radar detection: range and range rate to the target's surface along the line of sight to
/// its centre, and the direction of that line of sight.
struct RangeMeasurement {
  Timestamp stamp = 0;
  std::string frame_id;
  bool valid = false;                                    // false: no detection
  double range = 0, range_rate = 0;                      // m, m/s
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // unit, sensor frame
  double range_sigma = 0, range_rate_sigma = 0, angle_sigma = 0;
};

/// A radar measurement at time t.
Result<RangeMeasurement> measureRadar(const RadarSpec& spec, const RayCaster& target,
                                      const RelativePose& sensor_T_target, double t, Rng& rng);

}  // namespace cdff::egse
