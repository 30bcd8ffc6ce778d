#include "cdff/egse/lens.hpp"

#include <cmath>

namespace cdff::egse {

namespace {
double coefficient(const CameraModel& c, std::size_t i) {
  return i < c.distortion.size() ? c.distortion[i] : 0.0;
}
}  // namespace

Eigen::Vector2d distortNormalised(const CameraModel& c, const Eigen::Vector2d& p) {
  const double x = p.x(), y = p.y();
  switch (c.distortion_model) {
    case DistortionModel::kNone:
      return p;
    case DistortionModel::kRadialTangential: {
      const double k1 = coefficient(c, 0), k2 = coefficient(c, 1), p1 = coefficient(c, 2),
                   p2 = coefficient(c, 3), k3 = coefficient(c, 4), k4 = coefficient(c, 5),
                   k5 = coefficient(c, 6), k6 = coefficient(c, 7);
      const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
      const double radial = (1 + k1 * r2 + k2 * r4 + k3 * r6) / (1 + k4 * r2 + k5 * r4 + k6 * r6);
      return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
              y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
    }
    case DistortionModel::kEquidistant: {
      const double r = std::sqrt(x * x + y * y);
      if (r < 1e-15) return p;
      const double k1 = coefficient(c, 0), k2 = coefficient(c, 1), k3 = coefficient(c, 2),
                   k4 = coefficient(c, 3);
      const double th = std::atan(r), t2 = th * th;
      const double thd = th * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
      return p * (thd / r);
    }
  }
  return p;
}

Eigen::Vector2d undistortNormalised(const CameraModel& c, const Eigen::Vector2d& target) {
  return undistortNormalised(c, target, target);
}

Eigen::Vector2d undistortNormalised(const CameraModel& c, const Eigen::Vector2d& target,
                                    const Eigen::Vector2d& initial) {
  if (c.distortion_model == DistortionModel::kNone) return target;
  Eigen::Vector2d p = initial;
  for (int iteration = 0; iteration < 50; ++iteration) {
    const Eigen::Vector2d residual = distortNormalised(c, p) - target;
    if (residual.norm() < 1e-14) break;
    Eigen::Matrix2d J;
    if (c.distortion_model == DistortionModel::kRadialTangential) {
      // Analytic Jacobian of the radial-tangential model.
      const double k1 = coefficient(c, 0), k2 = coefficient(c, 1), p1 = coefficient(c, 2),
                   p2 = coefficient(c, 3), k3 = coefficient(c, 4), k4 = coefficient(c, 5),
                   k5 = coefficient(c, 6), k6 = coefficient(c, 7);
      const double x = p.x(), y = p.y(), r2 = x * x + y * y, r4 = r2 * r2;
      const double N = 1 + k1 * r2 + k2 * r4 + k3 * r4 * r2,
                   D = 1 + k4 * r2 + k5 * r4 + k6 * r4 * r2;
      const double dN = k1 + 2 * k2 * r2 + 3 * k3 * r4, dD = k4 + 2 * k5 * r2 + 3 * k6 * r4;
      const double R = N / D, dR = (dN * D - N * dD) / (D * D);  // dR / d(r^2)
      J(0, 0) = R + 2 * x * x * dR + 2 * p1 * y + 6 * p2 * x;
      J(0, 1) = 2 * x * y * dR + 2 * p1 * x + 2 * p2 * y;
      J(1, 0) = J(0, 1);
      J(1, 1) = R + 2 * y * y * dR + 6 * p1 * y + 2 * p2 * x;
    } else {
      // Central differences (the fisheye model is smooth and cheap).
      constexpr double h = 1e-7;
      J.col(0) = (distortNormalised(c, p + Eigen::Vector2d(h, 0)) -
                  distortNormalised(c, p - Eigen::Vector2d(h, 0))) /
                 (2 * h);
      J.col(1) = (distortNormalised(c, p + Eigen::Vector2d(0, h)) -
                  distortNormalised(c, p - Eigen::Vector2d(0, h))) /
                 (2 * h);
    }
    p -= J.inverse() * residual;
  }
  return p;
}

Eigen::Vector2d projectWithDistortion(const CameraModel& c, const Eigen::Vector3d& p) {
  const Eigen::Vector2d d = distortNormalised(c, Eigen::Vector2d(p.x() / p.z(), p.y() / p.z()));
  return {c.fx * d.x() + c.cx, c.fy * d.y() + c.cy};
}

Eigen::Vector3d pixelRay(const CameraModel& c, double u, double v) {
  const Eigen::Vector2d n =
      undistortNormalised(c, Eigen::Vector2d((u - c.cx) / c.fx, (v - c.cy) / c.fy));
  return Eigen::Vector3d(n.x(), n.y(), 1.0).normalized();
}

}  // namespace cdff::egse
