#pragma once
// Cropping a scan to the returns around a model at a pose, and thinning them evenly: how the
// verifying DFIs (PoseHypothesisSelection/IcpMisfit, SymmetryCheck/ScanMisfit) bound the returns
// they score a pose on.

#include <cstddef>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/point_cloud.hpp"

namespace cdff::registration {

/// The points of `cloud` within `radius` of any of `centres`, in the cloud's order, into
/// `inside` (cleared first); of every `stride`-th point of the cloud only (a subsample that is
/// the same whatever the centres).
void pointsWithin(const PointCloud& cloud, std::span<const Eigen::Vector3f> centres, float radius,
                  std::vector<Eigen::Vector3f>& inside, std::size_t stride = 1);

/// `points` evenly thinned to at most `most` of them (spread over the whole sequence, in order),
/// into `kept` (cleared first).
void thinEvenly(std::span<const Eigen::Vector3f> points, std::size_t most,
                std::vector<Eigen::Vector3f>& kept);

}  // namespace cdff::registration
