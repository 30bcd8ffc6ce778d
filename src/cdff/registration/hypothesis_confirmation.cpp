#include "cdff/registration/hypothesis_confirmation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "cdff/registration/misfit.hpp"

namespace cdff::registration {

namespace {

constexpr double kSameHypothesisDistance = 0.05;           // m
constexpr double kSameHypothesisAngle = 2.0 * M_PI / 180;  // rad

/// `s` moved to a local minimum of `cost` by a pattern search along the six pose axes (steps
/// halving twice from 4 cm and 2 degrees, at most 4 passes each); returns the cost there.
double descend(IcpRun& s, const std::function<double(const IcpRun&)>& cost) {
  double best = cost(s);
  double shift = 0.04, turn = 2.0 * M_PI / 180;
  for (int level = 0; level < 3; ++level, shift /= 2, turn /= 2)
    for (int pass = 0; pass < 4; ++pass) {
      bool moved = false;
      for (int axis = 0; axis < 6; ++axis)
        for (const double sign : {-1.0, 1.0}) {
          IcpRun trial = s;
          if (axis < 3) {
            trial.pose.translation()[axis] += sign * shift;
          } else {
            const Eigen::Matrix3d rotation =
                Eigen::AngleAxisd(sign * turn, Eigen::Vector3d::Unit(axis - 3)).toRotationMatrix() *
                Eigen::Matrix3d(trial.pose.linear());
            trial.pose.linear() = rotation;
          }
          const double c = cost(trial);
          if (c < best) {
            best = c;
            s = trial;
            moved = true;
          }
        }
      if (!moved) break;
    }
  return best;
}

}  // namespace

bool HypothesisConfirmation::following(Timestamp stamp) const {
  return options_.scans > 0 && !hypotheses_.empty() && stamp > stamp_ &&
         toSeconds(stamp - stamp_) <= options_.timeout && scans_ < 4 * options_.scans;
}

void HypothesisConfirmation::keepDistinct() {
  std::sort(hypotheses_.begin(), hypotheses_.end(),
            [](const Hypothesis& a, const Hypothesis& b) { return a.misfit < b.misfit; });
  std::vector<Hypothesis> distinct;
  for (const Hypothesis& h : hypotheses_) {
    bool duplicate = false;
    for (const Hypothesis& d : distinct)
      duplicate = duplicate || ((h.run.pose.translation() - d.run.pose.translation()).norm() <
                                    kSameHypothesisDistance &&
                                Eigen::AngleAxisd(Eigen::Matrix3d(h.run.pose.linear()) *
                                                  Eigen::Matrix3d(d.run.pose.linear()).transpose())
                                        .angle() < kSameHypothesisAngle);
    if (!duplicate && static_cast<int>(distinct.size()) < options_.kept) distinct.push_back(h);
  }
  hypotheses_ = std::move(distinct);
}

void HypothesisConfirmation::startSet(const ScanEvidence& scan, const Eigen::Isometry3d& guess,
                                      std::span<const Start> starts) {
  const auto score = [&](const IcpRun& s) { return scan.misfit(s.pose); };
  hypotheses_.clear();
  scans_ = 0;
  returns_ = 0;
  for (const Start& c : starts)
    hypotheses_.push_back({c.run, c.run.pose * guess.inverse(), score(c.run)});
  // Only the kept ones are moved to their misfit's minimum (the search costs about a hundred
  // misfit evaluations each).
  keepDistinct();
  for (Hypothesis& h : hypotheses_) {
    h.misfit = descend(h.run, score);
    h.from_guess = h.run.pose * guess.inverse();
  }
}

// Each hypothesis moves with the guess, and by what the target's own motion since the last scan
// can add (the prior; the guess, an acquisition's prediction, may not know the motion yet): a
// damped run that keeps it in its own minimum instead of sliding along the directions a sparse
// scan leaves loose into another's. Its move is part of the misfit (the prior's negative
// log-likelihood, in the same units). A hypothesis that finds no overlap any more explains
// nothing of the scan.
Status HypothesisConfirmation::follow(const ScanEvidence& scan, const Eigen::Isometry3d& guess) {
  const ConfirmationOptions& o = options_;
  const double unexplained = 2.0 * kUnmatchedCost * static_cast<double>(scan.returns);
  const double dt = toSeconds(scan.stamp - stamp_);
  const double shift_sigma = std::max(1e-6, o.follow_shift_sigma * dt);
  const double turn_sigma = std::max(1e-9, o.follow_turn_sigma * dt);
  Vector6d prior;
  prior << Eigen::Vector3d::Constant(1.0 / (shift_sigma * shift_sigma)),
      Eigen::Vector3d::Constant(1.0 / (turn_sigma * turn_sigma));
  const double noise = o.inlier_distance / 3.0;
  const auto cost = [&](const IcpRun& at) {
    const Vector6d moved = at.fromAnchor();
    return scan.misfit(at.pose) + moved.dot(prior.cwiseProduct(moved));
  };
  for (Hypothesis& h : hypotheses_) {
    const Eigen::Isometry3d start = h.from_guess * guess;
    IcpRun s = IcpRun::startingAt(
        start, std::clamp(o.inlier_distance + 3.0 * shift_sigma, o.min_correspondence_distance,
                          o.max_correspondence_distance));
    s.anchor = start;
    s.anchor_precision = noise * noise * prior;
    Result<IcpRun> run = scan.run(s);
    if (!run) return run.status();
    s = std::move(run).value();
    if (s.starved) {
      h.misfit += unexplained;
      h.run.setPose(start);
    } else {
      h.misfit += descend(s, cost);
      h.run = s;
    }
    h.from_guess = h.run.pose * guess.inverse();
  }
  return Status::ok();
}

Result<ConfirmationResult> HypothesisConfirmation::update(const ScanEvidence& scan,
                                                          const Eigen::Isometry3d& guess,
                                                          std::span<const Start> starts) {
  if (!following(scan.stamp))
    startSet(scan, guess, starts);
  else
    CDFF_RETURN_IF_ERROR(follow(scan, guess));
  stamp_ = scan.stamp;
  ++scans_;
  returns_ += scan.returns;
  keepDistinct();
  ConfirmationResult result;
  if (hypotheses_.empty()) {
    result.ambiguous = true;
    return result;
  }
  // A single distinct hypothesis left (every start, or every followed one, ended in the same
  // minimum) has no rival for more scans to rule out: it is decided at once.
  const double margin = hypotheses_.size() > 1 ? hypotheses_[1].misfit - hypotheses_[0].misfit
                                               : std::numeric_limits<double>::infinity();
  const Hypothesis& best = hypotheses_.front();
  result.misfit_per_return = best.misfit / static_cast<double>(std::max<std::size_t>(1, returns_));
  const bool explains = options_.max_unexplained <= 0 ||
                        result.misfit_per_return <= kUnmatchedCost * options_.max_unexplained;
  result.ambiguous = !explains || (hypotheses_.size() > 1 &&
                                   (scans_ < options_.scans || margin < options_.margin));
  result.best = best.run;
  // Decided, or scored on enough scans without a hypothesis that explains them: a later scan
  // starts a new set (from its own guess).
  if (!result.ambiguous || (!explains && scans_ >= options_.scans)) hypotheses_.clear();
  return result;
}

}  // namespace cdff::registration
