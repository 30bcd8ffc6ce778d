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
  checks_.clear();
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
  if (!checks_.empty() && (stamp <= last_ || toSeconds(stamp - last_) > options_.timeout)) reset();
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
  checks_.push_back({std::move(difference), tracked_misfit, points.size()});
  if (static_cast<int>(checks_.size()) > options_.scans) checks_.pop_front();

  std::vector<double> sums(symmetries_.size(), 0.0);
  double tracked_sum = 0, returns = 0;
  for (const Check& c : checks_) {
    for (std::size_t k = 0; k < sums.size(); ++k) sums[k] += c.differences[k];
    tracked_sum += c.tracked_misfit;
    returns += static_cast<double>(c.returns);
  }
  const std::size_t best =
      static_cast<std::size_t>(std::min_element(sums.begin(), sums.end()) - sums.begin());
  const double advantage = -sums[best];
  verdict.significance = returns > 0 ? advantage / std::sqrt(returns) : 0.0;
  verdict.relative_advantage = tracked_sum > 0 ? advantage / tracked_sum : 0.0;
  verdict.scans = static_cast<int>(checks_.size());
  // The rival must be distinct on this scan too (its pose is the one reported).
  if (verdict.scans >= options_.scans && verdict.significance >= options_.min_significance &&
      verdict.relative_advantage >= options_.min_relative_advantage &&
      angleBetween(rivals[best], tracked) >= options_.distinct_angle) {
    verdict.better = rivals[best];
    checks_.clear();
  }
  return verdict;
}

}  // namespace cdff::registration
