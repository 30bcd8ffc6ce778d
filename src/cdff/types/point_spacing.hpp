#pragma once
// The point spacing of a cloud that samples a surface: the scale from which the 3D feature DFNs
// derive their radii when none is given.

#include <cstddef>

#include "cdff/types/point_cloud.hpp"

namespace cdff {

/// The cloud's point spacing s: the pitch of its sampling, sqrt(surface area per point),
/// estimated from the distance r8 to the 8th nearest other point as s = r8 sqrt(pi / 8) (on a
/// surface of density 1/s^2, a disc of radius r8 holds 8 points). The 8th neighbour rather than
/// the nearest because it gives the same s, within 10 %, for a regular grid (the nearest is then
/// s) and for random samples (the nearest is then about s/2): a radius that follows s holds
/// about the same number of points whatever the sampling. The median over the points, so that
/// outliers and a scan's sparse rim do not move it; at most `max_samples` points, evenly spread
/// over the cloud's order, are queried (the median of 4096 is within a few percent of the full
/// one, at a fixed cost of about 1 ms). 0 when no point has 8 distinct others (a tiny cloud, or
/// all points coincide). Non-finite points are ignored.
double pointSpacing(const PointCloud& cloud, std::size_t max_samples = 4096);

}  // namespace cdff
