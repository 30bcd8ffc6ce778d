#include "cdff/eval/pose_evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

namespace cdff::eval {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRadToDeg = 180.0 / M_PI;

// The 95th percentile with linear interpolation between order statistics (the "type 7"
// estimator of Hyndman and Fan, as numpy's default), so that small sets give stable values.
double percentile(std::vector<double>& sorted, double p) {
  const double position = p * static_cast<double>(sorted.size() - 1);
  const std::size_t below = static_cast<std::size_t>(std::floor(position));
  const std::size_t above = std::min(below + 1, sorted.size() - 1);
  const double fraction = position - static_cast<double>(below);
  return sorted[below] + fraction * (sorted[above] - sorted[below]);
}

Transform interpolate(const Transform& a, const Transform& b, Timestamp stamp) {
  const double s = static_cast<double>(stamp - a.stamp) / static_cast<double>(b.stamp - a.stamp);
  Transform t = a;
  t.stamp = stamp;
  t.translation = (1.0 - s) * a.translation + s * b.translation;
  t.rotation = a.rotation.slerp(s, b.rotation).normalized();
  return t;
}

template <typename T, typename StampOf>
Status checkSorted(const std::vector<T>& series, StampOf stamp_of, const char* what) {
  for (std::size_t i = 1; i < series.size(); ++i)
    if (stamp_of(series[i]) < stamp_of(series[i - 1]))
      return invalidInput(
          "{} sample {} at t = {} us is older than the one before it ({} us); "
          "expected samples in time order",
          what, i, stamp_of(series[i]), stamp_of(series[i - 1]));
  return Status::ok();
}

// e^T C^-1 e, NaN when C is not positive definite.
template <int N>
double normalisedSquare(const Eigen::Matrix<double, N, N>& c,
                        const Eigen::Matrix<double, N, 1>& e) {
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(c);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  return e.dot(llt.solve(e));
}

// Fills the NEES fields of `m`; false when the covariance is not finite and positive definite.
bool normalisedErrors(const Transform& estimate, const Transform& truth, const Matrix6d& covariance,
                      bool attitude_observed, MatchedError& m) {
  if (!covariance.allFinite()) return false;
  Vector6d error;
  error << truth.translation - estimate.translation,
      logSO3((truth.rotation * estimate.rotation.conjugate()).normalized());
  const Matrix6d c = 0.5 * (covariance + covariance.transpose());
  m.position_nees = normalisedSquare<3>(c.topLeftCorner<3, 3>(), error.head<3>());
  if (!attitude_observed) return std::isfinite(m.position_nees);
  m.nees = normalisedSquare<6>(c, error);
  if (!std::isfinite(m.nees)) return false;
  m.attitude_nees = normalisedSquare<3>(c.bottomRightCorner<3, 3>(), error.tail<3>());
  return true;
}

/// Whether a covariance observes the attitude (kUnobservedAttitudeSigmaDeg).
bool attitudeObserved(const std::optional<Matrix6d>& covariance) {
  if (!covariance) return true;
  const double bound = kUnobservedAttitudeSigmaDeg * M_PI / 180.0;
  return covariance->bottomRightCorner<3, 3>().diagonal().maxCoeff() <= bound * bound;
}

CovarianceConsistency consistencyOf(const std::vector<MatchedError>& errors, std::size_t rejected) {
  CovarianceConsistency c;
  c.rejected = rejected;
  std::vector<double> nees;
  double position = 0, attitude = 0;
  std::size_t positions = 0;
  for (const MatchedError& e : errors) {
    // An estimate with an unobserved attitude counts in the position's consistency only.
    if (std::isfinite(e.position_nees)) {
      position += e.position_nees;
      ++positions;
    }
    if (!std::isfinite(e.nees)) continue;
    nees.push_back(e.nees);
    attitude += e.attitude_nees;
  }
  c.count = nees.size();
  if (positions > 0) c.position_nees_mean = position / static_cast<double>(positions);
  if (nees.empty()) return c;
  const double n = static_cast<double>(nees.size());
  double sum = 0, within = 0;
  for (double v : nees) {
    sum += v;
    if (v <= CovarianceConsistency::kChiSquare6Dof95) ++within;
  }
  c.nees_mean = sum / n;
  c.within_95_fraction = within / n;
  c.attitude_nees_mean = attitude / n;
  std::sort(nees.begin(), nees.end());
  c.nees_p95 = percentile(nees, 0.95);
  return c;
}

}  // namespace

double poseNees(const Transform& estimate, const Transform& truth, const Matrix6d& covariance) {
  MatchedError m;
  return normalisedErrors(estimate, truth, covariance, true, m)
             ? m.nees
             : std::numeric_limits<double>::quiet_NaN();
}

ErrorStatistics ErrorStatistics::of(std::vector<double> errors) {
  ErrorStatistics s;
  s.count = errors.size();
  if (errors.empty()) {
    s.rmse = s.p95 = s.max = kNaN;
    return s;
  }
  std::sort(errors.begin(), errors.end());
  double sum_squares = 0;
  for (double e : errors) sum_squares += e * e;
  s.rmse = std::sqrt(sum_squares / static_cast<double>(errors.size()));
  s.p95 = percentile(errors, 0.95);
  s.max = errors.back();
  return s;
}

std::optional<Transform> truthAt(const std::vector<Transform>& truth, Timestamp stamp,
                                 const PoseEvaluationOptions& options) {
  if (truth.empty()) return std::nullopt;
  const auto after = std::lower_bound(truth.begin(), truth.end(), stamp,
                                      [](const Transform& t, Timestamp s) { return t.stamp < s; });
  if (after != truth.end() && after->stamp == stamp) return *after;
  const Timestamp max_gap = fromSeconds(options.max_truth_gap_s);
  if (after != truth.begin() && after != truth.end()) {
    const Transform& before = *std::prev(after);
    if (after->stamp - before.stamp <= max_gap) return interpolate(before, *after, stamp);
  }
  // No bracketing pair: accept the closest sample only when it is (almost) simultaneous.
  const Timestamp tolerance = fromSeconds(options.nearest_truth_tolerance_s);
  const Transform* nearest = nullptr;
  if (after != truth.end()) nearest = &*after;
  if (after != truth.begin()) {
    const Transform& before = *std::prev(after);
    if (!nearest || stamp - before.stamp < nearest->stamp - stamp) nearest = &before;
  }
  if (nearest && std::llabs(nearest->stamp - stamp) <= tolerance) {
    Transform t = *nearest;
    t.stamp = stamp;
    return t;
  }
  return std::nullopt;
}

Result<PoseEvaluation> evaluatePoses(const std::vector<EstimateSample>& estimates,
                                     const std::vector<Transform>& truth,
                                     const PoseEvaluationOptions& options) {
  CDFF_RETURN_IF_ERROR(checkSorted(
      estimates, [](const EstimateSample& e) { return e.pose.stamp; }, "estimate"));
  CDFF_RETURN_IF_ERROR(checkSorted(
      truth, [](const Transform& t) { return t.stamp; }, "truth"));

  PoseEvaluation result;
  if (!truth.empty()) {
    result.parent_frame = truth.front().parent_frame;
    result.child_frame = truth.front().child_frame;
  }
  for (const EstimateSample& e : estimates) {
    if (!truth.empty() &&
        (e.pose.parent_frame != result.parent_frame || e.pose.child_frame != result.child_frame))
      return invalidInput(
          "estimate at t = {} us is {}_T_{}; the truth is {}_T_{}: expected the "
          "same transform in both series",
          e.pose.stamp, e.pose.parent_frame, e.pose.child_frame, result.parent_frame,
          result.child_frame);
    CDFF_RETURN_IF_ERROR(
        e.pose.validate().withContext(fmt::format("estimate at t = {} us", e.pose.stamp)));
  }

  std::vector<double> position, percent, angle, latency;
  std::size_t rejected_covariances = 0;
  UpdateRates rates;
  result.frames = estimates.size();
  for (const EstimateSample& e : estimates) {
    if (!e.valid) continue;
    rates.add(e.pose.stamp);
    ++result.valid_frames;
    if (e.latency_s) latency.push_back(*e.latency_s);

    const std::optional<Transform> reference = truthAt(truth, e.pose.stamp, options);
    if (!reference) continue;
    MatchedError m;
    m.stamp = e.pose.stamp;
    m.range_m = reference->translation.norm();
    m.position_error_m = (e.pose.translation - reference->translation).norm();
    const bool attitude_observed = attitudeObserved(e.covariance);
    m.angle_error_deg = attitude_observed
                            ? angularDistance(e.pose.rotation, reference->rotation) * kRadToDeg
                            : std::numeric_limits<double>::quiet_NaN();
    position.push_back(m.position_error_m);
    if (attitude_observed) angle.push_back(m.angle_error_deg);
    if (m.range_m > 0) percent.push_back(100.0 * m.position_error_m / m.range_m);
    if (e.covariance && !normalisedErrors(e.pose, *reference, *e.covariance, attitude_observed, m))
      ++rejected_covariances;
    result.errors.push_back(m);
  }
  result.matched_frames = result.errors.size();
  result.tracked_fraction =
      result.frames ? static_cast<double>(result.valid_frames) / result.frames : 0.0;
  result.position_error_m = ErrorStatistics::of(std::move(position));
  result.position_error_pct_range = ErrorStatistics::of(std::move(percent));
  result.angle_error_deg = ErrorStatistics::of(std::move(angle));
  result.latency_s = ErrorStatistics::of(std::move(latency));
  result.covariance = consistencyOf(result.errors, rejected_covariances);
  result.continuity = continuityOf(estimates);

  result.rate_hz = rates.meanHz();
  result.min_rate_hz = rates.worstHz();
  if (!result.errors.empty()) {
    const auto [lo, hi] = std::minmax_element(
        result.errors.begin(), result.errors.end(),
        [](const MatchedError& a, const MatchedError& b) { return a.range_m < b.range_m; });
    result.min_range_m = lo->range_m;
    result.max_range_m = hi->range_m;
  }
  return result;
}

double Continuity::maxWithin(Timestamp from, Timestamp to) const {
  double worst = std::numeric_limits<double>::quiet_NaN();
  for (const Step& s : steps)
    if (s.stamp >= from && s.stamp <= to && !(s.sigma <= worst)) worst = s.sigma;
  return worst;
}

Continuity continuityOf(const std::vector<EstimateSample>& estimates) {
  Continuity c;
  const EstimateSample* previous = nullptr;
  for (const EstimateSample& e : estimates) {
    if (!e.valid) {
      previous = nullptr;
      continue;
    }
    if (!e.twist) return {};
    if (e.restarted) previous = nullptr;
    if (previous && previous->covariance) {
      Transform moved = previous->pose;
      if (previous->twist) {
        const double dt = toSeconds(e.pose.stamp - previous->pose.stamp);
        moved.translation += previous->twist->linear * dt;
        moved.rotation = (expSO3(previous->twist->angular * dt) * moved.rotation).normalized();
      }
      const double nees = poseNees(moved, e.pose, *previous->covariance);
      if (std::isfinite(nees)) {
        const double sigma = std::sqrt(nees);
        c.steps.push_back({e.pose.stamp, sigma});
        if (sigma > Continuity::kJumpSigma) ++c.jumps;
        if (!(sigma <= c.max_sigma)) {
          c.max_sigma = sigma;
          c.worst_stamp = e.pose.stamp;
        }
      }
    }
    previous = &e;
  }
  return c;
}

std::vector<MatchedError> inRange(const std::vector<MatchedError>& errors, double min_range_m,
                                  double max_range_m) {
  std::vector<MatchedError> selected;
  for (const MatchedError& e : errors)
    if (e.range_m >= min_range_m && e.range_m < max_range_m) selected.push_back(e);
  return selected;
}

}  // namespace cdff::eval
