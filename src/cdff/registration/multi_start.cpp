#include "cdff/registration/multi_start.hpp"

#include <algorithm>
#include <cmath>

namespace cdff::registration {

std::vector<Eigen::Matrix3d> startTurns(int hypotheses, double angle) {
  std::vector<Eigen::Matrix3d> turns(1, Eigen::Matrix3d::Identity());
  const int n = hypotheses - 1;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / n;
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Eigen::Vector3d axis(rho * std::cos(golden * k), rho * std::sin(golden * k), z);
    turns.push_back(Eigen::AngleAxisd(angle, axis).toRotationMatrix());
  }
  return turns;
}

Eigen::Vector3d centredPosition(std::span<const Eigen::Vector3f> points,
                                const Eigen::Isometry3d& guess,
                                const Eigen::Vector3d& model_centroid,
                                const Eigen::Vector3f& viewpoint) {
  Eigen::Vector3d scan = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& p : points) scan += p.cast<double>();
  scan /= static_cast<double>(std::max<std::size_t>(1, points.size()));
  const Eigen::Vector3d centre = guess * model_centroid;
  const Eigen::Vector3d sight = (centre - viewpoint.cast<double>()).normalized();
  Eigen::Vector3d offset = scan - centre;
  offset -= offset.dot(sight) * sight;
  return guess.translation() + offset;
}

std::vector<Eigen::Vector3d> depthStarts(const Eigen::Vector3d& position,
                                         const Eigen::Matrix3d& position_covariance,
                                         const Eigen::Vector3f& viewpoint, double resolution) {
  std::vector<Eigen::Vector3d> positions{position};
  const Eigen::Vector3d sight = (position - viewpoint.cast<double>()).normalized();
  const double sigma = std::sqrt(std::max(0.0, sight.dot(position_covariance * sight)));
  if (!std::isfinite(sigma) || sigma <= resolution) return positions;
  for (const double k : {-2.0, -1.0, 1.0, 2.0}) positions.push_back(position + k * sigma * sight);
  return positions;
}

Result<std::vector<Start>> runStarts(Icp& icp, std::span<const Eigen::Vector3f> points,
                                     const ModelIndex& model, const Eigen::Isometry3d& guess,
                                     std::span<const Eigen::Vector3d> positions,
                                     std::span<const Eigen::Matrix3d> turns,
                                     const MultiStartOptions& options,
                                     const QualityOptions& quality) {
  std::vector<Start> starts;
  for (const Eigen::Vector3d& position : positions)
    for (const Eigen::Matrix3d& turn : turns) {
      IcpRun start;
      // Turned about the model's origin: its position in the sensor frame stays put.
      start.pose.linear() = turn * guess.linear();
      start.pose.translation() = position;
      start.distance = icp.options().max_correspondence_distance;
      Result<IcpRun> run = icp.iterate(points, start, options.iterations);
      if (!run) return run.status();
      start = std::move(run).value();
      // The guess's error is about the start angle: a start that turned much farther than that
      // found another minimum (a symmetric view of the target), not the pose.
      const double turned =
          Eigen::AngleAxisd(Eigen::Matrix3d(start.pose.linear()) * guess.linear().transpose())
              .angle();
      if (start.starved || turned > options.max_turn) continue;
      starts.push_back({start,
                        evaluate(points, model, start.pose, quality.inlier_distance,
                                 quality.covariance_inflation),
                        turned});
    }
  std::sort(starts.begin(), starts.end(),
            [](const Start& a, const Start& b) { return a.quality.fitness > b.quality.fitness; });
  return starts;
}

bool betterFit(const Quality& a, double a_turn, const Quality& b, double b_turn) {
  if (a.fitness > b.fitness + 0.02) return true;
  if (a.fitness < b.fitness - 0.02) return false;
  if (a.inlier_rms < 0.9 * b.inlier_rms) return true;
  if (b.inlier_rms < 0.9 * a.inlier_rms) return false;
  return a_turn < b_turn;
}

std::optional<IcpRun> chooseStart(std::span<const Start> starts,
                                  const std::function<double(const Eigen::Isometry3d&)>& visibility,
                                  double min_visibility) {
  const Start* best = nullptr;
  for (const Start& c : starts) {
    if (best && c.quality.fitness < best->quality.fitness - 0.02) break;
    if (visibility && min_visibility > 0 && visibility(c.run.pose) < min_visibility) continue;
    if (!best || betterFit(c.quality, c.turned, best->quality, best->turned)) best = &c;
  }
  if (!best) return std::nullopt;
  return best->run;
}

}  // namespace cdff::registration
