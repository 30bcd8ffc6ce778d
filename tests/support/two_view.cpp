#include "support/two_view.hpp"

#include <cmath>
#include <random>

namespace cdff::testing {

namespace {

bool inImage(const CameraModel& camera, const Eigen::Vector3d& p) {
  if (p.z() <= 0.1) return false;
  const Eigen::Vector2d px = camera.project(p);
  return px.x() >= 0 && px.y() >= 0 && px.x() <= camera.width - 1 && px.y() <= camera.height - 1;
}

// The second camera: `baseline` along (1, 0.2, 0.1) normalised, its optical axis turned to the
// box's centre (0, 0, 5.5).
Transform secondCamera(double baseline) {
  const Eigen::Vector3d c = baseline * Eigen::Vector3d(1.0, 0.2, 0.1).normalized();
  const Eigen::Vector3d z = (Eigen::Vector3d(0, 0, 5.5) - c).normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
  Eigen::Matrix3d r;
  r << x, z.cross(x), z;
  Transform t;
  t.parent_frame = "first";
  t.child_frame = "second";
  t.translation = c;
  t.rotation = Eigen::Quaterniond(r).normalized();
  return t;
}

}  // namespace

TwoViewScene twoViewScene(const TwoViewOptions& o) {
  TwoViewScene s;
  s.camera.width = 1024;
  s.camera.height = 768;
  s.camera.fx = s.camera.fy = 800;
  s.camera.cx = 511.5;
  s.camera.cy = 383.5;
  s.first_T_second = secondCamera(o.baseline);
  const Transform second_T_first = s.first_T_second.inverse();
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uy(-1.0, 1.0), uz(4.0, 7.0);
  std::uniform_real_distribution<double> upx(0, s.camera.width - 1), upy(0, s.camera.height - 1);
  std::uniform_real_distribution<double> u01(0, 1);
  std::normal_distribution<double> noise(0, o.sigma_px);
  while (static_cast<int>(s.points.size()) < o.points) {
    Eigen::Vector3d p(ux(rng), uy(rng), uz(rng));
    if (o.planar) p.z() = 5.0 + 0.3 * p.x() - 0.2 * p.y();
    const Eigen::Vector3d q = second_T_first * p;
    if (!inImage(s.camera, p) || !inImage(s.camera, q)) continue;
    s.points.push_back(p);
    s.truth.first.push_back(s.camera.project(p));
    s.truth.second.push_back(s.camera.project(q));
    const bool outlier = u01(rng) < o.outlier_fraction;
    s.inlier.push_back(!outlier);
    s.observed.first.push_back(s.truth.first.back() + Eigen::Vector2d(noise(rng), noise(rng)));
    s.observed.second.push_back(
        outlier ? Eigen::Vector2d(upx(rng), upy(rng))
                : Eigen::Vector2d(s.truth.second.back() + Eigen::Vector2d(noise(rng), noise(rng))));
  }
  return s;
}

Eigen::Matrix3d trueFundamental(const TwoViewScene& s) {
  // x2 ~ K (R p + t) with second_T_first = (R, t): E = [t]x R, F = K^-T E K^-1.
  const Transform second_T_first = s.first_T_second.inverse();
  const Eigen::Matrix3d e = skew(second_T_first.translation) * second_T_first.rotation.matrix();
  const Eigen::Matrix3d k_inv = s.camera.matrix().inverse();
  Eigen::Matrix3d f = k_inv.transpose() * e * k_inv;
  f /= f.norm();
  if (f(2, 2) < 0) f = -f;
  return f;
}

double epipolarDistance(const Eigen::Matrix3d& f, const Eigen::Vector2d& x1,
                        const Eigen::Vector2d& x2) {
  const Eigen::Vector3d a = x1.homogeneous(), b = x2.homogeneous();
  const Eigen::Vector3d l2 = f * a, l1 = f.transpose() * b;
  const double r = b.dot(f * a);
  return 0.5 * (std::abs(r) / l2.head<2>().norm() + std::abs(r) / l1.head<2>().norm());
}

double sampsonDistance(const Eigen::Matrix3d& f, const Eigen::Vector2d& x1,
                       const Eigen::Vector2d& x2) {
  const Eigen::Vector3d a = x1.homogeneous(), b = x2.homogeneous();
  const Eigen::Vector3d fa = f * a, fb = f.transpose() * b;
  return b.dot(fa) / std::sqrt(fa.head<2>().squaredNorm() + fb.head<2>().squaredNorm());
}

}  // namespace cdff::testing
