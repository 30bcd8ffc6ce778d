#pragma once
// Evaluating a run's recording (the output of `cdff run`): which product channel is measured
// against which truth channel, when a product counts as valid, and its processing latency.
//
//   Result<EvaluationReport> report = evaluateRecording({"out.mcap"});
//
// - Products: channels /cdff/<dfpc>/<output> whose type is a pose (PoseWithCovariance,
//   RigidBodyState or Transform) or a Bearing (far-range tracking; bearing_evaluation.hpp), the
//   latter in pixels with the focal length of the recording's camera calibration (CameraModel).
// - Truth: channels under /truth/ of a pose type. A product is paired with the truth channel of
//   the same transform (same parent and child frames); several candidates: the one named
//   /truth/target_pose, else the first by name (the report notes it). `pairs` overrides.
// - Validity: a product is valid unless its DFPC's track state at that time (from the
//   track_state_changed events on /cdff/events) is LOST or UNINITIALISED, or its pose is not
//   finite. A DFPC without a track state has every product valid.
// - Latency: the wall time of the DFN calls that the DFPC's step made at the product's stamp
//   (the timing records on /cdff/<dfpc>/timing), summed.
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/eval/report.hpp"

namespace cdff::eval {

struct RecordingEvaluationOptions {
  PoseEvaluationOptions pose;
  Statistic statistic = Statistic::kP95;
  /// product channel -> truth channel, instead of pairing by frames.
  std::map<std::string, std::string> pairs;
  /// Only these product channels (empty: every pose and bearing product).
  std::vector<std::string> products;
  /// The focal length (px) of bearings' pixel errors; NaN: from `camera_channel`'s calibration,
  /// or the recording's only camera calibration.
  double focal_px = std::numeric_limits<double>::quiet_NaN();
  std::string camera_channel;
};

/// What a recording holds that evaluation could not use, for the user to see.
struct RecordingEvaluationNotes {
  std::vector<std::string> notes;
};

/// Reads the recordings, pairs products with truth, evaluates each pair and checks the
/// requirements. Fails when a file cannot be read, when it has no pose or bearing product or no
/// truth at all (the message lists the channels it has), when a requested pair names a channel
/// that is missing or not a pose, or when --camera names one that is not a calibration.
Result<EvaluationReport> evaluateRecording(const std::vector<std::string>& paths,
                                           const RecordingEvaluationOptions& options = {},
                                           RecordingEvaluationNotes* notes = nullptr);

}  // namespace cdff::eval
