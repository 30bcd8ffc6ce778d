#pragma once
// The far-range products of a `cdff run` output against the simulator's truth (passed through):
// the bearing against the target's centre of mass (what the product claims, with its
// covariance), the tracked point against the truth of the designated point (the matcher's own
// accuracy: the point on the designation's ray at the centre of mass's depth, fixed to the
// target), and the radar range. Pixels are the far camera's (its focal length).
#include <optional>
#include <string>
#include <vector>

#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff::far_range {

struct Sample {
  Timestamp stamp = 0;
  double range = 0;            // true, m
  double bearing_px = 0;       // bearing vs the centre of mass, px
  double bearing_nees = 0;     // 2 dof
  double range_error_pct = 0;  // NaN without a range
};

struct Evaluation {
  std::optional<Timestamp> designated;  // when the track started
  std::string designation;              // user or automatic
  std::vector<Sample> bearings;
  std::vector<double> tracked_point_px;  // per match, vs the designated point's truth
  std::size_t images = 0;                // after the designation
  double centre_offset_m = 0;            // the designated point's distance from the centre
};

/// Reads `output` (a far_range_tracking run with the /truth/ channels of its input).
Result<Evaluation> evaluateFarRange(const std::string& output, double focal_px);

double rms(const std::vector<double>& v);

}  // namespace cdff::far_range
