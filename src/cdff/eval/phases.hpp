#pragma once
// The phases of a rendezvous (seed Table 1), by the target's true range: far range (bearing and
// range), mid range and close range (position and attitude). `cdff eval` gives each phase its
// own verdicts, from one run, over the estimates made while the truth was in the phase's band,
// and draws the phases' boundaries on its plots.

#include <string>
#include <vector>

#include "cdff/types/geometry.hpp"

namespace cdff::eval {

struct PhaseSpec {
  std::string name;                         // "far range", "mid range", "close range"
  double min_range_m = 0, max_range_m = 0;  // [min, max) of the true range
};

/// Table 1: far range from 100 m ("10's km to 100's m"), mid range 5 m to 100 m ("100's m to 5
/// m"), close range below 5 m ("5 m to 1 m", and the capture beyond it).
const std::vector<PhaseSpec>& rendezvousPhases();

/// When a run was in a phase: from the first to the last truth sample whose range is in the
/// band (an approach crosses each band once; a run that leaves and re-enters a band has one
/// span over both visits).
struct PhaseSpan {
  PhaseSpec phase;
  Timestamp start = 0, end = 0;
};

/// The spans of the phases the truth (servicer_T_target, sorted by stamp) visits, in time
/// order; none for a phase it never enters.
std::vector<PhaseSpan> phaseSpans(const std::vector<Transform>& truth,
                                  const std::vector<PhaseSpec>& phases = rendezvousPhases());

/// The longest time without a valid estimate inside [start, end], counting the time from the
/// start to the first valid stamp and from the last to the end: a product that serves only part
/// of a phase has that gap. `valid_stamps` sorted.
double longestGapWithin(const std::vector<Timestamp>& valid_stamps, Timestamp start, Timestamp end);

}  // namespace cdff::eval
