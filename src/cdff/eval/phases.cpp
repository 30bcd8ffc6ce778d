#include "cdff/eval/phases.hpp"

#include <algorithm>
#include <limits>

namespace cdff::eval {

const std::vector<PhaseSpec>& rendezvousPhases() {
  static const std::vector<PhaseSpec> phases{
      {"far range", 100.0, std::numeric_limits<double>::infinity()},
      {"mid range", 5.0, 100.0},
      {"close range", 0.0, 5.0},
  };
  return phases;
}

std::vector<PhaseSpan> phaseSpans(const std::vector<Transform>& truth,
                                  const std::vector<PhaseSpec>& phases) {
  std::vector<PhaseSpan> spans;
  for (const PhaseSpec& phase : phases) {
    PhaseSpan span{phase, 0, 0};
    bool seen = false;
    for (const Transform& t : truth) {
      const double range = t.translation.norm();
      if (!(range >= phase.min_range_m && range < phase.max_range_m)) continue;
      if (!seen) span.start = t.stamp;
      span.end = t.stamp;
      seen = true;
    }
    if (seen) spans.push_back(span);
  }
  std::sort(spans.begin(), spans.end(),
            [](const PhaseSpan& a, const PhaseSpan& b) { return a.start < b.start; });
  return spans;
}

double longestGapWithin(const std::vector<Timestamp>& valid_stamps, Timestamp start,
                        Timestamp end) {
  Timestamp previous = start, longest = 0;
  for (Timestamp t : valid_stamps) {
    if (t < start || t > end) continue;
    longest = std::max(longest, t - previous);
    previous = t;
  }
  longest = std::max(longest, end - previous);
  return toSeconds(longest);
}

}  // namespace cdff::eval
