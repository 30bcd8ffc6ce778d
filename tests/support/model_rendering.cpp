#include "support/model_rendering.hpp"

#include <algorithm>
#include <limits>
#include <random>

#include <opencv2/imgproc.hpp>

namespace cdff::testing {

namespace {

struct Raster {
  cv::Mat depth;  // CV_64F, infinity where empty
  cv::Mat face;   // CV_32S, -1 where empty
};

// Nearest face per sub-pixel of an s-times finer grid (sub-pixel centres at (i + 0.5) / s - 0.5).
Raster rasterise(const PolygonModel& model, const CameraModel& k, const Eigen::Isometry3d& c_T_m,
                 int s) {
  const int w = k.width * s, h = k.height * s;
  Raster r{cv::Mat(h, w, CV_64F, cv::Scalar(std::numeric_limits<double>::infinity())),
           cv::Mat(h, w, CV_32S, cv::Scalar(-1))};
  for (std::size_t f = 0; f < model.faces.size(); ++f) {
    std::vector<Eigen::Vector3d> poly;
    for (std::uint32_t p : model.faces[f].points) poly.push_back(c_T_m * model.points[p]);
    std::vector<Eigen::Vector3d> clipped;
    const double near = 1e-3;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const Eigen::Vector3d& a = poly[i];
      const Eigen::Vector3d& b = poly[(i + 1) % poly.size()];
      if (a.z() >= near) clipped.push_back(a);
      if ((a.z() >= near) != (b.z() >= near))
        clipped.push_back(a + (b - a) * ((near - a.z()) / (b.z() - a.z())));
    }
    if (clipped.size() < 3) continue;
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < poly.size(); ++i)
      normal += poly[i].cross(poly[(i + 1) % poly.size()]);
    normal.normalize();
    const double offset = normal.dot(poly[0]);
    std::vector<Eigen::Vector2d> px;
    double x0 = 1e18, x1 = -1e18, y0 = 1e18, y1 = -1e18;
    for (const Eigen::Vector3d& p : clipped) {
      const Eigen::Vector2d q((k.fx * p.x() / p.z() + k.cx + 0.5) * s - 0.5,
                              (k.fy * p.y() / p.z() + k.cy + 0.5) * s - 0.5);
      px.push_back(q);
      x0 = std::min(x0, q.x());
      x1 = std::max(x1, q.x());
      y0 = std::min(y0, q.y());
      y1 = std::max(y1, q.y());
    }
    const int i0 = std::max(0, static_cast<int>(std::floor(x0)) - 1);
    const int i1 = std::min(w - 1, static_cast<int>(std::ceil(x1)) + 1);
    const int j0 = std::max(0, static_cast<int>(std::floor(y0)) - 1);
    const int j1 = std::min(h - 1, static_cast<int>(std::ceil(y1)) + 1);
    if (i0 > i1 || j0 > j1) continue;
    // Exact scan-line coverage of the sub-pixel centres, depth from the face's plane.
    std::vector<double> crossings;
    for (int j = j0; j <= j1; ++j) {
      crossings.clear();
      for (std::size_t e = 0; e < px.size(); ++e) {
        const Eigen::Vector2d& a = px[e];
        const Eigen::Vector2d& b = px[(e + 1) % px.size()];
        if ((a.y() > j) != (b.y() > j))
          crossings.push_back(a.x() + (j - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
      }
      std::sort(crossings.begin(), crossings.end());
      double* depth = r.depth.ptr<double>(j);
      int* face = r.face.ptr<int>(j);
      const double v = ((j + 0.5) / s - 0.5 - k.cy) / k.fy;
      for (std::size_t c = 0; c + 1 < crossings.size(); c += 2) {
        const int from = std::max(i0, static_cast<int>(std::ceil(crossings[c])));
        const int to = std::min(i1, static_cast<int>(std::ceil(crossings[c + 1])) - 1);
        for (int i = from; i <= to; ++i) {
          const double u = ((i + 0.5) / s - 0.5 - k.cx) / k.fx;
          const double denom = normal.dot(Eigen::Vector3d(u, v, 1.0));
          if (std::abs(denom) < 1e-12) continue;
          const double z = offset / denom;
          if (z > near && z < depth[i]) {
            depth[i] = z;
            face[i] = static_cast<int>(f);
          }
        }
      }
    }
  }
  return r;
}

}  // namespace

cv::Mat renderModel(const PolygonModel& model, const CameraModel& camera,
                    const Eigen::Isometry3d& camera_T_model, const RenderOptions& options) {
  const int s = std::max(1, options.supersample);
  const Raster r = rasterise(model, camera, camera_T_model, s);
  std::vector<double> shade(model.faces.size());
  const Eigen::Vector3d light = Eigen::Vector3d(0.35, -0.55, -1.0).normalized();
  for (std::size_t f = 0; f < model.faces.size(); ++f) {
    const auto& pts = model.faces[f].points;
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < pts.size(); ++i)
      n += model.points[pts[i]].cross(model.points[pts[(i + 1) % pts.size()]]);
    n = (camera_T_model.linear() * n).normalized();
    shade[f] = options.gain * (70.0 + 170.0 * std::abs(n.dot(light)));
  }
  cv::Mat fine(r.face.size(), CV_32F);
  for (int j = 0; j < fine.rows; ++j)
    for (int i = 0; i < fine.cols; ++i) {
      const int f = r.face.at<int>(j, i);
      fine.at<float>(j, i) =
          static_cast<float>(f < 0 ? options.background * options.gain : shade[f]);
    }
  cv::Mat coarse;
  cv::resize(fine, coarse, cv::Size(camera.width, camera.height), 0, 0, cv::INTER_AREA);
  if (options.noise_sigma > 0) {
    std::mt19937 rng(options.seed);
    std::normal_distribution<float> noise(0.0f, static_cast<float>(options.noise_sigma));
    for (int j = 0; j < coarse.rows; ++j)
      for (int i = 0; i < coarse.cols; ++i) coarse.at<float>(j, i) += noise(rng);
  }
  cv::Mat out;
  coarse.convertTo(out, CV_8U);  // saturates
  return out;
}

cv::Mat renderDepth(const PolygonModel& model, const CameraModel& camera,
                    const Eigen::Isometry3d& camera_T_model) {
  const Raster r = rasterise(model, camera, camera_T_model, 1);
  cv::Mat depth(r.depth.size(), CV_32F);
  for (int j = 0; j < depth.rows; ++j)
    for (int i = 0; i < depth.cols; ++i) {
      const double z = r.depth.at<double>(j, i);
      depth.at<float>(j, i) = std::isfinite(z) ? static_cast<float>(z) : 0.0f;
    }
  return depth;
}

PolygonModel boxModel(const Eigen::Vector3d& size) {
  PolygonModel m;
  m.frame_id = "box";
  const Eigen::Vector3d h = size / 2;
  for (int i = 0; i < 8; ++i)
    m.points.emplace_back((i & 1 ? 1 : -1) * h.x(), (i & 2 ? 1 : -1) * h.y(),
                          (i & 4 ? 1 : -1) * h.z());
  // Counter-clockwise seen from outside.
  m.faces = {{{0, 2, 3, 1}, "bottom"}, {{4, 5, 7, 6}, "top"},  {{0, 1, 5, 4}, "front"},
             {{2, 6, 7, 3}, "back"},   {{0, 4, 6, 2}, "left"}, {{1, 3, 7, 5}, "right"}};
  return m;
}

PolygonModel lShapeModel(double a) {
  // An L in the x-y plane extruded along z: outline counter-clockwise seen from +z.
  const std::vector<Eigen::Vector2d> outline = {{0, 0}, {2 * a, 0}, {2 * a, a},
                                                {a, a}, {a, 2 * a}, {0, 2 * a}};
  PolygonModel m;
  m.frame_id = "l_shape";
  const std::size_t n = outline.size();
  for (const auto& p : outline) m.points.emplace_back(p.x() - a, p.y() - a, -a / 2);
  for (const auto& p : outline) m.points.emplace_back(p.x() - a, p.y() - a, a / 2);
  PolygonModel::Face bottom, top;
  for (std::size_t i = 0; i < n; ++i) {
    top.points.push_back(static_cast<std::uint32_t>(n + i));
    bottom.points.push_back(static_cast<std::uint32_t>(n - 1 - i));
  }
  top.name = "top";
  bottom.name = "bottom";
  m.faces.push_back(bottom);
  m.faces.push_back(top);
  for (std::size_t i = 0; i < n; ++i) {
    const auto j = static_cast<std::uint32_t>((i + 1) % n);
    const auto ii = static_cast<std::uint32_t>(i);
    m.faces.push_back(
        {{ii, j, static_cast<std::uint32_t>(n + j), static_cast<std::uint32_t>(n + ii)},
         "side" + std::to_string(i)});
  }
  return m;
}

Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                         const Eigen::Vector3d& down) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d y = down - down.dot(z) * z;
  if (y.norm() < 1e-9) y = z.unitOrthogonal();
  y.normalize();
  const Eigen::Vector3d x = y.cross(z);
  Eigen::Matrix3d m_R_c;
  m_R_c << x, y, z;
  Eigen::Isometry3d m_T_c = Eigen::Isometry3d::Identity();
  m_T_c.linear() = m_R_c;
  m_T_c.translation() = eye;
  return m_T_c.inverse();
}

}  // namespace cdff::testing
