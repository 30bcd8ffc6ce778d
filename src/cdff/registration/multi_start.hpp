#pragma once
// Multi-start acquisition from a poor guess: a sparse scan of a target that looks alike from
// several sides has local minima within the guess's error, into which a single ICP run falls.
// Every start (the guess's attitude and hypotheses - 1 turns of it, at the guess's position and
// at the scan-centred position) gets a short ICP run; the one that explains the scan best goes
// on to the full refinement, or the best distinct ones go on to the multi-scan confirmation
// (hypothesis_confirmation.hpp).

#include <cmath>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/registration/icp.hpp"
#include "cdff/registration/model_index.hpp"
#include "cdff/registration/quality.hpp"

namespace cdff::registration {

struct MultiStartOptions {
  int hypotheses = 1;                   // starting attitudes (1: the guess only, tracking)
  double angle = 10.0 * M_PI / 180;     // rad, the turn of the extra starts
  bool centroid = true;                 // also start from the scan-centred position
  double max_turn = 30.0 * M_PI / 180;  // rad: a start that ends farther from the guess is dropped
  int iterations = 15;                  // of each start's short run
  double min_visibility = 0;            // the least visibility of a start that may win (0: any)
};

/// A start's short run and how well it explains the scan.
struct Start {
  IcpRun run;
  Quality quality;
  double turned = 0;  // rad, its attitude's angle from the guess's
};

/// The starting rotations (applied to the guess in the sensor frame): none, then turns by
/// `angle` about `hypotheses` - 1 axes spread evenly over the sphere (a Fibonacci lattice), so
/// that a guess whose attitude error is about that angle has a start within a fraction of it.
std::vector<Eigen::Matrix3d> startTurns(int hypotheses, double angle);

/// The guess's position moved across the line of sight (from `viewpoint`) so that the model's
/// centroid (`model_centroid`, at the guess's attitude) lies on the line of sight to the scan's
/// centroid: a guess off by more than the target's size across the line of sight leaves the
/// ICP sliding the model along the scan into a wrong minimum, while the scan's centroid, across
/// the line of sight, is within a fraction of the target's size of its centre. Its depth stays
/// the guess's.
Eigen::Vector3d centredPosition(std::span<const Eigen::Vector3f> points,
                                const Eigen::Isometry3d& guess,
                                const Eigen::Vector3d& model_centroid,
                                const Eigen::Vector3f& viewpoint);

/// `position` and, when the guess's position covariance leaves its depth along the line of
/// sight from `viewpoint` uncertain by more than `resolution` (m: starts closer than that share
/// a basin), the positions 1 and 2 standard deviations nearer and farther along that line. The
/// scan fixes the target across the line of sight (centredPosition) but not its depth, and a
/// start a metre too deep or too shallow slides the model along the scan into a wrong minimum.
std::vector<Eigen::Vector3d> depthStarts(const Eigen::Vector3d& position,
                                         const Eigen::Matrix3d& position_covariance,
                                         const Eigen::Vector3f& viewpoint, double resolution);

/// Every start (each of `turns` applied to the guess's attitude, at each of `positions`) run
/// for options.iterations ICP iterations from the ICP's max correspondence distance; those that
/// starved or turned farther than options.max_turn from the guess are dropped (they found
/// another view of the target). Sorted by fitness, best first.
Result<std::vector<Start>> runStarts(Icp& icp, std::span<const Eigen::Vector3f> points,
                                     const ModelIndex& model, const Eigen::Isometry3d& guess,
                                     std::span<const Eigen::Vector3d> positions,
                                     std::span<const Eigen::Matrix3d> turns,
                                     const MultiStartOptions& options,
                                     const QualityOptions& quality);

/// More inliers (by more than 2 % of the scan); or as many with an inlier RMS smaller by more
/// than 10 %; or a fit as good nearer the guess (`turn`: the angle from the guess's attitude),
/// which is then the best information left.
bool betterFit(const Quality& a, double a_turn, const Quality& b, double b_turn);

/// The start to refine among `starts` (sorted by fitness): the best fit (betterFit) among those
/// within 2 % of the best fitness whose visibility (when `visibility` is set and min_visibility
/// > 0) is at least min_visibility; the visibility (a pass over the model) is computed only for
/// starts whose fitness could still win. None when no start qualifies.
std::optional<IcpRun> chooseStart(std::span<const Start> starts,
                                  const std::function<double(const Eigen::Isometry3d&)>& visibility,
                                  double min_visibility);

}  // namespace cdff::registration
