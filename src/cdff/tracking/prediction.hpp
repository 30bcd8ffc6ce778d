#pragma once
// The prediction a frame is tracked from: a filter state's pose moved to the measurements' time
// with its twist (EstimationFilter's constant-velocity model), with the pose covariance that the
// acquisition reads and the one carried to that time that the acquisition's confirmation reads.

#include <optional>

#include "cdff/types/geometry.hpp"
#include "cdff/types/time.hpp"

namespace cdff::tracking {

/// The pose of `state` moved to `to` with its twist, the mean of EstimationFilter's
/// constant-velocity prediction (translation += v dt, rotation = exp(w dt) rotation), stamped
/// `to`; the covariance is the state's pose covariance. A state not older than `to` is returned
/// as it is.
PoseWithCovariance predictPose(const RigidBodyState& state, Timestamp to);

/// The pose covariance of `state` carried to `to` with its velocity covariance, F P F^T with
/// F = [I, dt I] (dt = 0 when `to` is not after the state): how far the pose can have moved since
/// the state, without the filter's process noise.
Matrix6d carriedPoseCovariance(const RigidBodyState& state, Timestamp to);

/// A prediction of reference_T_model at the measurements' time.
struct PosePrediction {
  PoseWithCovariance pose;
  /// For a prediction from a filter state, its pose covariance carried to the measurements' time
  /// (carriedPoseCovariance); empty for a prediction given as a pose.
  std::optional<Matrix6d> carried_covariance;
};

}  // namespace cdff::tracking
