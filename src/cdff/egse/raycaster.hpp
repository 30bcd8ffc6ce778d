#pragma once
// Ray casting against a model with Embree 3 (one BVH per model, built on one thread). The rays
// of the LIDAR, ToF camera and radar are cast in the model's own frame: a moving target moves
// the rays, not the geometry, so no BVH is rebuilt while the target moves (and points taken at
// different times of a scan see the target where it was at that time).

#include <cstdint>
#include <memory>
#include <span>

#include <Eigen/Core>

#include "cdff/egse/model.hpp"

namespace cdff::egse {

struct Ray {
  Eigen::Vector3f origin;
  Eigen::Vector3f direction;  // unit
  float t_min = 0.0f;
  float t_max = 1e30f;
};

struct RayHit {
  bool hit = false;
  float distance = 0.0f;  // along the (unit) direction
  std::uint32_t triangle = 0;
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // geometric, unit, facing the ray's origin
};

/// The point of a model's surface nearest to a query point (the contact of a sphere with the
/// surface: cdff/egse/arm_simulator.hpp).
struct SurfacePoint {
  bool found = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // on the surface, model frame
  double distance = 0;                              // from the query point, m
  std::uint32_t triangle = 0;
  Eigen::Vector3d face_normal = Eigen::Vector3d::UnitZ();  // the triangle's, from its winding
};

class RayCaster {
 public:
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  static Result<std::unique_ptr<RayCaster>> create(const TargetModel& model);

  RayHit intersect(const Ray& ray) const;
  /// Many rays at once (Embree streams them in packets).
  void intersect(std::span<const Ray> rays, std::span<RayHit> hits) const;
  /// True when something lies on the ray between t_min and t_max.
  bool occluded(const Ray& ray) const;
  /// The surface point nearest to `query` within `max_distance` (Embree's point query over the
  /// BVH, the exact point of each candidate triangle in double precision); not found when the
  /// surface is farther.
  SurfacePoint closestPoint(const Eigen::Vector3d& query, double max_distance) const;

 private:
  RayCaster() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdff::egse
