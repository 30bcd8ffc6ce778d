// BearingFilter/ExtendedKalman: the far-range relative state from image bearings, the servicer's
// attitude and the radar, on the Clohessy-Wiltshire model.
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "BearingFilter.gen.hpp"
#include "cdff/tracking/imu_thrust.hpp"
#include "cdff/tracking/relative_motion.hpp"

namespace cdff::dfn {
namespace {

using tracking::Matrix9d;
using tracking::RelativeState;

/// A radar measurement record, checked.
struct RadarSample {
  Timestamp stamp = 0;
  bool valid = false;
  double range = 0, range_rate = 0, range_sigma = 0, range_rate_sigma = 0;
};

Result<RadarSample> parseRadar(const nlohmann::json& j) {
  RadarSample r;
  try {
    r.valid = j.at("valid").get<bool>();
    const nlohmann::json& t = j.at("timestamp");
    r.stamp = t.at("sec").get<std::int64_t>() * 1'000'000 + t.at("nsec").get<std::int64_t>() / 1000;
    if (!r.valid) return r;
    auto number = [&](const char* key) {
      const nlohmann::json& v = j.at(key);
      return v.is_null() ? std::numeric_limits<double>::quiet_NaN() : v.get<double>();
    };
    r.range = number("range");
    r.range_rate = number("range_rate");
    r.range_sigma = number("range_sigma");
    r.range_rate_sigma = number("range_rate_sigma");
  } catch (const std::exception& e) {
    return invalidInput(
        "input 'radar' record is malformed ({}); expected valid, range, range_rate, "
        "range_sigma, range_rate_sigma and timestamp",
        e.what());
  }
  if (!(r.range > 0) || !std::isfinite(r.range))
    return invalidInput(
        "input 'radar' range at t = {} us is {} m; expected a positive finite value", r.stamp,
        r.range);
  if (!std::isfinite(r.range_rate) || !(r.range_sigma > 0) || !(r.range_rate_sigma > 0))
    return invalidInput(
        "input 'radar' at t = {} us: range rate {} m/s, sigmas {} m and {} m/s; expected a finite "
        "rate and positive sigmas",
        r.stamp, r.range_rate, r.range_sigma, r.range_rate_sigma);
  return r;
}

/// Joseph-form update of `s` with measurement z (innovation y) of Jacobian h and noise r.
template <int M>
void update(RelativeState& s, const Eigen::Matrix<double, M, 1>& y,
            const Eigen::Matrix<double, M, 9>& h, const Eigen::Matrix<double, M, M>& r) {
  const Eigen::Matrix<double, M, M> innovation_cov = h * s.covariance * h.transpose() + r;
  const Eigen::Matrix<double, 9, M> k = s.covariance * h.transpose() * innovation_cov.inverse();
  const Matrix9d a = Matrix9d::Identity() - k * h;
  s.x += k * y;
  s.covariance = a * s.covariance * a.transpose() + k * r * k.transpose();
  s.covariance = 0.5 * (s.covariance + s.covariance.transpose()).eval();
}

}  // namespace

class BearingFilterExtendedKalman final : public BearingFilterExtendedKalmanBase {
 protected:
  Status onConfigure() override {
    state_.reset();
    attitudes_ = {};
    latest_radar_.reset();
    designation_.clear();
    imu_ = {};
    return Status::ok();
  }

  Status onProcess() override;

 private:
  double meanMotion() const { return tracking::meanMotion(params_.orbit_altitude); }
  /// Propagates `s` to `stamp`, with the IMU's measured thrust where there is one.
  Status propagateTo(RelativeState& s, Timestamp stamp);
  /// The measurement's covariance, each eigenvalue at least min_measurement_sigma^2 (px^2).
  Eigen::Matrix2d measurementCovariance(const ImageRegion& m) const {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(m.covariance);
    const double floor = params_.min_measurement_sigma * params_.min_measurement_sigma;
    return eig.eigenvectors() * eig.eigenvalues().cwiseMax(std::max(floor, 1e-4)).asDiagonal() *
           eig.eigenvectors().transpose();
  }
  Result<tracking::BearingGeometry> geometryAt(Timestamp stamp, const std::string& frame,
                                               Eigen::Matrix3d& attitude_cov) const;
  Status fuseRadar(const RadarSample& r, RelativeState& s);
  Status fuseImage(const ImageRegion& m, RelativeState& s, double& nis, bool& fused);
  Result<RelativeState> initialise(const ImageRegion& m);
  /// `state` (for the centre) and `point_state` (the tracked point) at the state's time.
  void publishState(const RelativeState& s);
  Bearing bearingOf(const RelativeState& s, const tracking::BearingGeometry& g,
                    const Eigen::Matrix3d& attitude_cov) const;

  std::optional<RelativeState> state_;
  tracking::AttitudeHistory attitudes_;
  std::optional<RadarSample> latest_radar_;
  Timestamp last_fix_ = 0;
  Timestamp last_range_ = std::numeric_limits<Timestamp>::min() / 2;
  std::string designation_;
  tracking::ImuHistory imu_;
};

Status BearingFilterExtendedKalman::propagateTo(RelativeState& s, Timestamp stamp) {
  const tracking::AccelerometerModel model{params_.accel_noise_density, params_.accel_bias_sigma,
                                           params_.accel_bias_random_walk};
  const tracking::MeasuredThrust thrust =
      imu_.between(s.stamp, stamp, attitudes_, params_.attitude_tolerance, model);
  if (thrust.samples_without_attitude > 0)
    warn(fmt::format(
        "{} IMU samples between t = {} us and t = {} us left out: no servicer attitude within "
        "{} s of them",
        thrust.samples_without_attitude, s.stamp, stamp, params_.attitude_tolerance));
  return tracking::propagate(s, stamp, meanMotion(), params_.acceleration_psd, thrust);
}

Result<tracking::BearingGeometry> BearingFilterExtendedKalman::geometryAt(
    Timestamp stamp, const std::string& frame, Eigen::Matrix3d& attitude_cov) const {
  if (!in.calibration.get() || !in.camera_mount.get())
    return invalidInput("input '{}' is not set; expected it before the first image measurement",
                        in.calibration.get() ? "camera_mount" : "calibration");
  const CameraModel& camera = *in.calibration;
  CDFF_RETURN_IF_ERROR(camera.validate().withContext("input 'calibration'"));
  const Transform& mount = *in.camera_mount;
  CDFF_RETURN_IF_ERROR(mount.validate().withContext("input 'camera_mount'"));
  if (!frame.empty() && mount.child_frame != frame)
    return invalidInput("input 'camera_mount' is {}_T_{}; expected the mounting of '{}'",
                        mount.parent_frame, mount.child_frame, frame);
  auto attitude = attitudes_.at(stamp, params_.attitude_tolerance);
  if (!attitude) return attitude.status();
  attitude_cov = attitude->second;
  return tracking::BearingGeometry{camera, mount.rotation.toRotationMatrix(),
                                   attitude->first.toRotationMatrix(), mount.translation};
}

Status BearingFilterExtendedKalman::fuseRadar(const RadarSample& r, RelativeState& s) {
  double range = r.range;
  if (r.stamp >= s.stamp) {
    CDFF_RETURN_IF_ERROR(propagateTo(s, r.stamp));
  } else if (s.stamp - r.stamp <= 200'000) {
    range += r.range_rate * static_cast<double>(s.stamp - r.stamp) * 1e-6;  // a little late
  } else {
    return invalidInput("input 'radar' at t = {} us is older than the filter's time (t = {} us)",
                        r.stamp, s.stamp);
  }
  const Eigen::Vector3d p = s.position(), v = s.velocity();
  const double n = p.norm();
  const Eigen::Vector3d d = p / n;
  Eigen::Matrix<double, 2, 9> h = Eigen::Matrix<double, 2, 9>::Zero();
  h.block<1, 3>(0, 0) = d.transpose();
  h.block<1, 3>(1, 0) = ((v - d * d.dot(v)) / n).transpose();
  h.block<1, 3>(1, 3) = d.transpose();
  const Eigen::Vector2d y(range - n, r.range_rate - d.dot(v));
  const Eigen::Matrix2d noise =
      Eigen::Vector2d(r.range_sigma * r.range_sigma, r.range_rate_sigma * r.range_rate_sigma)
          .asDiagonal();
  update<2>(s, y, h, noise);
  last_range_ = s.stamp;
  return Status::ok();
}

Result<RelativeState> BearingFilterExtendedKalman::initialise(const ImageRegion& m) {
  Eigen::Matrix3d attitude_cov;
  auto g = geometryAt(m.stamp, m.frame_id, attitude_cov);
  if (!g) return g.status();
  const Eigen::Vector3d ray = g->lvlh_R_servicer * g->servicer_R_camera * g->rayOf(m.centre());
  const Eigen::Vector3d camera_lvlh = g->lvlh_R_servicer * g->servicer_t_camera;
  double range = params_.initial_range, range_sigma = params_.initial_range_sigma;
  const bool radar = latest_radar_ && latest_radar_->valid &&
                     std::llabs(latest_radar_->stamp - m.stamp) <= 2'000'000;
  if (radar) {
    range = latest_radar_->range;
    range_sigma = latest_radar_->range_sigma;
  }
  const double pixel_var = measurementCovariance(m).trace() / 2;
  const double across_var =
      range * range * (pixel_var / (g->camera.fx * g->camera.fy) + attitude_cov.trace() / 3);
  RelativeState s;
  s.stamp = m.stamp;
  s.x.head<3>() = camera_lvlh + range * ray;
  const Eigen::Matrix3d along = ray * ray.transpose();
  s.covariance.topLeftCorner<3, 3>() =
      range_sigma * range_sigma * along + across_var * (Eigen::Matrix3d::Identity() - along);
  s.covariance.block<3, 3>(3, 3) =
      params_.initial_velocity_sigma * params_.initial_velocity_sigma * Eigen::Matrix3d::Identity();
  if (radar) last_range_ = m.stamp;
  return s;
}

Status BearingFilterExtendedKalman::fuseImage(const ImageRegion& m, RelativeState& s, double& nis,
                                              bool& fused) {
  if (m.stamp < s.stamp)
    return invalidInput(
        "input 'measurement' at t = {} us is older than the filter's time (t = {} us); expected "
        "images in time order",
        m.stamp, s.stamp);
  Eigen::Matrix3d attitude_cov;
  auto g = geometryAt(m.stamp, m.frame_id, attitude_cov);
  if (!g) return g.status().withContext("input 'measurement'");
  CDFF_RETURN_IF_ERROR(propagateTo(s, m.stamp));
  const Eigen::Vector3d p = s.position();
  const std::optional<Eigen::Vector2d> predicted = g->pixelOf(p);
  if (!predicted) return Status::ok();  // behind the camera: nothing to compare (not fused)
  Eigen::Matrix<double, 2, 9> h = Eigen::Matrix<double, 2, 9>::Zero();
  h.leftCols<3>() = g->positionJacobian(p);
  const Eigen::Matrix<double, 2, 3> ja = g->attitudeJacobian(p);
  Eigen::Matrix2d r = measurementCovariance(m) + ja * attitude_cov * ja.transpose();
  const Eigen::Vector2d y = m.centre() - *predicted;
  nis = y.dot((h * s.covariance * h.transpose() + r).inverse() * y);
  if (params_.gate > 0 && nis > params_.gate) {
    warn(fmt::format(
        "image measurement at t = {} us not fused: normalised innovation {:.1f} above the gate "
        "{:.1f} ({:.1f} px from the prediction)",
        m.stamp, nis, params_.gate, y.norm()));
    return Status::ok();
  }
  update<2>(s, y, h, r);
  fused = true;
  return Status::ok();
}

Bearing BearingFilterExtendedKalman::bearingOf(const RelativeState& s,
                                               const tracking::BearingGeometry& g,
                                               const Eigen::Matrix3d& attitude_cov) const {
  const Eigen::Vector3d p = s.position(), v = s.velocity();
  const double n = p.norm();
  const Eigen::Vector3d d_l = p / n;
  const Eigen::Matrix3d servicer_R_lvlh = g.lvlh_R_servicer.transpose();
  Bearing b;
  b.stamp = s.stamp;
  b.frame_id = "servicer";
  b.direction = servicer_R_lvlh * d_l;
  const Eigen::Matrix3d j = (Eigen::Matrix3d::Identity() - d_l * d_l.transpose()) / n;
  const Eigen::Matrix3d sk = skew(b.direction);
  b.covariance = servicer_R_lvlh * j * s.covariance.topLeftCorner<3, 3>() * j.transpose() *
                     servicer_R_lvlh.transpose() +
                 sk * attitude_cov * sk.transpose() +
                 std::pow(params_.centre_offset_sigma / n, 2) *
                     (Eigen::Matrix3d::Identity() - b.direction * b.direction.transpose());
  b.covariance = 0.5 * (b.covariance + b.covariance.transpose()).eval();
  if (s.stamp - last_range_ <= static_cast<Timestamp>(params_.lost_after * 1e6)) {
    b.range = n;
    // The radar's range is to the surface, the centre lies about centre_offset_sigma beyond.
    b.range_variance = d_l.dot(s.covariance.topLeftCorner<3, 3>() * d_l) +
                       std::pow(params_.centre_offset_sigma, 2);
    b.range_rate = d_l.dot(v);
    b.range_rate_variance = d_l.dot(s.covariance.block<3, 3>(3, 3) * d_l);
  }
  b.designation = designation_;
  return b;
}

void BearingFilterExtendedKalman::publishState(const RelativeState& s) {
  tracking::ServicerAttitude attitude;
  if (auto a = attitudes_.at(s.stamp, params_.attitude_tolerance)) attitude = *a;
  RigidBodyState point = tracking::toRigidBodyState(s, attitude);
  RigidBodyState centre = tracking::toRigidBodyState(s, attitude, /*with_bias=*/false);
  // The filter follows the tracked point; the centre lies within centre_offset_sigma of it.
  centre.covariance.topLeftCorner<3, 3>() +=
      Eigen::Matrix3d::Identity() * std::pow(params_.centre_offset_sigma, 2);
  out.state.set(std::move(centre));
  out.point_state.set(std::move(point));
}

Status BearingFilterExtendedKalman::onProcess() {
  if (in.attitude.isFresh()) CDFF_RETURN_IF_ERROR(attitudes_.add(*in.attitude));
  if (in.imu.isFresh() && params_.use_imu)
    CDFF_RETURN_IF_ERROR(imu_.add(*in.imu, in.imu_mount.get()));
  std::optional<RadarSample> radar;
  if (in.radar.isFresh()) {
    Result<RadarSample> parsed = parseRadar(*in.radar);
    if (!parsed) return parsed.status();
    radar = *parsed;
  }
  const ImageRegion* m = in.measurement.isFresh() ? in.measurement.get() : nullptr;
  const ImageRegion* prediction = in.prediction.isFresh() ? in.prediction.get() : nullptr;
  if (m) CDFF_RETURN_IF_ERROR(m->validate().withContext("input 'measurement'"));
  if (!m && !prediction && !radar) return Status::ok();  // an attitude or IMU sample, kept

  // Work on a copy so that a failed call leaves the filter as it was.
  std::optional<RelativeState> next = state_;
  std::optional<RadarSample> latest_radar = latest_radar_;
  if (radar && radar->valid) latest_radar_ = radar;
  const Timestamp last_range = last_range_;
  auto fail = [&](Status s) {
    latest_radar_ = latest_radar;
    last_range_ = last_range;
    return s;
  };
  const bool radar_first = !m || (radar && radar->stamp <= m->stamp);
  if (radar_first && radar && radar->valid && next)
    if (Status s = fuseRadar(*radar, *next); !s) return fail(s);
  double nis = std::numeric_limits<double>::quiet_NaN();
  bool fused = false;
  const ImageRegion* at = nullptr;  // the image whose time the bearing is published at
  const bool designation = m && (m->source == "user" || m->source == "automatic");
  const bool lost =
      next && next->stamp - last_fix_ > static_cast<Timestamp>(params_.lost_after * 1e6);
  if (m && (!next || (designation && lost))) {
    Result<RelativeState> started = initialise(*m);
    if (!started) return fail(started.status().withContext("input 'measurement'"));
    if (next && next->hasBias()) {  // the accelerometer's bias outlives the track
      started->x.tail<3>() = next->x.tail<3>();
      started->covariance.bottomRightCorner<3, 3>() = next->covariance.bottomRightCorner<3, 3>();
    }
    next = *started;
    fused = true;
    at = m;
  } else if (m) {
    if (Status s = fuseImage(*m, *next, nis, fused); !s) return fail(s);
    at = m;
  } else if (prediction && next) {
    if (prediction->stamp < next->stamp)
      return fail(invalidInput(
          "input 'prediction' at t = {} us is older than the filter's time (t = {} us); expected "
          "images in time order",
          prediction->stamp, next->stamp));
    if (Status s = propagateTo(*next, prediction->stamp); !s) return fail(s);
    at = prediction;
  }
  if (designation) designation_ = m->source;
  if (fused) last_fix_ = next->stamp;
  if (at) {
    Eigen::Matrix3d attitude_cov;
    Result<tracking::BearingGeometry> g = geometryAt(at->stamp, at->frame_id, attitude_cov);
    if (g)
      out.bearing.set(bearingOf(*next, *g, attitude_cov));
    else
      warn(g.status().message());
  }
  if (!radar_first && radar && radar->valid && next)
    if (Status s = fuseRadar(*radar, *next); !s) return fail(s);
  state_ = next;
  if (state_) publishState(*state_);
  const bool tracking =
      state_ && state_->stamp - last_fix_ <= static_cast<Timestamp>(params_.lost_after * 1e6);
  out.track_state.set(!state_    ? TrackState::kUninitialised
                      : tracking ? TrackState::kTracking
                                 : TrackState::kLost);
  out.innovation_nis.set(nis);
  return Status::ok();
}

CDFF_REGISTER_DFI(BearingFilterExtendedKalman);

}  // namespace cdff::dfn
