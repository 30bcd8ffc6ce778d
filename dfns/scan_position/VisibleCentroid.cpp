#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <fmt/ranges.h>
#include <Eigen/Eigenvalues>

#include "ScanPosition.gen.hpp"
#include "visible_rows.hpp"

namespace cdff::dfn {

namespace {

using scan_position::OffsetStatistics;
using scan_position::ViewableModel;
using scan_position::VisibleRows;

// The visible rows are rebuilt when the angle the target's radius subtends, R / r, has changed
// by more than this (rad) since they were built: the perspective moves the visible surface's
// centroid by a fraction of R of the order of R / r, so the rows stay within 1 % of R of those
// at the scan's range (an approach from 60 to 12 m rebuilds them about 20 times).
constexpr double kViewTolerance = 0.01;

// Returns of one laser share its elevation to float precision (the range noise is along the
// ray); a thinned or de-skewed scan's returns lie a little off it. Elevations closer than this
// (rad) are one ring, as the registration's ring visibility groups them.
constexpr double kSameRing = 0.25 * M_PI / 180.0;

// The line-of-sight frame of a direction u: x = u, z towards the sensor's z across u (the
// direction across its rings), y = z x x.
Eigen::Matrix3d lineOfSightFrame(const Eigen::Vector3d& u) {
  Eigen::Vector3d z = Eigen::Vector3d::UnitZ() - u.z() * u;
  z = z.norm() > 1e-6 ? z.normalized() : u.unitOrthogonal();
  Eigen::Matrix3d frame;
  frame << u, z.cross(u), z;
  return frame;
}

// The lasers (elevations, rad) that cross a target seen at elevation `elevation` within
// +-`half_extent` rad, and the gap between them there (rad) over which their phase is unknown.
struct Rings {
  std::vector<double> elevations;
  double gap = 0;
};

// From the sensor's lasers: all of them, the gap the largest between two neighbours that
// overlaps the target's extent (the coarsest sampling of it); one laser: a gap across the
// target (that laser crosses it anywhere).
Rings sensorRings(const std::vector<double>& lasers, double elevation, double half_extent) {
  Rings rings{lasers, 0.0};
  for (std::size_t i = 0; i + 1 < lasers.size(); ++i)
    if (lasers[i + 1] >= elevation - half_extent && lasers[i] <= elevation + half_extent)
      rings.gap = std::max(rings.gap, lasers[i + 1] - lasers[i]);
  if (rings.gap == 0) rings.gap = 2 * half_extent;
  return rings;
}

// Without a description, from the rings seen: lasers spaced by the smallest gap between the
// rings seen (a larger gap is a ring that missed the target), from the lowest seen, over the
// target's extent; one ring seen: that ring, with a gap across the target.
Rings seenRings(const std::vector<double>& seen, double elevation, double half_extent) {
  if (seen.size() < 2) return {seen, 2 * half_extent};
  double gap = seen[1] - seen[0];
  for (std::size_t i = 1; i + 1 < seen.size(); ++i) gap = std::min(gap, seen[i + 1] - seen[i]);
  Rings rings{{}, gap};
  const auto low = static_cast<int>(std::floor((elevation - half_extent - seen[0]) / gap)) - 1;
  const auto high = static_cast<int>(std::ceil((elevation + half_extent - seen[0]) / gap)) + 1;
  for (int k = low; k <= high; ++k) rings.elevations.push_back(seen[0] + k * gap);
  return rings;
}

// The rings with returns (their elevations, lowest first) and the spacing of the returns along
// them at the target (the median angle between neighbours on a ring, times the range; 0 with
// no ring of two returns).
struct SeenRings {
  std::vector<double> elevations;
  double spacing = 0;
};

SeenRings seenRingsOf(const std::vector<Eigen::Vector3d>& points, double range) {
  std::vector<Eigen::Vector2d> angles;  // elevation, azimuth
  angles.reserve(points.size());
  for (const Eigen::Vector3d& p : points)
    if (p.norm() > 0) angles.emplace_back(std::asin(p.z() / p.norm()), std::atan2(p.y(), p.x()));
  std::sort(angles.begin(), angles.end(),
            [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() < b.x(); });
  SeenRings seen;
  std::vector<double> gaps, ring;
  auto close_ring = [&] {  // a ring's azimuth step is cos(elevation) of its angle
    std::sort(ring.begin(), ring.end());
    for (std::size_t i = 1; i < ring.size(); ++i)
      gaps.push_back((ring[i] - ring[i - 1]) * std::cos(seen.elevations.back()));
    ring.clear();
  };
  for (const Eigen::Vector2d& a : angles) {
    if (seen.elevations.empty() || a.x() - seen.elevations.back() > kSameRing) {
      if (!seen.elevations.empty()) close_ring();
      seen.elevations.push_back(a.x());
    }
    ring.push_back(a.y());
  }
  if (!seen.elevations.empty()) close_ring();
  if (!gaps.empty()) {
    std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
    seen.spacing = gaps[gaps.size() / 2] * range;
  }
  return seen;
}

}  // namespace

class ScanPositionVisibleCentroid final : public ScanPositionVisibleCentroidBase {
 protected:
  Status onConfigure() override {
    model_.reset();
    rows_.reset();
    model_points_ = nullptr;
    return Status::ok();
  }

  Status onProcess() override {
    if (in.model.isFresh() || !model_) CDFF_RETURN_IF_ERROR(readModel(*in.model));
    if (!in.cloud.isFresh()) return Status::ok();
    CDFF_RETURN_IF_ERROR(checkInputs());
    const PointCloud& cloud = *in.cloud;
    const Transform& a_T_lidar = *in.sensor_pose;
    const Eigen::Matrix3d prediction_covariance = in.prediction->covariance.topLeftCorner<3, 3>();
    const Eigen::Vector3d centre = a_T_lidar.inverse() * in.prediction->pose.translation;
    const double sigma_max = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(
                                           prediction_covariance, Eigen::EigenvaluesOnly)
                                           .eigenvalues()
                                           .maxCoeff());
    const double radius = model_->radius + params_.gate_sigmas * sigma_max;
    std::vector<Eigen::Vector3d> points;
    std::size_t non_finite = 0;
    for (const Point4f& p : cloud.points) {
      const Eigen::Vector3d q = p.vec().cast<double>();
      if (!q.allFinite())
        ++non_finite;
      else if ((q - centre).squaredNorm() <= radius * radius)
        points.push_back(q);
    }
    if (non_finite > 0)
      warn(fmt::format(
          "input 'cloud' at t = {} us has {} of its {} points with a non-finite coordinate; "
          "skipped",
          cloud.stamp, non_finite, cloud.size()));
    if (points.size() < static_cast<std::size_t>(params_.min_points)) {
      warn(fmt::format(
          "{} returns of the cloud at t = {} us in the gate (centre ({:.3f}) m in frame '{}', "
          "radius {:.3f} m = R {:.3f} m + {} x sigma_max {:.3f} m); expected at least "
          "min_points = {}: no position",
          points.size(), cloud.stamp, fmt::join(centre, ", "), cloud.frame_id, radius,
          model_->radius, params_.gate_sigmas, sigma_max, params_.min_points));
      return Status::ok();
    }
    return measure(points);
  }

 private:
  // The model is read once per point buffer (a DFPC re-sends the same); its rows are built at
  // the first scan's range.
  Status readModel(const PointCloud& model) {
    if (model_ && model.points.data() == model_points_) return Status::ok();
    if (model.empty())
      return invalidInput(
          "input 'model' has no points; expected the target's model point cloud in its frame "
          "(e.g. ModelPointCloud's model)");
    CDFF_RETURN_IF_ERROR(model.validate("input 'model'"));
    Result<ViewableModel> viewable = ViewableModel::of(model);
    if (!viewable) return viewable.status();
    model_ = std::move(viewable).value();
    rows_.reset();
    model_points_ = model.points.data();
    return Status::ok();
  }

  Status checkInputs() const {
    const PointCloud& cloud = *in.cloud;
    const Transform& a_T_lidar = *in.sensor_pose;
    const RigidBodyState& prediction = *in.prediction;
    CDFF_RETURN_IF_ERROR(cloud.validate("input 'cloud'", /*require_finite=*/false));
    CDFF_RETURN_IF_ERROR(a_T_lidar.validate().withContext("input 'sensor_pose'"));
    if (cloud.frame_id != a_T_lidar.child_frame)
      return invalidInput(
          "input 'cloud' is in frame '{}' but input 'sensor_pose' is {}_T_{}; expected the "
          "cloud in the frame of the LIDAR whose mounting sensor_pose gives ('{}')",
          cloud.frame_id, a_T_lidar.parent_frame, a_T_lidar.child_frame, a_T_lidar.child_frame);
    CDFF_RETURN_IF_ERROR(prediction.validate().withContext("input 'prediction'"));
    if (prediction.pose.parent_frame != a_T_lidar.parent_frame)
      return invalidInput(
          "input 'prediction' is {}_T_{} but input 'sensor_pose' is {}_T_{}; expected the "
          "prediction in the sensor pose's parent frame '{}'",
          prediction.pose.parent_frame, prediction.pose.child_frame, a_T_lidar.parent_frame,
          a_T_lidar.child_frame, a_T_lidar.parent_frame);
    const Eigen::Matrix3d c = prediction.covariance.topLeftCorner<3, 3>();
    const Eigen::Vector3d eigenvalues =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c, Eigen::EigenvaluesOnly).eigenvalues();
    if (!(eigenvalues.minCoeff() > 0))
      return invalidInput(
          "input 'prediction' has a position covariance with eigenvalues ({:.3g}) m^2; expected "
          "a positive definite 3x3 block (its largest standard deviation sets the gate)",
          fmt::join(eigenvalues, ", "));
    const std::string& model_frame = in.model->frame_id;
    if (!model_frame.empty() && !prediction.pose.child_frame.empty() &&
        model_frame != prediction.pose.child_frame)
      return invalidInput(
          "input 'model' is in frame '{}' but input 'prediction' is {}_T_{}; expected the "
          "model in the predicted target's frame",
          model_frame, prediction.pose.parent_frame, prediction.pose.child_frame);
    if (in.sensor.hasValue()) {
      CDFF_RETURN_IF_ERROR(in.sensor->validate().withContext("input 'sensor'"));
      if (in.sensor->frame_id != cloud.frame_id)
        return invalidInput(
            "input 'sensor' describes the LIDAR of frame '{}' but input 'cloud' is in frame "
            "'{}'; expected the description of the sensor that took the cloud",
            in.sensor->frame_id, cloud.frame_id);
    }
    return Status::ok();
  }

  // The rings crossing the target seen along u from range r.
  Rings ringsAt(const SeenRings& seen, double elevation, double r) const {
    const double half_extent = std::asin(std::min(1.0, model_->radius / r));
    if (in.sensor.hasValue())
      return sensorRings(in.sensor->sortedElevations(kSameRing), elevation, half_extent);
    return seenRings(seen.elevations, elevation, half_extent);
  }

  Status measure(const std::vector<Eigen::Vector3d>& points) {
    const auto n = static_cast<double>(points.size());
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& p : points) c += p;
    c /= n;
    const double r = c.norm();
    if (!(r > 0))
      return invalidInput(
          "the {} returns in the gate have their centroid at the sensor's origin; expected a "
          "target at a range",
          points.size());
    const Eigen::Vector3d u = c / r;
    const double elevation = std::asin(std::clamp(u.z(), -1.0, 1.0));
    const SeenRings seen = seenRingsOf(points, r);
    const Rings rings = ringsAt(seen, elevation, r);
    std::vector<double> heights;  // across the line of sight at the target, m
    for (const double e : rings.elevations)
      if (std::abs(e - elevation) < 0.5 * M_PI) heights.push_back(r * std::tan(e - elevation));
    const double R = model_->radius;
    if (!rows_ || std::abs(R / r - R / rows_->viewDistance()) > kViewTolerance)
      rows_ = VisibleRows::build(*model_, params_.attitude_samples, r);
    // Only the draws that would give a measurement (min_points returns) count, weighed by how
    // well their spread along the rings matches the scan's; if none would (a model smaller than
    // the target seen), every draw with a return alike.
    const Eigen::Matrix3d los = lineOfSightFrame(u);
    double along_sq = 0;
    for (const Eigen::Vector3d& p : points) along_sq += std::pow((p - c).dot(los.col(1)), 2);
    OffsetStatistics offset = rows_->offsets(
        heights, r * rings.gap,
        {seen.spacing, params_.min_points, std::sqrt(along_sq / n), static_cast<int>(n)});
    if (offset.samples == 0) offset = rows_->offsets(heights, r * rings.gap);
    if (offset.samples == 0) {
      std::vector<double> degrees;
      for (const double e : rings.elevations) degrees.push_back(e * 180 / M_PI);
      return invalidInput(
          "no laser at ({:.3f}) deg crosses the model (radius {:.3f} m) at range {:.3f} m and "
          "elevation {:.3f} deg at any attitude; expected the description of the LIDAR that "
          "took the cloud (input 'sensor') and the target's model",
          fmt::join(degrees, ", "), R, r, elevation * 180 / M_PI);
    }
    const Eigen::Vector3d origin = c + los * offset.mean;
    // Beside the offset's spread, three small terms that the rows do not hold: the grid's
    // resolution (a cell h, uniform h^2 / 12 on each axis: a symmetric model's offset may not
    // vary at all); the returns' spacing along the rings (a ring samples its row every s_a
    // from an unknown start: s_a^2 / 12 along the rings, averaged over the rings seen); the
    // range noise of the n returns, along u.
    const double h = rows_->cellSize();
    Eigen::Matrix3d los_covariance = offset.covariance;
    los_covariance.diagonal().array() += h * h / 12;
    los_covariance(1, 1) += seen.spacing * seen.spacing / 12 /
                            static_cast<double>(std::max<std::size_t>(seen.elevations.size(), 1));
    if (in.sensor.hasValue()) los_covariance(0, 0) += std::pow(in.sensor->range_noise, 2) / n;
    const Eigen::Matrix3d covariance = los * los_covariance * los.transpose();
    writeOutputs(origin, covariance, los * offset.attitude * los.transpose(), points.size());
    return Status::ok();
  }

  void writeOutputs(const Eigen::Vector3d& origin, const Eigen::Matrix3d& covariance_lidar,
                    const Eigen::Matrix3d& bias_lidar, std::size_t used) {
    const Transform& a_T_lidar = *in.sensor_pose;
    const Eigen::Matrix3d rotation = a_T_lidar.rotation.toRotationMatrix();
    PoseWithCovariance p;
    p.pose = Transform::identity(a_T_lidar.parent_frame, in.prediction->pose.child_frame,
                                 in.cloud->stamp);
    p.pose.translation = a_T_lidar * origin;
    PoseWithCovariance bias = p;
    const Eigen::Matrix3d c = rotation * covariance_lidar * rotation.transpose();
    const Eigen::Matrix3d b = rotation * bias_lidar * rotation.transpose();
    p.covariance.topLeftCorner<3, 3>() = 0.5 * (c + c.transpose());
    const double sa = params_.unknown_attitude_sigma;
    p.covariance.bottomRightCorner<3, 3>() = sa * sa * Eigen::Matrix3d::Identity();
    bias.covariance.topLeftCorner<3, 3>() = 0.5 * (b + b.transpose());
    out.position.set(std::move(p));
    out.position_bias.set(std::move(bias));
    out.points_used.set(static_cast<int>(used));
  }

  std::optional<ViewableModel> model_;
  std::optional<VisibleRows> rows_;        // seen from rows_->viewDistance()
  const Point4f* model_points_ = nullptr;  // the buffer model_ was read from
};

CDFF_REGISTER_DFI(ScanPositionVisibleCentroid);

}  // namespace cdff::dfn
