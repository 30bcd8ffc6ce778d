#include "visible_rows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "cdff/types/point_spacing.hpp"

namespace cdff::dfn::scan_position {

namespace {

// The grid's cell is at least R / 50: about 100 cells across the target, so that a model whose
// point spacing is finer keeps a bounded cost and the rows resolve a ring's position on it to
// 1 % of its size.
constexpr double kCellsPerRadius = 50.0;
// The most ring phases offsets() draws: enough that a phase step is under a cell at any range
// a spinning LIDAR's gap allows (a 2 deg gap at 60 m over a 2 m target is 40 cells).
constexpr int kMostPhases = 64;

struct Grid {
  double extent, cell, distance;
  int size;
};

// One attitude's visible rows (`rows`, one per z row of the grid, empty on entry): the nearest
// point per cell of the projection plane's grid, summed per row.
void visibleRows(const Eigen::Matrix3Xf& model, const Eigen::Matrix3f& rotation, const Grid& g,
                 std::vector<float>& depth, std::vector<Eigen::Vector3f>& nearest,
                 std::span<VisibleRow> rows) {
  std::fill(depth.begin(), depth.end(), std::numeric_limits<float>::infinity());
  const auto distance = static_cast<float>(g.distance);
  const auto extent = static_cast<float>(g.extent);
  const auto inv_cell = static_cast<float>(1.0 / g.cell);
  for (Eigen::Index i = 0; i < model.cols(); ++i) {
    const Eigen::Vector3f q = rotation * model.col(i);
    const float scale = distance / (distance + q.x());  // central projection onto x = 0
    const int iy = std::clamp(static_cast<int>((q.y() * scale + extent) * inv_cell), 0, g.size - 1);
    const int iz = std::clamp(static_cast<int>((q.z() * scale + extent) * inv_cell), 0, g.size - 1);
    const std::size_t k = static_cast<std::size_t>(iz) * g.size + iy;
    if (q.x() < depth[k]) {
      depth[k] = q.x();
      nearest[k] = q;
    }
  }
  for (int iz = 0; iz < g.size; ++iz)
    for (int iy = 0; iy < g.size; ++iy) {
      const std::size_t k = static_cast<std::size_t>(iz) * g.size + iy;
      if (!std::isfinite(depth[k])) continue;
      const Eigen::Vector3d p = nearest[k].cast<double>();
      VisibleRow& row = rows[static_cast<std::size_t>(iz)];
      row.sum += p;
      row.sum_yy += p.y() * p.y();
      row.count += 1.0;
    }
}

// One draw of offsets(): an attitude and a phase of the rings.
struct OffsetDraw {
  Eigen::Vector3d offset;  // origin (0) - centroid of the rows hit
  double spread;           // of the visible points along the rows hit (y), m
  int attitude;
};

// The fewest attitudes (effective number, (sum w)^2 / sum w^2 of their weights) the weighed
// draws must come from: the mean offset within about 1 / sqrt(30) = 18 % of its spread of the
// mean over all such attitudes.
constexpr double kMinEffectiveAttitudes = 30;

// The draws' weights: 1 without the scan's spread; else a kernel on log(spread of the draw /
// spread of the scan), both floored at a cell (a row one cell wide has no measurable spread),
// as wide as the spread of n returns varies (relative standard deviation 1 / sqrt(2 (n - 1))),
// widened by sqrt(2) until kMinEffectiveAttitudes attitudes count.
std::vector<double> spreadWeights(const std::vector<OffsetDraw>& draws, const ScanShape& shape,
                                  double cell, int attitudes) {
  std::vector<double> weights(draws.size(), 1.0);
  if (shape.returns <= 1) return weights;
  const double observed = std::log(std::max(shape.along_ring_spread, cell));
  std::vector<double> log_ratio_sq(draws.size());
  for (std::size_t i = 0; i < draws.size(); ++i)
    log_ratio_sq[i] = std::pow(std::log(std::max(draws[i].spread, cell)) - observed, 2);
  double width = 1.0 / std::sqrt(2.0 * (shape.returns - 1));
  std::vector<double> per_attitude(static_cast<std::size_t>(attitudes));
  for (int round = 0; round < 32; ++round, width *= std::sqrt(2.0)) {
    std::fill(per_attitude.begin(), per_attitude.end(), 0.0);
    for (std::size_t i = 0; i < draws.size(); ++i) {
      weights[i] = std::exp(-0.5 * log_ratio_sq[i] / (width * width));
      per_attitude[static_cast<std::size_t>(draws[i].attitude)] += weights[i];
    }
    double sum = 0, sum_sq = 0;
    for (const double w : per_attitude) {
      sum += w;
      sum_sq += w * w;
    }
    if (sum_sq > 0 && sum * sum / sum_sq >= kMinEffectiveAttitudes) break;
  }
  return weights;
}

// The weighed moments of the draws (attitude-major); the attitude's part (law of total
// covariance) from each attitude's weighed mean over its phases. samples == 0 when every weight
// underflowed (no draw resembles the scan).
OffsetStatistics weighedStatistics(const std::vector<OffsetDraw>& draws,
                                   const std::vector<double>& weights) {
  double total = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_sq = Eigen::Matrix3d::Zero(), sum_attitude_sq = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < draws.size();) {
    Eigen::Vector3d attitude_sum = Eigen::Vector3d::Zero();
    double attitude_weight = 0;
    const int a = draws[i].attitude;
    for (; i < draws.size() && draws[i].attitude == a; ++i) {
      const double w = weights[i];
      const Eigen::Vector3d& o = draws[i].offset;
      sum += w * o;
      sum_sq += w * o * o.transpose();
      attitude_sum += w * o;
      attitude_weight += w;
    }
    total += attitude_weight;
    if (attitude_weight > 0)
      sum_attitude_sq += attitude_sum * attitude_sum.transpose() / attitude_weight;
  }
  OffsetStatistics out;
  if (!(total > 0)) return out;
  out.samples = draws.size();
  out.mean = sum / total;
  const Eigen::Matrix3d mean_sq = out.mean * out.mean.transpose();
  out.covariance = sum_sq / total - mean_sq;
  out.attitude = sum_attitude_sq / total - mean_sq;
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose());
  out.attitude = 0.5 * (out.attitude + out.attitude.transpose());
  return out;
}

}  // namespace

Result<ViewableModel> ViewableModel::of(const PointCloud& model) {
  const Eigen::Matrix3Xf all = model.xyzMatrix();
  ViewableModel v;
  v.radius = all.cols() ? std::sqrt(all.colwise().squaredNorm().maxCoeff()) : 0.0;
  if (!(v.radius > 0))
    return invalidInput(
        "input 'model' has all its {} points at its origin; expected the target's surface "
        "around its origin (its extent sets the gate and the visible-surface offset)",
        all.cols());
  const double spacing = pointSpacing(model);
  v.cell = std::max(v.radius / kCellsPerRadius, 2.0 * spacing);
  // A cell facing the sensor needs a few points, (cell / spacing)^2 = 4 at twice the spacing:
  // a finer model is thinned to that density (every stride-th point; a model is sampled over
  // its surface in its order, as ModelPointCloud's).
  const Eigen::Index stride =
      spacing > 0 ? std::max<Eigen::Index>(
                        1, static_cast<Eigen::Index>(std::pow(v.cell / (2.0 * spacing), 2)))
                  : 1;
  v.points.resize(3, (all.cols() + stride - 1) / stride);
  for (Eigen::Index i = 0, k = 0; i < all.cols(); i += stride, ++k) v.points.col(k) = all.col(i);
  return v;
}

std::vector<Eigen::Vector4d> VisibleRows::spreadAttitudes(int count) {
  constexpr double kPhi = 1.4142135623730951;          // sqrt(2)
  constexpr double kPsi = 1.533751168755204288118041;  // the real root of psi^4 = psi + 4
  std::vector<Eigen::Vector4d> out;
  out.reserve(static_cast<std::size_t>(std::max(count, 0)));
  for (int i = 0; i < count; ++i) {
    const double s = i + 0.5;
    const double r = std::sqrt(s / count), big_r = std::sqrt(1.0 - s / count);
    const double alpha = 2.0 * M_PI * s / kPhi, beta = 2.0 * M_PI * s / kPsi;
    out.emplace_back(r * std::sin(alpha), r * std::cos(alpha), big_r * std::sin(beta),
                     big_r * std::cos(beta));
  }
  return out;
}

VisibleRows VisibleRows::build(const ViewableModel& model, int attitudes, double view_distance) {
  VisibleRows v;
  v.view_distance_ = std::max(view_distance, 2.0 * model.radius);
  // A point at R from the origin projects within R d / (d - R) of it.
  v.extent_ = model.radius * v.view_distance_ / (v.view_distance_ - model.radius);
  v.cell_ = model.cell;
  v.attitudes_ = attitudes;
  v.grid_ = static_cast<int>(std::ceil(2.0 * v.extent_ / v.cell_)) + 1;
  const Grid grid{v.extent_, v.cell_, v.view_distance_, v.grid_};
  const auto size = static_cast<std::size_t>(v.grid_);
  v.rows_.assign(static_cast<std::size_t>(attitudes) * size, VisibleRow{});
  std::vector<float> depth(size * size);
  std::vector<Eigen::Vector3f> nearest(size * size);
  const std::vector<Eigen::Vector4d> spread = spreadAttitudes(attitudes);
  for (int a = 0; a < attitudes; ++a) {
    const Eigen::Quaterniond q(spread[a].w(), spread[a].x(), spread[a].y(), spread[a].z());
    visibleRows(model.points, q.normalized().toRotationMatrix().cast<float>(), grid, depth, nearest,
                std::span<VisibleRow>(v.rows_).subspan(static_cast<std::size_t>(a) * size, size));
  }
  return v;
}

OffsetStatistics VisibleRows::offsets(std::span<const double> rings, double phase_span,
                                      const ScanShape& shape) const {
  // Expected returns per cell of a row (1 when the spacing is unknown: a cell is a return).
  const double per_cell = shape.return_spacing > 0 ? cell_ / shape.return_spacing : 1.0;
  const int phases =
      phase_span > 0 ? std::clamp(static_cast<int>(std::ceil(phase_span / cell_)), 1, kMostPhases)
                     : 1;
  std::vector<double> near;  // the lasers that can reach the model at some phase
  for (const double z : rings)
    if (std::abs(z) <= extent_ + 0.5 * phase_span + cell_) near.push_back(z);
  std::vector<OffsetDraw> draws;
  for (int a = 0; a < attitudes_; ++a)
    for (int e = 0; e < phases; ++e) {
      const double shift = phase_span * ((e + 0.5) / phases - 0.5);
      Eigen::Vector3d s = Eigen::Vector3d::Zero();
      double yy = 0, count = 0;
      for (const double z : near) {
        const double index = std::floor((z + shift + extent_) / cell_);
        if (index < 0 || index >= grid_) continue;
        const VisibleRow& r = row(a, static_cast<int>(index));
        s += r.sum;
        yy += r.sum_yy;
        count += r.count;
      }
      // A draw with fewer returns than min_returns gives no measurement (rounded: a row of
      // 4.6 cells' worth of returns gives 4 or 5 of them, as its phase along the ring falls).
      if (count == 0 || count * per_cell < shape.min_returns - 0.5) continue;
      const Eigen::Vector3d centroid = s / count;
      const double variance = std::max(yy / count - centroid.y() * centroid.y(), 0.0);
      draws.push_back({-centroid, std::sqrt(variance), a});
    }
  if (draws.empty()) return {};
  return weighedStatistics(draws, spreadWeights(draws, shape, cell_, attitudes_));
}

}  // namespace cdff::dfn::scan_position
