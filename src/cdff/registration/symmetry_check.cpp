#include "cdff/registration/symmetry_check.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "cdff/types/time.hpp"

namespace cdff::registration {

void SymmetryCheck::configure(const SymmetryCheckOptions& options) {
  options_ = options;
  icp_.configure(options.icp);
  reset();
}

void SymmetryCheck::setModel(const ModelSearch& model,
                             std::span<const Eigen::Isometry3d> symmetries) {
  icp_.setModel(model);
  symmetries_.assign(symmetries.begin(), symmetries.end());
  reset();
}

void SymmetryCheck::reset() {
  differences_.clear();
  tracked_misfits_.clear();
  returns_.clear();
  last_ = 0;
}

namespace {

double angleBetween(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

}  // namespace

Result<SymmetryVerdict> SymmetryCheck::check(
    std::span<const Eigen::Vector3f> points, const Eigen::Isometry3d& tracked, Timestamp stamp,
    const std::function<double(const Eigen::Isometry3d&)>& misfit) {
  SymmetryVerdict verdict;
  if (symmetries_.empty()) return verdict;
  if (!differences_.empty() && (stamp <= last_ || toSeconds(stamp - last_) > options_.timeout))
    reset();
  last_ = stamp;

  const double tracked_misfit = misfit(tracked);
  std::vector<double> difference(symmetries_.size(), 0.0);
  std::vector<Eigen::Isometry3d> rivals(symmetries_.size(), tracked);
  for (std::size_t k = 0; k < symmetries_.size(); ++k) {
    Result<IcpRun> run = icp_.iterate(
        points,
        IcpRun::startingAt(tracked * symmetries_[k], options_.icp.max_correspondence_distance),
        options_.iterations);
    if (!run) return run.status();
    if (run->starved || angleBetween(run->pose, tracked) < options_.distinct_angle) continue;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::Quaterniond(run->pose.linear()).normalized().toRotationMatrix();
    pose.translation() = run->pose.translation();
    rivals[k] = pose;
    difference[k] = misfit(pose) - tracked_misfit;
  }
  differences_.push_back(std::move(difference));
  tracked_misfits_.push_back(tracked_misfit);
  returns_.push_back(points.size());
  if (static_cast<int>(differences_.size()) > options_.scans) {
    differences_.pop_front();
    tracked_misfits_.pop_front();
    returns_.pop_front();
  }

  std::vector<double> sums(symmetries_.size(), 0.0);
  for (const std::vector<double>& d : differences_)
    for (std::size_t k = 0; k < sums.size(); ++k) sums[k] += d[k];
  double tracked_sum = 0, returns = 0;
  for (double m : tracked_misfits_) tracked_sum += m;
  for (std::size_t n : returns_) returns += static_cast<double>(n);
  const std::size_t best =
      static_cast<std::size_t>(std::min_element(sums.begin(), sums.end()) - sums.begin());
  verdict.advantage = -sums[best];
  verdict.significance = returns > 0 ? -sums[best] / std::sqrt(returns) : 0.0;
  verdict.relative_advantage = tracked_sum > 0 ? -sums[best] / tracked_sum : 0.0;
  verdict.scans = static_cast<int>(differences_.size());
  // The rival must be distinct on this scan too (its pose is the one reported).
  if (verdict.scans >= options_.scans && verdict.significance >= options_.min_significance &&
      verdict.relative_advantage >= options_.min_relative_advantage &&
      angleBetween(rivals[best], tracked) >= options_.distinct_angle) {
    verdict.better = rivals[best];
    const Timestamp last = last_;
    reset();
    last_ = last;
  }
  return verdict;
}

}  // namespace cdff::registration
