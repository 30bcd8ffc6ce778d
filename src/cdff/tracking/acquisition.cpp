#include "cdff/tracking/acquisition.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>

#include "cdff/tracking/acquisition_confirmation.hpp"

namespace cdff::tracking {

double predictionSpreadPx(const TrackingModel& model, const CameraFrame& frame,
                          const PoseWithCovariance& predicted, double sigmas,
                          double near_clipping) {
  if (sigmas <= 0) return 0;
  const Matrix6d& c = predicted.covariance;
  if (!c.allFinite() || c.diagonal().maxCoeff() <= 0 || c.diagonal().maxCoeff() >= 1e5) return 0;
  const Eigen::Isometry3d c_T_m = frame.camera_T_reference.isometry() * predicted.pose.isometry();
  const double z = (c_T_m * model.centre).z();
  if (z <= near_clipping) return 0;
  const double r = model.radius;
  const Eigen::Matrix3d p = c.topLeftCorner<3, 3>();
  const double lateral = std::sqrt(std::max(0.0, p(0, 0) + p(1, 1)));
  const double range = std::sqrt(std::max(0.0, p(2, 2)));
  const double attitude = std::sqrt(std::max(0.0, c.bottomRightCorner<3, 3>().trace()));
  const double f = std::max(frame.camera.fx, frame.camera.fy);
  return sigmas * f / z * (lateral + range * r / z + attitude * r);
}

double visibleSpreadPx(const TrackingModel& model, const CameraFrame& frame,
                       const PoseWithCovariance& predicted, double sigmas, double near_clipping) {
  if (sigmas <= 0) return 0;
  const Matrix6d& c = predicted.covariance;
  if (!c.allFinite() || c.diagonal().maxCoeff() <= 0 || c.diagonal().maxCoeff() >= 1e5) return 0;
  const Eigen::Isometry3d r_T_m = predicted.pose.isometry();
  const Eigen::Isometry3d c_T_r = frame.camera_T_reference.isometry();
  if ((c_T_r * r_T_m * model.centre).z() <= near_clipping) return 0;
  const CameraModel& k = frame.camera;
  // A point x (reference frame) moves by dt + dtheta x (x - t) under the perturbation [dt,
  // dtheta] (rotation about the model's origin t); its pixel by the projection's Jacobian J of
  // that.
  double worst = 0, worst_any = 0;
  for (const Eigen::Vector3d& p : model.points) {
    const Eigen::Vector3d x = r_T_m * p;
    const Eigen::Vector3d xc = c_T_r * x;
    if (xc.z() <= near_clipping) continue;
    Eigen::Matrix<double, 3, 6> moves;
    moves << Eigen::Matrix3d::Identity(), -skew(x - r_T_m.translation());
    Eigen::Matrix<double, 2, 3> project;
    project << k.fx / xc.z(), 0, -k.fx * xc.x() / (xc.z() * xc.z()), 0, k.fy / xc.z(),
        -k.fy * xc.y() / (xc.z() * xc.z());
    const Eigen::Matrix<double, 2, 6> J = project * c_T_r.linear() * moves;
    // The root-mean-square displacement over both image axes.
    const double px = std::sqrt(std::max(0.0, (J * c * J.transpose()).trace()));
    worst_any = std::max(worst_any, px);
    const double u = k.fx * xc.x() / xc.z() + k.cx, v = k.fy * xc.y() / xc.z() + k.cy;
    if (u >= 0 && v >= 0 && u < k.width && v < k.height) worst = std::max(worst, px);
  }
  return sigmas * (worst > 0 ? worst : worst_any);
}

double modelSizePx(const TrackingModel& model, const CameraFrame& frame,
                   const PoseWithCovariance& predicted, double near_clipping) {
  const Eigen::Isometry3d c_T_m = frame.camera_T_reference.isometry() * predicted.pose.isometry();
  const double z = (c_T_m * model.centre).z();
  if (z <= near_clipping) return 0;
  return 2 * model.radius * std::max(frame.camera.fx, frame.camera.fy) / z;
}

namespace {

// Pyramid levels below full resolution: as many as the spread needs (at most twice the search at
// the coarsest), at most 3, while the model's image at the level stays large enough to fix the
// pose (kMinModelPx across).
int acquisitionLevels(double spread, int search, double model_px) {
  const auto fits = [&](int level) { return model_px / (1 << level) >= kMinModelPx; };
  int levels = 0;
  while (levels < 3 && spread / (1 << levels) > 2 * search && fits(levels + 1)) ++levels;
  return levels;
}

// The options of the acquisition's passes: one matching pass each, the contours recomputed at
// every pass, no inlier test (the passes at full resolution that follow decide the status), and
// divergence thresholds as wide as the prediction is uncertain, so that the passes may move that
// far.
EdgeTrackerOptions passOptions(const EdgeTrackerOptions& options, const Matrix6d& c,
                               double sigmas) {
  EdgeTrackerOptions coarse = options;
  coarse.refinement_passes = 0;
  coarse.visibility_update_translation = coarse.visibility_update_rotation = 0;
  coarse.min_inlier_ratio = 0;
  coarse.degraded_inlier_ratio = 0;
  coarse.solver.divergence_translation =
      std::max(options.solver.divergence_translation,
               2 * sigmas * std::sqrt(c.topLeftCorner<3, 3>().trace()));
  coarse.solver.divergence_rotation =
      std::max(options.solver.divergence_rotation,
               2 * sigmas * std::sqrt(c.bottomRightCorner<3, 3>().trace()));
  return coarse;
}

// One hypothesis's coarse-to-fine passes.
struct Passes {
  bool ran = false;  // the prediction's spread exceeded the search
  bool ok = true;    // false: a pass lost the track
  Transform pose;    // the start, moved by every pass that held
  std::string failure;
};

// One frame's acquisition: what its steps share.
struct Acquisition {
  EdgeTracker& tracker;
  const FrameMeasurements& frame;
  const PoseWithCovariance& predicted;
  const EdgeTrackerOptions& options;
  const AcquisitionOptions& acquisition;
  FramePyramids& pyramids;

  Result<TrackingResult> track(const Transform& start) {
    return tracker.track(frame.cameras, frame.depth, frame.depth_T_reference, start, options);
  }

  // The cameras of a pass at `level`. Below full resolution only the reference camera: the
  // coarse levels place the model within the full-resolution search, which one camera does as
  // well as two at half the cost; at full resolution every camera contributes.
  std::vector<CameraFrame> levelFrames(int level, std::size_t reference) {
    std::vector<CameraFrame> scaled;
    for (std::size_t i = 0; i < frame.cameras.size(); ++i) {
      if (level > 0 && i != reference) continue;
      scaled.push_back(pyramids.frame(i, level));
    }
    return scaled;
  }

  // The passes of one level, from out.pose; the coarsest level (`coarsest`) with the wide search.
  // With `lateral_first` the coarsest level finds the lateral offset alone with the wide search,
  // and all six degrees of freedom are freed with the usual search from the next finer level on
  // (on the same level when it is full resolution). A pixel of level L is 2^L at full
  // resolution: the attitude and range a six-dof pass takes there come from associations too
  // coarse to tell the model's finer edges apart (at close range such a pass turns the model
  // about the adapter ring's axis, where the ring's circles still fit, by more than the finer
  // levels' searches bring back).
  Status levelPasses(int level, bool coarsest, std::size_t reference, double spread,
                     bool lateral_first, EdgeTrackerOptions& coarse, Passes& out) {
    const std::vector<CameraFrame> scaled = levelFrames(level, reference);
    const int search = options.search.search_distance;
    const double level_spread = spread / (1 << level);
    const bool lateral_only_level = coarsest && lateral_first;
    const int steps = lateral_only_level && level > 0 ? 1 : 2;
    for (int step = lateral_only_level ? 0 : 1; step < steps; ++step) {
      coarse.solver.lateral_only = step == 0;
      coarse.search.search_distance = coarsest && (step == 0 || !lateral_first)
                                          ? std::clamp(static_cast<int>(std::ceil(level_spread)),
                                                       search, acquisition.max_search_distance)
                                          : search;
      Result<TrackingResult> pass = tracker.track(scaled, level == 0 ? frame.depth : nullptr,
                                                  frame.depth_T_reference, out.pose, coarse);
      if (!pass) return pass.status();
      if (pass->status == TrackingStatus::kLost) {
        out.ok = false;
        out.failure = fmt::format("at pyramid level {} (search distance {} px{}): {}", level,
                                  coarse.search.search_distance, step == 0 ? ", lateral only" : "",
                                  pass->reason);
        return Status::ok();
      }
      out.pose = pass->reference_T_model;
    }
    return Status::ok();
  }

  // Coarse-to-fine passes from `start`: on the pyramid level where the prediction's spread fits
  // the search, then one per finer level. They run only when the spread in the reference camera
  // exceeds the search distance; the final passes at full resolution (track()) check the inlier
  // ratio.
  Result<Passes> passes(const Transform& start, bool lateral_first) {
    Passes out;
    out.pose = start;
    if (frame.cameras.empty()) return out;
    const std::size_t reference = referenceCamera(frame.cameras);
    const CameraFrame& ref = frame.cameras[reference];
    const double near = options.visibility.near_clipping;
    if (!tracker.hasModel() || visibleSpreadPx(tracker.model(), ref, predicted, acquisition.sigmas,
                                               near) <= options.search.search_distance)
      return out;
    const double spread =
        predictionSpreadPx(tracker.model(), ref, predicted, acquisition.sigmas, near);
    out.ran = true;
    const int levels = acquisitionLevels(spread, options.search.search_distance,
                                         modelSizePx(tracker.model(), ref, predicted, near));
    EdgeTrackerOptions coarse = passOptions(options, predicted.covariance, acquisition.sigmas);
    for (int level = levels; level >= 0 && out.ok; --level)
      CDFF_RETURN_IF_ERROR(
          levelPasses(level, level == levels, reference, spread, lateral_first, coarse, out));
    return out;
  }

  // The acquisition from one start, before the gate: the lateral-first hypothesis, then the plain
  // one when the lateral-first result is not accepted.
  Result<AcquisitionResult> acquire(const Transform& start, bool coarse_placed) {
    Result<Passes> lateral = passes(start, acquisition.lateral_first);
    if (!lateral) return lateral.status();
    Result<TrackingResult> tracked = track(lateral->pose);
    if (!tracked) return tracked.status();
    AcquisitionResult r;
    r.ran = lateral->ran;
    r.acquired = lateral->ok;
    r.failure = lateral->failure;
    r.tracking = std::move(tracked).value();
    if (r.ran && acquisition.lateral_first && !accepted(r, coarse_placed))
      CDFF_RETURN_IF_ERROR(plainHypothesis(start, r));
    return r;
  }

  // Whether an acquisition's result stands without another hypothesis or start: acquired, not
  // lost, admitted by the prediction, and tracking unless a coarse placement preceded it.
  bool accepted(const AcquisitionResult& r, bool coarse_placed) const {
    return r.acquired && r.tracking.status != TrackingStatus::kLost &&
           (coarse_placed || r.tracking.status == TrackingStatus::kTracking) &&
           testGate(r.tracking.reference_T_model, predicted.pose, gateCovariance(r.tracking))
               .admitted;
  }

  // The covariance of the acquired pose's difference from the prediction: the prediction's plus
  // the estimate's own (the estimate is a measurement with its error, not the truth).
  Matrix6d gateCovariance(const TrackingResult& t) const {
    Matrix6d c = predicted.covariance;
    if (t.status != TrackingStatus::kLost && t.covariance.allFinite()) c += t.covariance;
    return c;
  }

  // The plain hypothesis from `start`: its result replaces the lateral-first one when that is not
  // acquired or lost, or when its inlier ratio is higher. When neither is acquired the failure
  // names both; when the plain passes held and only its full-resolution track was lost, the plain
  // part repeats the lateral-first failure.
  Status plainHypothesis(const Transform& start, AcquisitionResult& r) {
    Result<Passes> plain = passes(start, false);
    if (!plain) return plain.status();
    if (plain->ok) {
      Result<TrackingResult> other = track(plain->pose);
      if (!other) return other.status();
      const bool lateral_ok = r.acquired && r.tracking.status != TrackingStatus::kLost;
      if (other->status != TrackingStatus::kLost &&
          (!lateral_ok || other->inlier_ratio > r.tracking.inlier_ratio)) {
        r.tracking = std::move(other).value();
        r.acquired = true;
      }
    }
    if (!r.acquired)
      r.failure =
          "lateral first: " + r.failure + "; plain: " + (plain->ok ? r.failure : plain->failure);
    return Status::ok();
  }

  // The status of the acquisition's result: lost with the prediction's pose when not acquired,
  // and when the prediction's covariance does not admit the acquired pose (a wide acquisition can
  // lock onto a wrong alignment: at long range the model's image is small next to the search).
  void gate(AcquisitionResult& r) const {
    TrackingResult& t = r.tracking;
    if (!r.acquired) {
      t.status = TrackingStatus::kLost;
      t.reason = "acquisition from the initial pose failed: " + r.failure;
      t.reference_T_model = predicted.pose;
      t.covariance = noInformationCovariance();
    } else if (t.status == TrackingStatus::kLost) {
      t.reference_T_model = predicted.pose;
    } else if (r.ran) {
      const GateTest test = testGate(t.reference_T_model, predicted.pose, gateCovariance(t));
      if (test.admitted) return;
      const Vector6d d = poseDifference(t.reference_T_model, predicted.pose);
      t.status = TrackingStatus::kLost;
      t.reason = fmt::format(
          "the acquired pose is {:.3f} m and {:.2f} deg from the prediction, a squared "
          "Mahalanobis distance of {:.1f} under its and the estimate's covariance (gate {:.2f}: "
          "chi-square, 6 dof, "
          "0.999)",
          d.head<3>().norm(), d.tail<3>().norm() * 180 / M_PI, test.distance, kAcquisitionGate);
      t.reference_T_model = predicted.pose;
      t.covariance = noInformationCovariance();
    }
  }
};

}  // namespace

std::vector<Transform> restartStarts(const Transform& start, const Matrix6d& covariance,
                                     double sigmas, int first, int count) {
  std::vector<Transform> starts;
  const Eigen::Matrix3d attitude = covariance.bottomRightCorner<3, 3>();
  if (count <= 0 || sigmas <= 0 || !attitude.allFinite()) return starts;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> axes(attitude);
  if (axes.info() != Eigen::Success || axes.eigenvalues().minCoeff() <= 0) return starts;
  for (int i = first; i < first + count; ++i) {
    // Largest axis first, each to both sides: 0 and 1 about the largest, 2 and 3 the middle one.
    const int k = (i / 2) % 3;
    const Eigen::Vector3d turn = (i % 2 ? -sigmas : sigmas) * std::sqrt(axes.eigenvalues()(2 - k)) *
                                 axes.eigenvectors().col(2 - k);
    Transform s = start;
    s.rotation = (expSO3(turn) * start.rotation).normalized();
    starts.push_back(s);
  }
  return starts;
}

Result<AcquisitionResult> trackWithAcquisition(EdgeTracker& tracker, const FrameMeasurements& frame,
                                               const PoseWithCovariance& predicted,
                                               const Transform& start, bool coarse_placed,
                                               const EdgeTrackerOptions& options,
                                               const AcquisitionOptions& acquisition,
                                               FramePyramids& pyramids,
                                               std::span<const Transform> restarts) {
  Acquisition a{tracker, frame, predicted, options, acquisition, pyramids};
  Result<AcquisitionResult> r = a.acquire(start, coarse_placed);
  if (!r) return r.status();
  if (r->ran && !a.accepted(*r, coarse_placed)) {
    for (const Transform& other : restarts) {
      ++r->restarts;
      Result<AcquisitionResult> again = a.acquire(other, coarse_placed);
      if (!again) return again.status();
      if (!a.accepted(*again, coarse_placed)) continue;
      const int tried = r->restarts;
      r = std::move(again);
      r->restarts = tried;
      break;
    }
  }
  a.gate(*r);
  return r;
}

}  // namespace cdff::tracking
