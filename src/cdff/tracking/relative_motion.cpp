#include "cdff/tracking/relative_motion.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

#include "cdff/types/opencv.hpp"

namespace cdff::tracking {

double meanMotion(double altitude) {
  constexpr double kMu = 3.986004418e14, kEarthRadius = 6378137.0;  // m^3/s^2, m (as egse)
  return altitude > 0 ? std::sqrt(kMu / std::pow(kEarthRadius + altitude, 3)) : 0.0;
}

Matrix6d cwTransition(double n, double dt) {
  Matrix6d phi = Matrix6d::Identity();
  if (n == 0.0) {
    phi.topRightCorner<3, 3>() = dt * Eigen::Matrix3d::Identity();
    return phi;
  }
  const double s = std::sin(n * dt), c = std::cos(n * dt);
  phi.topLeftCorner<3, 3>() << 4 - 3 * c, 0, 0, 6 * (s - n * dt), 1, 0, 0, 0, c;
  phi.topRightCorner<3, 3>() << s / n, 2 * (1 - c) / n, 0, 2 * (c - 1) / n,
      (4 * s - 3 * n * dt) / n, 0, 0, 0, s / n;
  phi.bottomLeftCorner<3, 3>() << 3 * n * s, 0, 0, 6 * n * (c - 1), 0, 0, 0, 0, -n * s;
  phi.bottomRightCorner<3, 3>() << c, 2 * s, 0, -2 * s, 4 * c - 3, 0, 0, 0, c;
  return phi;
}

Matrix6d whiteAccelerationNoise(double psd, double dt) {
  Matrix6d q = Matrix6d::Zero();
  const Eigen::Matrix3d i = Eigen::Matrix3d::Identity();
  q.topLeftCorner<3, 3>() = psd * dt * dt * dt / 3.0 * i;
  q.topRightCorner<3, 3>() = psd * dt * dt / 2.0 * i;
  q.bottomLeftCorner<3, 3>() = psd * dt * dt / 2.0 * i;
  q.bottomRightCorner<3, 3>() = psd * dt * i;
  return q;
}

Status propagate(RelativeState& s, Timestamp stamp, double mean_motion, double psd,
                 double bias_walk_psd) {
  if (stamp < s.stamp)
    return invalidInput("cannot propagate the relative state back from t = {} us to t = {} us",
                        s.stamp, stamp);
  const double dt = static_cast<double>(stamp - s.stamp) * 1e-6;
  const Matrix6d phi = cwTransition(mean_motion, dt);
  const Vector6d x = s.x.head<6>();
  s.x.head<6>() = phi * x;
  // The position and velocity blocks as the 6-state filter computes them; the bias's
  // cross-covariance carried by the transition.
  const Matrix6d p = s.covariance.topLeftCorner<6, 6>();
  Matrix6d q = phi * p * phi.transpose() + whiteAccelerationNoise(psd, dt);
  s.covariance.topLeftCorner<6, 6>() = 0.5 * (q + q.transpose());
  if (s.hasBias()) {
    const Eigen::Matrix<double, 6, 3> cross = phi * s.covariance.topRightCorner<6, 3>();
    s.covariance.topRightCorner<6, 3>() = cross;
    s.covariance.bottomLeftCorner<3, 6>() = cross.transpose();
    s.covariance.bottomRightCorner<3, 3>() += bias_walk_psd * dt * Eigen::Matrix3d::Identity();
  }
  s.stamp = stamp;
  return Status::ok();
}

namespace {
// The state's indices in a RigidBodyState's covariance [dt, dtheta, dv, domega]: p, v, b.
constexpr int kRigidIndex[9] = {0, 1, 2, 6, 7, 8, 9, 10, 11};
}  // namespace

RigidBodyState toRigidBodyState(const RelativeState& s, const ServicerAttitude& attitude,
                                bool with_bias) {
  RigidBodyState r;
  r.pose = Transform::identity("lvlh", "servicer", s.stamp);
  // The servicer relative to the target is -p, -v: the sign change of both leaves their
  // covariances (and the cross-covariance) as they are; b keeps its sign, so its
  // cross-covariance with p and v changes sign.
  r.pose.translation = -s.x.head<3>();
  r.twist.linear = -s.x.segment<3>(3);
  const int n = with_bias ? 9 : 6;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      r.covariance(kRigidIndex[i], kRigidIndex[j]) =
          ((i < 6) != (j < 6) ? -1.0 : 1.0) * s.covariance(i, j);
  if (with_bias) r.twist.angular = s.x.tail<3>();
  if (attitude) {
    r.pose.rotation = attitude->first;
    r.covariance.block<3, 3>(3, 3) = attitude->second;
  }
  return r;
}

Result<RelativeState> fromRigidBodyState(const RigidBodyState& state) {
  CDFF_RETURN_IF_ERROR(state.validate());
  if (state.pose.parent_frame != "lvlh" || state.pose.child_frame != "servicer")
    return invalidInput(
        "relative state {}_T_{}; expected lvlh_T_servicer (the servicer in the target's orbital "
        "frame), a BearingFilter's state",
        state.pose.parent_frame, state.pose.child_frame);
  RelativeState s;
  s.stamp = state.pose.stamp;
  s.x.head<3>() = -state.pose.translation;
  s.x.segment<3>(3) = -state.twist.linear;
  s.x.tail<3>() = state.twist.angular;
  for (int i = 0; i < 9; ++i)
    for (int j = 0; j < 9; ++j)
      s.covariance(i, j) =
          ((i < 6) != (j < 6) ? -1.0 : 1.0) * state.covariance(kRigidIndex[i], kRigidIndex[j]);
  return s;
}

std::optional<Eigen::Vector2d> BearingGeometry::pixelOf(const Eigen::Vector3d& p_lvlh) const {
  const Eigen::Vector3d p =
      servicer_R_camera.transpose() * (lvlh_R_servicer.transpose() * p_lvlh - servicer_t_camera);
  if (p.z() <= 0) return std::nullopt;
  if (!camera.hasDistortion()) return camera.project(p);
  std::vector<cv::Point3d> object{{p.x(), p.y(), p.z()}};
  std::vector<cv::Point2d> image;
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  if (camera.distortion_model == DistortionModel::kEquidistant)
    cv::fisheye::projectPoints(object, image, zero, zero, cameraMatrix(camera),
                               distortionCoefficients(camera));
  else
    cv::projectPoints(object, zero, zero, cameraMatrix(camera), distortionCoefficients(camera),
                      image);
  return Eigen::Vector2d(image[0].x, image[0].y);
}

Eigen::Vector3d BearingGeometry::rayOf(const Eigen::Vector2d& pixel) const {
  Eigen::Vector2d xy((pixel.x() - camera.cx) / camera.fx, (pixel.y() - camera.cy) / camera.fy);
  if (camera.hasDistortion()) {
    std::vector<cv::Point2d> in{{pixel.x(), pixel.y()}}, out;
    if (camera.distortion_model == DistortionModel::kEquidistant)
      cv::fisheye::undistortPoints(in, out, cameraMatrix(camera), distortionCoefficients(camera));
    else
      cv::undistortPoints(in, out, cameraMatrix(camera), distortionCoefficients(camera));
    xy = {out[0].x, out[0].y};
  }
  return Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
}

Eigen::Matrix<double, 2, 3> BearingGeometry::positionJacobian(const Eigen::Vector3d& p) const {
  Eigen::Matrix<double, 2, 3> j = Eigen::Matrix<double, 2, 3>::Zero();
  const double h = 1e-6 * std::max(1.0, p.norm());
  for (int i = 0; i < 3; ++i) {
    const auto plus = pixelOf(p + h * Eigen::Vector3d::Unit(i));
    const auto minus = pixelOf(p - h * Eigen::Vector3d::Unit(i));
    if (plus && minus) j.col(i) = (*plus - *minus) / (2 * h);
  }
  return j;
}

Eigen::Matrix<double, 2, 3> BearingGeometry::attitudeJacobian(const Eigen::Vector3d& p) const {
  Eigen::Matrix<double, 2, 3> j = Eigen::Matrix<double, 2, 3>::Zero();
  const double h = 1e-7;
  for (int i = 0; i < 3; ++i) {
    BearingGeometry plus = *this, minus = *this;
    plus.lvlh_R_servicer =
        lvlh_R_servicer * expSO3(h * Eigen::Vector3d::Unit(i)).toRotationMatrix();
    minus.lvlh_R_servicer =
        lvlh_R_servicer * expSO3(-h * Eigen::Vector3d::Unit(i)).toRotationMatrix();
    const auto a = plus.pixelOf(p), b = minus.pixelOf(p);
    if (a && b) j.col(i) = (*a - *b) / (2 * h);
  }
  return j;
}

Status AttitudeHistory::add(const PoseWithCovariance& m) {
  CDFF_RETURN_IF_ERROR(m.validate().withContext("input 'attitude'"));
  if (m.pose.parent_frame != "lvlh")
    return invalidInput(
        "input 'attitude' is {}_T_{}; expected lvlh_T_servicer (the servicer's attitude in the "
        "target's orbital frame: an AHRS with `frame: lvlh`, or the AHRS composed with the orbit)",
        m.pose.parent_frame, m.pose.child_frame);
  if (!samples_.empty() && m.pose.stamp < samples_.back().pose.stamp)
    return invalidInput("input 'attitude' at t = {} us is older than the last one (t = {} us)",
                        m.pose.stamp, samples_.back().pose.stamp);
  samples_.push_back(m);
  if (samples_.size() > 64) samples_.erase(samples_.begin());
  return Status::ok();
}

Result<std::pair<Eigen::Quaterniond, Eigen::Matrix3d>> AttitudeHistory::at(Timestamp stamp,
                                                                           double tolerance) const {
  if (samples_.empty())
    return invalidInput(
        "no servicer attitude yet; expected an 'attitude' sample (lvlh_T_servicer)");
  const auto after =
      std::lower_bound(samples_.begin(), samples_.end(), stamp,
                       [](const PoseWithCovariance& s, Timestamp t) { return s.pose.stamp < t; });
  const Timestamp tol = static_cast<Timestamp>(tolerance * 1e6);
  if (after != samples_.end() && after != samples_.begin() &&
      after->pose.stamp - std::prev(after)->pose.stamp <= 4 * tol) {
    const PoseWithCovariance& a = *std::prev(after);
    const PoseWithCovariance& b = *after;
    const double f = b.pose.stamp == a.pose.stamp
                         ? 0.0
                         : static_cast<double>(stamp - a.pose.stamp) /
                               static_cast<double>(b.pose.stamp - a.pose.stamp);
    const PoseWithCovariance& nearer = f < 0.5 ? a : b;
    return std::pair{a.pose.rotation.slerp(f, b.pose.rotation),
                     Eigen::Matrix3d(nearer.covariance.block<3, 3>(3, 3))};
  }
  const PoseWithCovariance* nearest = nullptr;
  for (const PoseWithCovariance& s : samples_)
    if (!nearest || std::llabs(s.pose.stamp - stamp) < std::llabs(nearest->pose.stamp - stamp))
      nearest = &s;
  if (std::llabs(nearest->pose.stamp - stamp) > tol)
    return invalidInput(
        "no servicer attitude within {} s of t = {} us (nearest at t = {} us); expected an AHRS "
        "sample at least that close to every image",
        tolerance, stamp, nearest->pose.stamp);
  return std::pair{nearest->pose.rotation, Eigen::Matrix3d(nearest->covariance.block<3, 3>(3, 3))};
}

}  // namespace cdff::tracking
