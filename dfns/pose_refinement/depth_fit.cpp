#include "depth_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "cdff/types/depth_metres.hpp"

namespace cdff::pose_refinement {

Result<MeasuredDepth> measuredDepth(const DepthMap& map, const std::string& port) {
  Result<cv::Mat> metres = depthMetres(map);
  if (!metres) return Status(metres.status().code(), port + ": " + metres.status().message());
  if (!map.image.camera)
    return invalidInput(
        "{} has no camera model; expected the calibrated camera of the detections' image (any "
        "resolution)",
        port);
  if (map.image.camera->hasDistortion())
    return invalidInput(
        "{} has lens distortion ({}); expected the depth of a rectified or undistorted image", port,
        toString(map.image.camera->distortion_model));
  if (map.image.camera->width != map.image.width || map.image.camera->height != map.image.height)
    return invalidInput("{} is {}x{} px but its camera model is {}x{}; expected the same size",
                        port, map.image.width, map.image.height, map.image.camera->width,
                        map.image.camera->height);
  return MeasuredDepth{std::move(metres).value(), *map.image.camera};
}

void pointsNear(const MeasuredDepth& depth, const Eigen::Vector3d& centre, double radius,
                std::size_t max_points, std::vector<Eigen::Vector3f>& out) {
  out.clear();
  const CameraModel& c = depth.camera;
  if (centre.z() <= radius * 1e-3) return;
  // The sphere's image lies within the box of its centre's projection +- radius seen at its
  // nearest depth.
  const double nearest = std::max(centre.z() - radius, 0.05 * centre.z());
  const double u0 = c.fx * centre.x() / centre.z() + c.cx,
               v0 = c.fy * centre.y() / centre.z() + c.cy;
  const double du = c.fx * radius / nearest * 1.5, dv = c.fy * radius / nearest * 1.5;
  const int left = std::max(0, static_cast<int>(std::floor(u0 - du)));
  const int right = std::min(depth.metres.cols - 1, static_cast<int>(std::ceil(u0 + du)));
  const int top = std::max(0, static_cast<int>(std::floor(v0 - dv)));
  const int bottom = std::min(depth.metres.rows - 1, static_cast<int>(std::ceil(v0 + dv)));
  const double r2 = radius * radius;
  auto inside = [&](int u, int v, float z) {
    if (!std::isfinite(z)) return false;
    const Eigen::Vector3d p((u - c.cx) / c.fx * z, (v - c.cy) / c.fy * z, z);
    return (p - centre).squaredNorm() <= r2;
  };
  // Which pixels of the box are measured inside the sphere, once for both passes.
  cv::Mat1b in_sphere(std::max(0, bottom - top + 1), std::max(0, right - left + 1));
  std::size_t measured = 0;
  for (int v = top; v <= bottom; ++v) {
    const float* row = depth.metres.ptr<float>(v);
    std::uint8_t* flags = in_sphere.ptr<std::uint8_t>(v - top);
    for (int u = left; u <= right; ++u) measured += flags[u - left] = inside(u, v, row[u]);
  }
  // Pixels in blocks of b x b, b such that the measured pixels make about max_points blocks;
  // each block with at least half its pixels measured inside the sphere gives one point at the
  // median depth of those (independent noise shrinks by about b; an edge stays where it is).
  const int b = std::max(
      1, static_cast<int>(std::floor(std::sqrt(static_cast<double>(measured) / max_points))));
  std::vector<float> depths;
  for (int v0 = top; v0 + b - 1 <= bottom; v0 += b)
    for (int u0 = left; u0 + b - 1 <= right; u0 += b) {
      depths.clear();
      double su = 0, sv = 0;
      for (int v = v0; v < v0 + b; ++v) {
        const float* row = depth.metres.ptr<float>(v);
        const std::uint8_t* flags = in_sphere.ptr<std::uint8_t>(v - top);
        for (int u = u0; u < u0 + b; ++u) {
          if (!flags[u - left]) continue;
          depths.push_back(row[u]);
          su += u;
          sv += v;
        }
      }
      if (depths.empty() || 2 * depths.size() < static_cast<std::size_t>(b * b)) continue;
      const auto middle = depths.begin() + static_cast<std::ptrdiff_t>(depths.size() / 2);
      std::nth_element(depths.begin(), middle, depths.end());
      const double z = *middle, u = su / depths.size(), v = sv / depths.size();
      out.emplace_back(static_cast<float>((u - c.cx) / c.fx * z),
                       static_cast<float>((v - c.cy) / c.fy * z), static_cast<float>(z));
    }
  if (out.size() <= max_points) return;
  const std::size_t n = out.size();
  for (std::size_t k = 0; k < max_points; ++k) out[k] = out[k * n / max_points];
  out.resize(max_points);
}

ModelShape modelShape(const registration::ModelIndex& index, std::size_t samples,
                      std::span<const float> reflectivity) {
  ModelShape s;
  const std::size_t n = index.points.size();
  if (n == 0) return s;
  const registration::ModelBounds bounds = registration::modelBounds(index);
  s.centre = bounds.centre();
  s.radius = bounds.radius();
  const std::size_t keep = std::min(n, std::max<std::size_t>(samples, 1));
  for (std::size_t k = 0; k < keep; ++k) {
    s.points.push_back(index.points[k * n / keep].vec());
    s.normals.push_back(index.normals[k * n / keep].vec());
    if (reflectivity.size() == n) s.reflectivity.push_back(reflectivity[k * n / keep]);
  }
  // The model is uniform by area: keep points of n at spacing d cover n d^2, so the subsample's
  // spacing is d sqrt(n / keep).
  s.spacing = registration::modelSpacing(index) * std::sqrt(static_cast<double>(n) / keep);
  return s;
}

std::vector<Eigen::Isometry3d> startsOf(const Eigen::Isometry3d& candidate,
                                        std::span<const Eigen::Isometry3d> symmetries) {
  std::vector<Eigen::Isometry3d> starts = {candidate};
  for (const Eigen::Isometry3d& s : symmetries) starts.push_back(candidate * s);
  return starts;
}

double shownModelCost(const Eigen::Isometry3d& pose, const ModelShape& shape,
                      const MeasuredDepth& depth, double sigma, double missing_cost,
                      const DepthReturn& returns, Score& score) {
  const CameraModel& c = depth.camera;
  const int width = depth.metres.cols, height = depth.metres.rows;
  // z-buffer cells span the subsample's projected spacing, so that a nearer surface covers
  // every cell the points behind it fall in.
  const double z_centre = std::max((pose * shape.centre).z(), 1e-3);
  const int cell = std::max(1, static_cast<int>(std::ceil(1.5 * c.fx * shape.spacing / z_centre)));
  const int gw = width / cell + 1, gh = height / cell + 1;
  std::vector<float> nearest(static_cast<std::size_t>(gw * gh),
                             std::numeric_limits<float>::infinity());
  struct Shown {
    float z;
    int u, v;
    bool sure;  // the camera surely measures it
  };
  std::vector<Shown> candidates;
  candidates.reserve(shape.points.size() / 2);
  for (std::size_t i = 0; i < shape.points.size(); ++i) {
    const Eigen::Vector3d p = pose * shape.points[i].cast<double>();
    const Eigen::Vector3d n = pose.linear() * shape.normals[i].cast<double>();
    if (p.z() <= 0 || n.dot(p) >= 0) continue;  // behind the camera or facing away
    const int u = static_cast<int>(std::lround(c.fx * p.x() / p.z() + c.cx));
    const int v = static_cast<int>(std::lround(c.fy * p.y() / p.z() + c.cy));
    if (u < 0 || v < 0 || u >= width || v >= height) continue;
    float& z = nearest[static_cast<std::size_t>((v / cell) * gw + u / cell)];
    z = std::min(z, static_cast<float>(p.z()));
    const float reflectivity = shape.reflectivity.empty() ? 1.0f : shape.reflectivity[i];
    candidates.push_back({static_cast<float>(p.z()), u, v, returns.sure(p, n, reflectivity)});
  }
  // Points more than the subsample's spacing (and the noise) behind the cell's nearest are hidden.
  const double hidden = std::max(3 * sigma, 2 * shape.spacing);
  double cost = 0;
  std::size_t shown = 0, expected = 0, confirmed = 0;
  for (const Shown& s : candidates) {
    if (s.z > nearest[static_cast<std::size_t>((s.v / cell) * gw + s.u / cell)] + hidden) continue;
    ++shown;
    const float measured = depth.metres.at<float>(s.v, s.u);
    if (!std::isfinite(measured)) {
      cost += s.sure ? missing_cost : 1.0;
      expected += s.sure;
      continue;
    }
    ++expected;
    const double r = (measured - s.z) / sigma;
    cost += std::min(r * r, kUnexplainedCost);
    confirmed += std::abs(r) <= 3;
  }
  score.shown = shown;
  score.confirmed = expected > 0 ? static_cast<double>(confirmed) / expected : 0.0;
  return cost;
}

}  // namespace cdff::pose_refinement
