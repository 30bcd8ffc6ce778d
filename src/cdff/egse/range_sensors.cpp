#include "cdff/egse/range_sensors.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

#include "cdff/egse/lens.hpp"

namespace cdff::egse {

namespace {

Status positive(double value, const std::string& name, const char* key) {
  if (!std::isfinite(value) || value <= 0)
    return invalidParameter("{}: '{}' = {} is invalid; expected > 0", name, key, value);
  return Status::ok();
}

Status probability(double value, const std::string& name, const char* key) {
  if (!std::isfinite(value) || value < 0 || value > 1)
    return invalidParameter("{}: '{}' = {} is out of range; expected [0, 1]", name, key, value);
  return Status::ok();
}

Eigen::Isometry3d interpolate(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double s) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  out.linear() = qa.slerp(s, qb).toRotationMatrix();
  out.translation() = (1 - s) * a.translation() + s * b.translation();
  return out;
}

}  // namespace

LidarSpec LidarSpec::vlp16() {
  LidarSpec s;
  // VLP-16 laser IDs 0..15 in firing order: even IDs -15, -13, ..., odd IDs 1, 3, ... degrees.
  for (int i = 0; i < 16; ++i)
    s.elevations.push_back((i % 2 == 0 ? -15.0 + i : static_cast<double>(i)) * M_PI / 180.0);
  return s;
}

LidarInfo LidarSpec::info(const std::string& frame_id, Timestamp stamp) const {
  LidarInfo info;
  info.stamp = stamp;
  info.frame_id = frame_id;
  info.elevations = elevations;
  info.rotation_rate = rotation_rate;
  info.min_range = min_range;
  info.max_range = max_range;
  info.range_noise = range_noise;
  return info;
}

Status LidarSpec::validate(const std::string& name) const {
  if (elevations.empty() || elevations.size() > 256)
    return invalidParameter("{}: {} laser elevations; expected 1 to 256", name, elevations.size());
  for (double e : elevations)
    if (!std::isfinite(e) || std::abs(e) >= M_PI / 2)
      return invalidParameter(
          "{}: laser elevation {} rad is invalid; expected within (-pi/2, pi/2)", name, e);
  CDFF_RETURN_IF_ERROR(positive(rotation_rate, name, "rotation_rate"));
  CDFF_RETURN_IF_ERROR(positive(firing_cycle, name, "firing_cycle"));
  if (!std::isfinite(laser_interval) || laser_interval < 0 ||
      laser_interval * static_cast<double>(elevations.size()) > firing_cycle + 1e-12)
    return invalidParameter(
        "{}: {} lasers x 'laser_interval' {} s do not fit in 'firing_cycle' {} s", name,
        elevations.size(), laser_interval, firing_cycle);
  if (firing_cycle > 1.0 / rotation_rate)
    return invalidParameter("{}: 'firing_cycle' = {} s is longer than a revolution ({} s)", name,
                            firing_cycle, 1.0 / rotation_rate);
  CDFF_RETURN_IF_ERROR(positive(max_range, name, "max_range"));
  if (!std::isfinite(min_range) || min_range < 0 || min_range >= max_range)
    return invalidParameter(
        "{}: 'min_range' = {} m is invalid; expected 0 <= min_range < max_range ({} m)", name,
        min_range, max_range);
  if (!std::isfinite(range_noise) || range_noise < 0)
    return invalidParameter("{}: 'range_noise' = {} is invalid; expected >= 0 m", name,
                            range_noise);
  CDFF_RETURN_IF_ERROR(probability(dropout_probability, name, "dropout_probability"));
  if (!std::isfinite(spurious_rate) || spurious_rate < 0)
    return invalidParameter("{}: 'spurious_rate' = {} is invalid; expected >= 0 per scan", name,
                            spurious_rate);
  return Status::ok();
}

Result<LidarSensor> LidarSensor::create(const LidarSpec& spec, const std::string& name) {
  CDFF_RETURN_IF_ERROR(spec.validate(name));
  LidarSensor s;
  s.spec_ = spec;
  s.name_ = name;
  s.cycles_ = static_cast<std::size_t>(std::floor((1.0 / spec.rotation_rate) / spec.firing_cycle));
  std::vector<std::size_t> order(spec.elevations.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return spec.elevations[a] < spec.elevations[b];
  });
  s.ring_.resize(order.size());
  for (std::size_t r = 0; r < order.size(); ++r) s.ring_[order[r]] = static_cast<std::uint16_t>(r);
  return s;
}

namespace {

// Relative poses every millisecond across a scan, interpolated per firing sequence.
class ScanPoses {
 public:
  ScanPoses(const RelativePose& sensor_T_target, double start, double period, bool motion)
      : keys_(static_cast<std::size_t>(std::ceil(period / kKeyStep)) + 1), motion_(motion) {
    for (std::size_t k = 0; k < keys_.size(); ++k)
      keys_[k] = sensor_T_target(start + std::min(period, k * kKeyStep));
  }
  // sensor_T_target dt seconds into the scan (the first pose without motion during the scan).
  Eigen::Isometry3d at(double dt) const {
    const std::size_t keys = keys_.size();
    if (!motion_) return keys_.front();
    const double x = std::clamp(dt / kKeyStep, 0.0, static_cast<double>(keys - 1));
    const std::size_t k = std::min(static_cast<std::size_t>(x), keys - 2);
    return interpolate(keys_[k], keys_[k + 1], x - static_cast<double>(k));
  }
  const Eigen::Isometry3d& first() const { return keys_.front(); }
  const Eigen::Isometry3d& last() const { return keys_.back(); }

 private:
  static constexpr double kKeyStep = 1e-3;
  std::vector<Eigen::Isometry3d> keys_;
  bool motion_;
};

// The cone from the sensor that holds the target's bounding sphere, grown by its motion over the
// scan: only rays inside it are cast.
struct TargetCone {
  Eigen::Vector3d direction;
  double cos_half_angle;  // -2 when the sensor is inside the sphere: every ray
};

TargetCone targetCone(const TargetModel& model, const ScanPoses& poses) {
  const Eigen::Vector3d centre_model = model.boundingCentre();
  const double radius = model.boundingRadius();
  Eigen::Vector3d c0 = poses.first() * centre_model, c1 = poses.last() * centre_model;
  const double motion = (c1 - c0).norm();
  const Eigen::Vector3d c_mid = 0.5 * (c0 + c1);
  const double reach = radius + motion + 0.05;
  const bool inside = c_mid.norm() <= reach;
  const double cone_cos = inside ? -2.0 : std::cos(std::asin(std::min(1.0, reach / c_mid.norm())));
  return {c_mid.normalized(), cone_cos};
}

// Direction of a laser at elevation el and azimuth az, sensor frame. Azimuth grows clockwise
// seen from above (the VLP-16's spin), from +x towards -y.
Eigen::Vector3d firingDirection(double el, double az) {
  return {std::cos(el) * std::cos(az), -std::cos(el) * std::sin(az), std::sin(el)};
}

// A laser firing towards the target: its slot (cycle * lasers + laser), time and direction.
struct Firing {
  std::size_t slot;
  double time;
  Eigen::Vector3d direction;  // sensor frame
};

std::vector<Firing> firingsTowards(const LidarSpec& sp, std::size_t cycles,
                                   const TargetCone& cone) {
  const double omega = 2 * M_PI * sp.rotation_rate;
  const std::size_t lasers = sp.elevations.size();
  std::vector<Firing> firings;
  for (std::size_t j = 0; j < cycles; ++j) {
    const double tj = j * sp.firing_cycle;
    for (std::size_t l = 0; l < lasers; ++l) {
      const double t = tj + l * sp.laser_interval;
      const double az = omega * t, el = sp.elevations[l];
      const Eigen::Vector3d d = firingDirection(el, az);
      if (d.dot(cone.direction) < cone.cos_half_angle) continue;
      firings.push_back({j * lasers + l, t, d});
    }
  }
  return firings;
}

// The rays of the firings, in the target's frame at the time of each.
std::vector<Ray> raysOf(const std::vector<Firing>& firings, const ScanPoses& poses,
                        double max_range) {
  std::vector<Ray> rays(firings.size());
  for (std::size_t i = 0; i < firings.size(); ++i) {
    const Eigen::Isometry3d target_T_sensor = poses.at(firings[i].time).inverse();
    rays[i].origin = target_T_sensor.translation().cast<float>();
    rays[i].direction =
        (target_T_sensor.linear() * firings[i].direction).normalized().cast<float>();
    rays[i].t_min = 0.0f;
    rays[i].t_max = static_cast<float>(max_range * 1.5);
  }
  return rays;
}

// The points of a scan, in firing order.
struct ScanPoints {
  std::vector<Point4f> points;
  std::vector<float> intensity;
  std::vector<std::uint16_t> rings;
  std::vector<std::int32_t> offsets;

  void emit(const Eigen::Vector3d& p, double t, std::uint16_t ring, float value) {
    points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                        static_cast<float>(p.z()));
    intensity.push_back(value);
    rings.push_back(ring);
    offsets.push_back(static_cast<std::int32_t>(std::llround(t * 1e6)));
  }
  PointCloud cloud() && {
    PointCloud cloud;
    cloud.points = Buffer<Point4f>::fromVector(std::move(points));
    cloud.intensity = Buffer<float>::fromVector(std::move(intensity));
    cloud.ring = Buffer<std::uint16_t>::fromVector(std::move(rings));
    cloud.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(offsets));
    return cloud;
  }
};

}  // namespace

Result<PointCloud> LidarSensor::scan(const RayCaster& target, const TargetModel& model,
                                     const RelativePose& sensor_T_target, double start,
                                     const LidarFaults& faults, Rng& rng) const {
  const LidarSpec& sp = spec_;
  const double period = 1.0 / sp.rotation_rate, omega = 2 * M_PI * sp.rotation_rate;
  const std::size_t lasers = sp.elevations.size();
  const ScanPoses poses(sensor_T_target, start, period, sp.motion_during_scan);
  const TargetCone cone = targetCone(model, poses);

  const double dropout = std::clamp(sp.dropout_probability + faults.extra_dropout, 0.0, 1.0);
  // Spurious returns: firing slots chosen up front so that the draws do not depend on the scene.
  const std::size_t slots = cycles_ * lasers;
  std::vector<std::pair<std::size_t, double>> spurious;  // (slot, range)
  const std::int64_t spurious_count = rng.poisson(sp.spurious_rate + faults.extra_spurious);
  for (std::int64_t i = 0; i < spurious_count && slots > 0; ++i)
    spurious.emplace_back(rng.below(slots), rng.uniform(sp.min_range, sp.max_range));
  std::sort(spurious.begin(), spurious.end());

  const std::vector<Firing> candidates = firingsTowards(sp, cycles_, cone);
  const std::vector<Ray> rays = raysOf(candidates, poses, sp.max_range);
  std::vector<RayHit> hits(rays.size());
  target.intersect(rays, hits);

  ScanPoints out;
  std::size_t next_spurious = 0;
  auto emit_spurious_until = [&](std::size_t slot) {
    while (next_spurious < spurious.size() && spurious[next_spurious].first <= slot) {
      const auto [s, range] = spurious[next_spurious++];
      const std::size_t j = s / lasers, l = s % lasers;
      const double t = j * sp.firing_cycle + l * sp.laser_interval, az = omega * t,
                   el = sp.elevations[l];
      const Eigen::Vector3d d = firingDirection(el, az);
      out.emit(range * d, t, ring_[l], static_cast<float>(rng.uniform(0.0, 20.0)));
    }
  };
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    emit_spurious_until(candidates[i].slot);
    const RayHit& h = hits[i];
    if (!h.hit || h.distance < sp.min_range || h.distance > sp.max_range) continue;
    // Draw both numbers for every return so that the stream does not depend on the outcome.
    const double noise = rng.normal();
    const bool dropped = rng.uniform() < dropout;
    if (dropped) continue;
    const double range = std::max(0.0, h.distance + sp.range_noise * noise);
    const float cos_incidence = std::abs(h.normal.dot(rays[i].direction));
    const float reflectivity = model.triangleMaterial(h.triangle).lidar_reflectivity;
    out.emit(range * candidates[i].direction, candidates[i].time,
             ring_[candidates[i].slot % lasers], 100.0f * reflectivity * cos_incidence);
  }
  emit_spurious_until(slots);
  return std::move(out).cloud();
}

TofSpec TofSpec::defaults() {
  TofSpec s;
  s.model.width = 320;
  s.model.height = 240;
  // A 60 x 47 degree field of view.
  s.model.fx = s.model.fy = 160.0 / std::tan(30.0 * M_PI / 180.0);
  s.model.cx = 159.5;
  s.model.cy = 119.5;
  return s;
}

Status TofSpec::validate(const std::string& name) const {
  CDFF_RETURN_IF_ERROR(model.validate().withContext(name));
  CDFF_RETURN_IF_ERROR(positive(max_range, name, "max_range"));
  if (!std::isfinite(min_range) || min_range < 0 || min_range >= max_range)
    return invalidParameter(
        "{}: 'min_range' = {} m is invalid; expected 0 <= min_range < max_range ({} m)", name,
        min_range, max_range);
  if (!std::isfinite(noise_constant) || noise_constant < 0 || !std::isfinite(noise_quadratic) ||
      noise_quadratic < 0)
    return invalidParameter("{}: noise ({} m + {} m/m^2 r^2) is invalid; expected >= 0", name,
                            noise_constant, noise_quadratic);
  CDFF_RETURN_IF_ERROR(probability(dropout_probability, name, "dropout_probability"));
  if (!std::isfinite(min_amplitude) || min_amplitude < 0)
    return invalidParameter("{}: 'min_amplitude' = {} is invalid; expected >= 0", name,
                            min_amplitude);
  return Status::ok();
}

Result<TofSensor> TofSensor::create(const TofSpec& spec, const std::string& name) {
  CDFF_RETURN_IF_ERROR(spec.validate(name));
  TofSensor s;
  s.spec_ = spec;
  s.name_ = name;
  s.rays_.reserve(static_cast<std::size_t>(spec.model.width) * spec.model.height);
  for (int y = 0; y < spec.model.height; ++y)
    for (int x = 0; x < spec.model.width; ++x)
      s.rays_.push_back(pixelRay(spec.model, x, y).cast<float>());
  return s;
}

Result<DepthMap> TofSensor::capture(const RayCaster& target, const TargetModel& model,
                                    const Eigen::Isometry3d& sensor_T_target, double extra_dropout,
                                    Rng& rng) const {
  const TofSpec& sp = spec_;
  const Eigen::Isometry3d target_T_sensor = sensor_T_target.inverse();
  const Eigen::Matrix3f R = target_T_sensor.linear().cast<float>();
  const Eigen::Vector3f origin = target_T_sensor.translation().cast<float>();
  std::vector<Ray> rays(rays_.size());
  for (std::size_t i = 0; i < rays_.size(); ++i)
    rays[i] = {origin, R * rays_[i], 0.0f, static_cast<float>(sp.max_range * 1.5)};
  std::vector<RayHit> hits(rays.size());
  target.intersect(rays, hits);
  const double dropout = std::clamp(sp.dropout_probability + extra_dropout, 0.0, 1.0);
  std::vector<float> depth(rays.size(), 0.0f);
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const double noise = rng.normal();
    const bool dropped = rng.uniform() < dropout;
    const RayHit& h = hits[i];
    if (!h.hit || dropped || h.distance < sp.min_range || h.distance > sp.max_range) continue;
    const double amplitude = model.triangleMaterial(h.triangle).lidar_reflectivity *
                             std::abs(h.normal.dot(rays[i].direction)) / (h.distance * h.distance);
    if (amplitude < sp.min_amplitude) continue;
    const double sigma = sp.noise_constant + sp.noise_quadratic * h.distance * h.distance;
    const double range = h.distance + sigma * noise;
    depth[i] = static_cast<float>(range * rays_[i].z());
  }
  std::vector<std::uint8_t> bytes(depth.size() * sizeof(float));
  std::memcpy(bytes.data(), depth.data(), bytes.size());
  auto image =
      Image::fromBytes(std::move(bytes), sp.model.width, sp.model.height, PixelFormat::kFloat32);
  if (!image) return image.status();
  DepthMap map;
  map.image = std::move(image).value();
  map.image.camera = sp.model;
  map.meters_per_unit = 1.0;
  return map;
}

Status RadarSpec::validate(const std::string& name) const {
  CDFF_RETURN_IF_ERROR(positive(max_range, name, "max_range"));
  if (!std::isfinite(min_range) || min_range < 0 || min_range >= max_range)
    return invalidParameter(
        "{}: 'min_range' = {} m is invalid; expected 0 <= min_range < max_range ({} m)", name,
        min_range, max_range);
  if (!std::isfinite(beam_half_angle) || beam_half_angle <= 0 || beam_half_angle > M_PI)
    return invalidParameter("{}: 'beam_half_angle' = {} rad is invalid; expected (0, pi]", name,
                            beam_half_angle);
  if (range_noise < 0 || range_rate_noise < 0 || angle_noise < 0 ||
      !std::isfinite(range_noise + range_rate_noise + angle_noise))
    return invalidParameter(
        "{}: noise figures must be finite and >= 0 (range {}, range rate {}, angle {})", name,
        range_noise, range_rate_noise, angle_noise);
  return Status::ok();
}

Result<RangeMeasurement> measureRadar(const RadarSpec& spec, const RayCaster& target,
                                      const RelativePose& sensor_T_target, double t, Rng& rng) {
  RangeMeasurement m;
  m.range_sigma = spec.range_noise;
  m.range_rate_sigma = spec.range_rate_noise;
  m.angle_sigma = spec.angle_noise;
  // Draws first, so that the stream does not depend on detection.
  const double n_range = rng.normal(), n_rate = rng.normal(), n_a = rng.normal(),
               n_b = rng.normal();
  const bool dropped = spec.dropout_probability > 0 && rng.uniform() < spec.dropout_probability;
  const Eigen::Isometry3d pose = sensor_T_target(t);
  const Eigen::Vector3d centre = pose.translation();  // the target's centre of mass
  const double distance = centre.norm();
  if (distance < 1e-9) return m;
  const Eigen::Vector3d los = centre / distance;
  if (std::acos(std::clamp(los.x(), -1.0, 1.0)) > spec.beam_half_angle) return m;
  // Range to the surface along the line of sight (the centre itself if the ray slips through).
  const Eigen::Isometry3d target_T_sensor = pose.inverse();
  const RayHit hit = target.intersect({target_T_sensor.translation().cast<float>(),
                                       (target_T_sensor.linear() * los).cast<float>(), 0.0f,
                                       static_cast<float>(distance * 2)});
  const double range = hit.hit ? hit.distance : distance;
  if (range < spec.min_range || range > spec.max_range || dropped) return m;
  constexpr double h = 1e-3;
  const double rate =
      (sensor_T_target(t + h).translation().norm() - sensor_T_target(t - h).translation().norm()) /
      (2 * h);
  m.valid = true;
  m.range = range + spec.range_noise * n_range;
  m.range_rate = rate + spec.range_rate_noise * n_rate;
  // Angle noise: a small rotation of the line of sight about two axes perpendicular to it.
  const Eigen::Vector3d a = los.unitOrthogonal(), b = los.cross(a);
  m.direction = (los + spec.angle_noise * (n_a * a + n_b * b)).normalized();
  return m;
}

}  // namespace cdff::egse
