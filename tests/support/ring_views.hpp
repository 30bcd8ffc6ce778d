#pragma once
// Key frames of a fly-around inspection with known truth, for the BundleAdjustment DFN's tests
// and benchmark: cameras on a ring (or an arc of it) around a 2 m object, looking at its centre,
// the points on the object's surface, each seen by at least two cameras, Gaussian pixel noise,
// injected outliers, and a perturbed initial guess. No GoogleTest: the benchmark compiles it too.
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/point_cloud.hpp"

namespace cdff::testing {

struct RingOptions {
  int cameras = 10;
  int points = 300;
  double arc = 2 * 3.14159265358979323846;  // rad of azimuth the cameras cover (2 pi: a ring)
  double radius = 3.0;                      // m, the cameras' distance from the object's centre
  double sigma_px = 0.5;                    // Gaussian pixel noise per coordinate
  double outlier_fraction = 0.0;            // observations whose pixel is replaced by a random one
  double position_sigma = 0.02;  // m, the initial guess's error per axis (camera centres, points)
  double angle_sigma = 0.005;    // rad, per axis (camera rotations)
  int exact_poses = 1;           // leading poses given exactly (held by the DFN)
  std::uint32_t seed = 1;
};

struct RingObservation {
  int camera = 0;
  int point = 0;
  Eigen::Vector2d pixel;  // observed (noise, or the outlier's random pixel)
  Eigen::Vector2d truth;  // the noise-free projection
  bool inlier = true;
};

struct RingScene {
  CameraModel camera;                             // 1024 x 768, f = 800 px, no distortion
  std::vector<Eigen::Isometry3d> world_T_camera;  // the truth
  std::vector<Eigen::Vector3d> points;            // the truth, m, world frame
  std::vector<RingObservation> observations;
  std::vector<Eigen::Isometry3d> initial_poses;  // perturbed (the first exact_poses exact; with
                                                 // one, the second at its true distance from it)
  std::vector<Eigen::Vector3d> initial_points;   // perturbed
};

/// Cameras at `radius` from the centre of an ellipsoid of semi-axes 1 x 0.8 x 0.7 m (a 2 m
/// object), evenly spread over `arc` of azimuth (a closed ring when arc is 2 pi) at elevations
/// within +-14 deg, optical axis on the centre; points uniformly on the ellipsoid, seen by a
/// camera when in the image and within 75 deg of their surface normal, kept when seen by two.
RingScene ringScene(const RingOptions& options);

/// The DFN's inputs: the poses (frame "target"), the points and the observations.
PoseArray ringPoses(const std::vector<Eigen::Isometry3d>& poses);
PointCloud ringPoints(const std::vector<Eigen::Vector3d>& points);
nlohmann::json ringObservations(const RingScene& scene);

}  // namespace cdff::testing
