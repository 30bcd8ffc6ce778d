#pragma once
// The servicer's measured thrust as the far-range model's control input (docs/far-range-
// tracking.md, "The IMU"). In orbit an accelerometer measures the thrust (gravity acts on its
// proof mass and case alike), so between two filter times the relative state
// p = target - servicer obeys the Clohessy-Wiltshire equations driven by
// -lvlh_R_servicer (f - b): f the measured specific force, b the accelerometer's bias, which
// the state carries (RelativeState's x.tail<3>(), servicer axes) because the turn-on bias alone
// (0.02 m/s^2 on the seed's MTi) taken as thrust moves the prediction 36 m in a minute.
// The lever arm terms (alpha x r, omega x (omega x r)) of the IMU's offset on the servicer are
// left in the unmodelled acceleration (acceleration_psd).

#include <deque>
#include <vector>

#include <Eigen/Core>

#include "cdff/tracking/relative_motion.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/sensors.hpp"

namespace cdff::tracking {

/// The accelerometer as its datasheet describes it.
struct AccelerometerModel {
  double noise_density =
      0;                  ///< m/s^2/sqrt(Hz): the measured thrust's white noise PSD is its square
  double bias_sigma = 0;  ///< m/s^2 per axis: the turn-on bias, the bias states' initial sigma
  double bias_random_walk = 0;  ///< m/s^2/sqrt(s): the bias states' random walk
};

/// One sample's measured specific force, held from `from` to `to`, with the servicer's
/// attitude at the sample (lvlh_R_servicer).
struct ThrustSpan {
  Timestamp from = 0, to = 0;
  Eigen::Vector3d specific_force = Eigen::Vector3d::Zero();  ///< servicer axes, m/s^2
  Eigen::Matrix3d lvlh_R_servicer = Eigen::Matrix3d::Identity();
};

/// The measured thrust over an interval: its spans in time order; the interval's rest is
/// unmeasured (propagated as without an IMU).
struct MeasuredThrust {
  std::vector<ThrustSpan> spans;
  AccelerometerModel model;
  int samples_without_attitude = 0;  ///< samples left out: no attitude near their time
};

/// The last IMU samples, rotated into the servicer frame by the IMU's mounting as they come (the
/// only per-sample work: the filter sees every 120 Hz sample).
class ImuHistory {
 public:
  /// A sample may hold for at most this long (an IMU that stops is not thrusting for ever).
  static constexpr Timestamp kMaxHold = 100'000;  // us: 12 samples at 120 Hz

  /// Adds a sample; errors (naming input 'imu'): a non-finite value, no `mount` (servicer_T_imu)
  /// or one for another frame, a sample older than the last one.
  Status add(const ImuSample& sample, const Transform* mount);
  /// The spans of [t0, t1]: each sample holds until the next one, or kMaxHold; its attitude is
  /// the servicer's at its time (`attitudes.at(stamp, tolerance)`); a sample without one is left
  /// out (counted).
  MeasuredThrust between(Timestamp t0, Timestamp t1, const AttitudeHistory& attitudes,
                         double tolerance, const AccelerometerModel& model) const;
  bool empty() const { return samples_.empty(); }

 private:
  struct Sample {
    Timestamp stamp;
    Eigen::Vector3d specific_force;  // servicer axes
  };
  std::deque<Sample> samples_;  // by stamp, the last 2048 (17 s at 120 Hz)
};

/// Propagates `s` to `stamp` (forward only) with the measured thrust as the control input of the
/// Clohessy-Wiltshire model and its bias in the state: sample by sample, x <- Phi(dt) x +
/// Gamma(dt) lvlh_R_servicer (b - f), Gamma = integral of Phi(dt - tau) [0; I] (3-point
/// Gauss-Legendre); the covariance once, through the interval's transition and the Jacobian of
/// the state on b, plus `psd` (what is not measured) over the whole interval, the accelerometer's
/// noise density squared over the measured part and its bias random walk. The first measured
/// span starts the bias states (b = 0, sigma bias_sigma) if they are not yet in use. Without
/// spans it is propagate() above, to the bit.
Status propagate(RelativeState& s, Timestamp stamp, double mean_motion, double psd,
                 const MeasuredThrust& thrust);

}  // namespace cdff::tracking
