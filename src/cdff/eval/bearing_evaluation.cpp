#include "cdff/eval/bearing_evaluation.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>

namespace cdff::eval {

namespace {

// The 2-dof NEES of the direction error across the estimated direction: the covariance's
// two-dimensional part across it (its rank), NaN when it is not positive definite there.
double directionNees(const Eigen::Vector3d& estimate, const Eigen::Vector3d& truth,
                     const Eigen::Matrix3d& covariance) {
  if (!covariance.allFinite()) return BearingError::kNaN;
  // Two unit vectors across the estimate.
  const Eigen::Vector3d a = estimate.unitOrthogonal(), b = estimate.cross(a);
  Eigen::Matrix<double, 3, 2> across;
  across << a, b;
  const Eigen::Matrix2d c =
      across.transpose() * (0.5 * (covariance + covariance.transpose())) * across;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(c);
  if (eigen.eigenvalues().minCoeff() <= 0) return BearingError::kNaN;
  // The error's components across the estimate (the small angles that take it to the truth).
  const Eigen::Vector2d e = across.transpose() * (truth - estimate);
  return e.dot(c.inverse() * e);
}

BearingConsistency bearingConsistencyOf(const std::vector<BearingError>& errors,
                                        std::size_t rejected) {
  BearingConsistency c;
  c.rejected = rejected;
  std::vector<double> nees;
  double within = 0, range_sum = 0;
  std::size_t ranges = 0;
  for (const BearingError& e : errors) {
    if (std::isfinite(e.range_nees)) {
      range_sum += e.range_nees;
      ++ranges;
    }
    if (!std::isfinite(e.nees)) continue;
    nees.push_back(e.nees);
    if (e.nees <= BearingConsistency::kChiSquare2Dof95) ++within;
  }
  if (ranges) c.range_nees_mean = range_sum / static_cast<double>(ranges);
  c.count = nees.size();
  if (nees.empty()) return c;
  double sum = 0;
  for (double v : nees) sum += v;
  c.nees_mean = sum / static_cast<double>(nees.size());
  c.within_95_fraction = within / static_cast<double>(nees.size());
  c.nees_p95 = ErrorStatistics::of(std::move(nees)).p95;
  return c;
}

Status checkBearingInputs(const std::vector<BearingSample>& estimates,
                          const std::vector<Transform>& truth) {
  for (std::size_t i = 1; i < estimates.size(); ++i)
    if (estimates[i].bearing.stamp < estimates[i - 1].bearing.stamp)
      return invalidInput(
          "bearing {} at t = {} us is older than the one before it ({} us); expected bearings "
          "in time order",
          i, estimates[i].bearing.stamp, estimates[i - 1].bearing.stamp);
  for (std::size_t i = 1; i < truth.size(); ++i)
    if (truth[i].stamp < truth[i - 1].stamp)
      return invalidInput(
          "truth sample {} at t = {} us is older than the one before it ({} us); expected "
          "samples in time order",
          i, truth[i].stamp, truth[i - 1].stamp);
  if (truth.empty()) return Status::ok();
  for (const BearingSample& e : estimates)
    if (e.bearing.frame_id != truth.front().parent_frame)
      return invalidInput(
          "bearing at t = {} us is in frame '{}'; the truth is {}_T_{}: expected the truth's "
          "parent frame to be the bearings' frame",
          e.bearing.stamp, e.bearing.frame_id, truth.front().parent_frame,
          truth.front().child_frame);
  return Status::ok();
}

}  // namespace

Result<BearingEvaluation> evaluateBearings(const std::vector<BearingSample>& estimates,
                                           const std::vector<Transform>& truth, double focal_px,
                                           const PoseEvaluationOptions& options) {
  CDFF_RETURN_IF_ERROR(checkBearingInputs(estimates, truth));
  BearingEvaluation result;
  result.focal_px = focal_px;
  if (!truth.empty()) result.frame = truth.front().parent_frame;

  std::vector<double> angle, pixels, range_pct, latency;
  std::size_t rejected = 0;
  UpdateRates rates;
  result.frames = estimates.size();
  for (const BearingSample& s : estimates) {
    const Bearing& b = s.bearing;
    // A direction that is not finite and unit is not a bearing the DFPC can stand by.
    const bool usable =
        s.valid && b.direction.allFinite() && std::abs(b.direction.norm() - 1.0) < 1e-6;
    if (!usable) continue;
    rates.add(b.stamp);
    ++result.valid_frames;
    if (s.latency_s) latency.push_back(*s.latency_s);

    const std::optional<Transform> reference = truthAt(truth, b.stamp, options);
    if (!reference) continue;
    BearingError e;
    e.stamp = b.stamp;
    e.range_m = reference->translation.norm();
    if (!(e.range_m > 0)) continue;
    const Eigen::Vector3d u = reference->translation / e.range_m;
    // atan2 of the cross and dot products: accurate at microradians, where acos is not.
    const double angle_rad = std::atan2(b.direction.cross(u).norm(), b.direction.dot(u));
    e.angle_urad = angle_rad * 1e6;
    if (std::isfinite(focal_px)) e.pixels = angle_rad * focal_px;
    // An all-zero covariance is none (not a rejected one).
    if (!b.covariance.isZero(0)) {
      e.nees = directionNees(b.direction, u, b.covariance);
      if (!std::isfinite(e.nees)) ++rejected;
    }
    if (std::isfinite(b.range)) {
      e.range_error_pct = 100.0 * (b.range - e.range_m) / e.range_m;
      range_pct.push_back(std::abs(e.range_error_pct));
      if (b.range_variance > 0) e.range_nees = std::pow(b.range - e.range_m, 2) / b.range_variance;
    }
    angle.push_back(e.angle_urad);
    if (std::isfinite(e.pixels)) pixels.push_back(e.pixels);
    result.errors.push_back(e);
  }
  result.matched_frames = result.errors.size();
  result.ranged_frames = range_pct.size();
  result.tracked_fraction =
      result.frames ? static_cast<double>(result.valid_frames) / result.frames : 0.0;
  result.angle_urad = ErrorStatistics::of(std::move(angle));
  result.pixels = ErrorStatistics::of(std::move(pixels));
  result.range_error_pct = ErrorStatistics::of(std::move(range_pct));
  result.latency_s = ErrorStatistics::of(std::move(latency));
  result.covariance = bearingConsistencyOf(result.errors, rejected);
  result.rate_hz = rates.meanHz();
  result.min_rate_hz = rates.worstHz();
  if (!result.errors.empty()) {
    const auto [lo, hi] = std::minmax_element(
        result.errors.begin(), result.errors.end(),
        [](const BearingError& a, const BearingError& b) { return a.range_m < b.range_m; });
    result.min_range_m = lo->range_m;
    result.max_range_m = hi->range_m;
  }
  return result;
}

}  // namespace cdff::eval
