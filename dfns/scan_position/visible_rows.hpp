#pragma once
// The part of a target model that a sparse LIDAR scan sees, over every attitude: ScanPosition's
// model of where the origin lies behind the centroid of the returns.
//
// The model is seen from a viewpoint on the line of sight (-x, at a distance from its origin)
// at a fixed, deterministic set of attitudes spread evenly over SO(3). Each point is projected
// onto the plane through the origin across the line of sight (central projection, as the
// sensor's rays go); per attitude, the nearest point in each cell of a fine grid on that plane
// is the visible surface, sampled uniformly in angle as a scan samples it, and its cells are
// summed per row (z). A scan's lasers sweep cones of constant elevation, which cross the target
// along rows of constant projected z: the returns' centroid is the centroid of the rows the
// lasers hit. Per scan, offsets() places the lasers' rows at every phase across one gap between
// them and gives the statistics of (origin - centroid of the rows hit) over attitudes and
// phases. With lasers as fine as the grid it is the centroid of the whole visible surface.

#include <cstddef>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff::dfn::scan_position {

/// Statistics of origin - centroid over attitudes and ring phases, in the line-of-sight frame:
/// x along the line of sight (depth, away from the sensor), z across it towards the sensor's up
/// (across the rings), y = z x x (along the rings).
struct OffsetStatistics {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();        // m
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // m^2, over attitudes and phases
  /// The part of `covariance` that comes from the attitude alone: the spread over attitudes of
  /// each attitude's phase-averaged offset (law of total covariance; the rest is the spread
  /// over the rings' phase at a fixed attitude).
  Eigen::Matrix3d attitude = Eigen::Matrix3d::Zero();
  std::size_t samples = 0;  // attitude x phase draws in which some laser hit the target
};

/// A target model ready to be viewed: its points about its origin (thinned to what the grid
/// needs), its radius R and the grid's cell.
struct ViewableModel {
  Eigen::Matrix3Xf points;
  double radius = 0;  // R: the largest distance of a point from the origin, m
  /// The larger of R/50 and twice the model's point spacing (so that a cell of a surface
  /// facing the sensor holds a point: a hole would show the surface behind it), m.
  double cell = 0;

  /// From finite points in the target frame; an error when every point is at the origin.
  static Result<ViewableModel> of(const PointCloud& model);
};

/// What is known of the scan: which draws give a scan that is measured (those with at least
/// `min_returns` returns), and how far its returns spread along the rings, which the draws
/// that count must resemble.
struct ScanShape {
  /// The distance between neighbouring returns along a ring at the target (m; its azimuth
  /// step times the range); 0: unknown (each visible cell a laser crosses is one return).
  double return_spacing = 0;
  int min_returns = 1;
  /// The standard deviation of the returns' positions along the rings (y, m) and their number;
  /// returns == 0: not known (every draw counts alike).
  double along_ring_spread = 0;
  int returns = 0;
};

/// One row of the visible surface at one attitude: its points (one per grid cell) in the
/// line-of-sight frame.
struct VisibleRow {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();  // of the points, m
  double sum_yy = 0;                              // of their y^2 (along the rings), m^2
  double count = 0;
};

class VisibleRows {
 public:
  /// The rows of `model` seen at `attitudes` attitudes from `view_distance` m (at least 2 R:
  /// nearer, from 2 R).
  static VisibleRows build(const ViewableModel& model, int attitudes, double view_distance);

  double viewDistance() const { return view_distance_; }  // m
  double cellSize() const { return cell_; }               // m

  /// The offsets when lasers cross the projection plane at heights `rings` (m, along z, the
  /// line of sight at 0) shifted together by each of a set of phases evenly spread over
  /// [-phase_span / 2, phase_span / 2] (m; the gap between the lasers at the target: where the
  /// target's origin lies between them is not known). Draws in which no laser hits are left out
  /// (they give no scan). samples == 0 when no laser ever hits the model.
  ///
  /// With the scan's spread along the rings known, each draw is weighed by how well its own
  /// spread matches it (a Gaussian kernel on the logarithm of the ratio, as wide as the
  /// standard deviation of n returns' spread, 1 / sqrt(2 (n - 1)), widened until the draws that
  /// count come from at least 30 attitudes): the statistics are then those
  /// of the attitudes that look like the scan. A satellite whose wings face the sensor spreads
  /// a ring's returns over metres and puts their centroid far from the origin; one seen
  /// edge-on does not: over every attitude alike, the first is a rare draw and its covariance
  /// far too small.
  OffsetStatistics offsets(std::span<const double> rings, double phase_span,
                           const ScanShape& shape = {}) const;

  /// The evenly spread attitudes (unit quaternions as x, y, z, w) of a set of `count`: the
  /// super-Fibonacci spiral (Alexa, CVPR 2022), deterministic.
  static std::vector<Eigen::Vector4d> spreadAttitudes(int count);

 private:
  const VisibleRow& row(int attitude, int index) const {
    return rows_[static_cast<std::size_t>(attitude) * grid_ + index];
  }

  double extent_ = 0, cell_ = 0, view_distance_ = 0;
  int attitudes_ = 0, grid_ = 0;  // grid_ rows of cell_ from z = -extent_
  std::vector<VisibleRow> rows_;  // attitude-major
};

}  // namespace cdff::dfn::scan_position
