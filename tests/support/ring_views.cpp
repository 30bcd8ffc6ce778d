#include "support/ring_views.hpp"

#include <cmath>
#include <random>

namespace cdff::testing {

namespace {

// world_T_camera of a camera at `centre` looking at the origin, x horizontal (world z up).
Eigen::Isometry3d lookingAtCentre(const Eigen::Vector3d& centre) {
  const Eigen::Vector3d z = (-centre).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Matrix3d r;
  r << x, z.cross(x), z;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = r;
  pose.translation() = centre;
  return pose;
}

}  // namespace

RingScene ringScene(const RingOptions& o) {
  RingScene s;
  s.camera.width = 1024;
  s.camera.height = 768;
  s.camera.fx = s.camera.fy = 800;
  s.camera.cx = 511.5;
  s.camera.cy = 383.5;
  const bool closed = o.arc >= 2 * M_PI - 1e-9;
  for (int i = 0; i < o.cameras; ++i) {
    const double azimuth =
        closed ? o.arc * i / o.cameras : o.arc * i / std::max(1, o.cameras - 1) - 0.5 * o.arc;
    const double elevation = 0.25 * std::sin(2 * azimuth + 0.7);
    const Eigen::Vector3d centre =
        o.radius * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                   std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    s.world_T_camera.push_back(lookingAtCentre(centre));
  }
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> normal(0, 1);
  std::uniform_real_distribution<double> u01(0, 1), upx(0, s.camera.width - 1),
      upy(0, s.camera.height - 1);
  const Eigen::Vector3d axes(1.0, 0.8, 0.7);
  const double cos_max = std::cos(75 * M_PI / 180);
  while (static_cast<int>(s.points.size()) < o.points) {
    const Eigen::Vector3d d = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    const Eigen::Vector3d x = axes.cwiseProduct(d);
    const Eigen::Vector3d n = x.cwiseQuotient(axes.cwiseProduct(axes)).normalized();
    std::vector<int> seen;
    std::vector<Eigen::Vector2d> pixels;
    for (int i = 0; i < o.cameras; ++i) {
      const Eigen::Vector3d to_camera = s.world_T_camera[i].translation() - x;
      if (n.dot(to_camera) < cos_max * to_camera.norm()) continue;
      const Eigen::Vector3d p = s.world_T_camera[i].inverse() * x;
      if (p.z() < 0.1) continue;
      const Eigen::Vector2d px = s.camera.project(p);
      if (px.x() < 0 || px.y() < 0 || px.x() > s.camera.width - 1 || px.y() > s.camera.height - 1)
        continue;
      seen.push_back(i);
      pixels.push_back(px);
    }
    if (seen.size() < 2) continue;
    const int j = static_cast<int>(s.points.size());
    s.points.push_back(x);
    for (std::size_t k = 0; k < seen.size(); ++k) {
      RingObservation ob;
      ob.camera = seen[k];
      ob.point = j;
      ob.truth = pixels[k];
      ob.inlier = !(u01(rng) < o.outlier_fraction);
      ob.pixel =
          ob.inlier
              ? Eigen::Vector2d(pixels[k] + o.sigma_px * Eigen::Vector2d(normal(rng), normal(rng)))
              : Eigen::Vector2d(upx(rng), upy(rng));
      s.observations.push_back(ob);
    }
  }
  // The initial guess.
  for (int i = 0; i < o.cameras; ++i) {
    Eigen::Isometry3d pose = s.world_T_camera[i];
    if (i >= o.exact_poses) {
      const Eigen::Vector3d dtheta =
          o.angle_sigma * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      pose.linear() =
          Eigen::AngleAxisd(dtheta.norm(), dtheta.normalized()).toRotationMatrix() * pose.linear();
      Eigen::Vector3d c = pose.translation() +
                          o.position_sigma * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      if (i == 1 && o.exact_poses == 1) {  // the scale: the true distance from the first
        const Eigen::Vector3d c0 = s.world_T_camera[0].translation();
        c = c0 + (c - c0).normalized() * (s.world_T_camera[1].translation() - c0).norm();
      }
      pose.translation() = c;
    }
    s.initial_poses.push_back(pose);
  }
  for (const Eigen::Vector3d& x : s.points)
    s.initial_points.push_back(x + o.position_sigma *
                                       Eigen::Vector3d(normal(rng), normal(rng), normal(rng)));
  return s;
}

PoseArray ringPoses(const std::vector<Eigen::Isometry3d>& poses) {
  PoseArray out;
  out.stamp = 1000000;
  out.frame_id = "target";
  out.poses = poses;
  return out;
}

PointCloud ringPoints(const std::vector<Eigen::Vector3d>& points) {
  std::vector<Eigen::Vector3f> xyz;
  for (const Eigen::Vector3d& x : points) xyz.push_back(x.cast<float>());
  return PointCloud::fromXyz(xyz, "target", 1000000);
}

nlohmann::json ringObservations(const RingScene& scene) {
  nlohmann::json out = nlohmann::json::array();
  for (const RingObservation& o : scene.observations)
    out.push_back(
        {{"camera", o.camera}, {"point", o.point}, {"pixel", {o.pixel.x(), o.pixel.y()}}});
  return out;
}

}  // namespace cdff::testing
