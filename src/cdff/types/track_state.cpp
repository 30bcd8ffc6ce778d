#include "cdff/types/track_state.hpp"

namespace cdff {

std::string_view toString(TrackState state) {
  switch (state) {
    case TrackState::kUninitialised:
      return "UNINITIALISED";
    case TrackState::kAcquiring:
      return "ACQUIRING";
    case TrackState::kTracking:
      return "TRACKING";
    case TrackState::kDegraded:
      return "DEGRADED";
    case TrackState::kLost:
      return "LOST";
  }
  return "UNINITIALISED";
}

const std::vector<TrackState>& allTrackStates() {
  static const std::vector<TrackState> states = {TrackState::kUninitialised, TrackState::kAcquiring,
                                                 TrackState::kTracking, TrackState::kDegraded,
                                                 TrackState::kLost};
  return states;
}

std::optional<TrackState> parseTrackState(std::string_view name) {
  for (TrackState s : allTrackStates())
    if (toString(s) == name) return s;
  return std::nullopt;
}

std::string joinTrackStates(const std::vector<TrackState>& states, std::string_view separator) {
  std::string out;
  for (TrackState s : states) {
    if (!out.empty()) out += separator;
    out += toString(s);
  }
  return out;
}

bool isTracked(TrackState state) {
  return state == TrackState::kTracking || state == TrackState::kDegraded;
}

}  // namespace cdff
