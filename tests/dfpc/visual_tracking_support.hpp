#pragma once
// Shared by the visual tracking DFPC tests and benchmarks: the perturbed initial pose the visual
// tracking issue prescribes (ground truth off by a fraction of the range and an angle, until the
// detection DFPC provides one) and the evaluation of the DFPC's products with src/cdff/eval.
#include <random>
#include <string>
#include <vector>

#include "cdff/dfpc/stream.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/types/geometry.hpp"

namespace cdff::dfpc::visual {

/// A unit vector drawn uniformly on the sphere.
inline Eigen::Vector3d randomDirection(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d d;
  do d = Eigen::Vector3d(n(rng), n(rng), n(rng));
  while (d.norm() < 1e-6);
  return d.normalized();
}

/// The true camera_T_target moved by exactly `range_fraction` of its range in a random direction
/// and turned by exactly `angle` about a random axis; its covariance says so (one standard
/// deviation per axis equal to the whole offset), with a still target (zero twist, 5 cm/s and
/// 5 deg/s standard deviations).
inline RigidBodyState perturbedInitialState(const Eigen::Isometry3d& truth,
                                            const std::string& parent, const std::string& child,
                                            Timestamp stamp, double range_fraction, double angle,
                                            std::mt19937& rng) {
  RigidBodyState s;
  const double offset = range_fraction * truth.translation().norm();
  Eigen::Isometry3d p = truth;
  p.translation() += offset * randomDirection(rng);
  p.linear() = expSO3(angle * randomDirection(rng)).toRotationMatrix() * truth.linear();
  s.pose = Transform::fromIsometry(p, parent, child, stamp);
  s.covariance.setZero();
  s.covariance.diagonal() << Eigen::Vector3d::Constant(offset * offset),
      Eigen::Vector3d::Constant(angle * angle), Eigen::Vector3d::Constant(0.05 * 0.05),
      Eigen::Vector3d::Constant(std::pow(5.0 * M_PI / 180, 2));
  return s;
}

/// The poses of a channel of RigidBodyState or PoseWithCovariance products, as eval samples;
/// `skip_first` leaves out the initial state the filter publishes when it is initialised.
inline std::vector<eval::EstimateSample> estimates(const std::vector<Message>& messages,
                                                   std::size_t skip_first = 0) {
  std::vector<eval::EstimateSample> out;
  for (std::size_t i = skip_first; i < messages.size(); ++i) {
    const Message& m = messages[i];
    eval::EstimateSample e;
    if (const RigidBodyState* s = m.as<RigidBodyState>())
      e.pose = s->pose;
    else if (const PoseWithCovariance* p = m.as<PoseWithCovariance>())
      e.pose = p->pose;
    else
      continue;
    out.push_back(e);
  }
  return out;
}

}  // namespace cdff::dfpc::visual
