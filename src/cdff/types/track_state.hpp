#pragma once
// The state of a track, one definition for the DFNs that publish it, the DFPC graphs whose
// conditions and recoveries name it, and the evaluation that counts tracked frames.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace cdff {

enum class TrackState {
  kUninitialised,  // no estimate yet
  kAcquiring,      // an estimate that is not yet a track (an acquisition not yet confirmed)
  kTracking,       // a confirmed track
  kDegraded,       // a track with reduced quality (a failed camera, few inliers); still valid
  kLost,           // the track was lost; the estimate is a prediction
};

/// "UNINITIALISED", "ACQUIRING", "TRACKING", "DEGRADED", "LOST": the names graph files,
/// recordings and reports use.
std::string_view toString(TrackState state);
/// The state named `name` (exactly as toString() writes it), or none.
std::optional<TrackState> parseTrackState(std::string_view name);
/// Every state, in declaration order.
const std::vector<TrackState>& allTrackStates();
/// The states' names joined by `separator` ("UNINITIALISED, LOST"), for messages.
std::string joinTrackStates(const std::vector<TrackState>& states, std::string_view separator);
/// Whether an estimate in this state counts as a tracked frame (TRACKING or DEGRADED).
bool isTracked(TrackState state);

}  // namespace cdff
