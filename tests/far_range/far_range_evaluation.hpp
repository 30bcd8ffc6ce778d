#pragma once
// The far-range products of a `cdff run` output against the simulator's truth (passed through):
// the bearing against the target's centre of mass (what the product claims, with its
// covariance, and the radar range: `cdff eval`'s evaluation), the tracked point against the
// truth of the designated point (the matcher's own accuracy: the point on the designation's ray
// at the centre of mass's depth, fixed to the target). Pixels are the far camera's (its
// calibration, passed through by `cdff run`).
#include <optional>
#include <string>
#include <vector>

#include "cdff/eval/bearing_evaluation.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff::far_range {

struct Evaluation {
  std::optional<Timestamp> designated;   // when the track started
  std::string designation;               // user or automatic
  eval::BearingEvaluation bearing;       // the bearing product (valid while tracking)
  std::vector<double> tracked_point_px;  // per match, vs the designated point's truth
  std::size_t images = 0;                // after the designation
  double centre_offset_m = 0;            // the designated point's distance from the centre
};

/// Reads `output` (a far_range_tracking run with the /truth/ channels and the far camera's
/// calibration of its input).
Result<Evaluation> evaluateFarRange(const std::string& output);

double rms(const std::vector<double>& v);

}  // namespace cdff::far_range
