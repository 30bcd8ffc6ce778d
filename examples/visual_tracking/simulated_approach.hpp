#pragma once
// The visual tracking DFPC (dfpcs/visual_tracking.yaml, or visual_tracking_stereo.yaml) on a
// scenario of the simulator, streamed frame by frame from the simulator into the Orchestrator,
// started from the true pose perturbed by a fraction of the range and an angle, and evaluated
// against the simulator's ground truth with src/cdff/eval. Used by the end-to-end tests, the
// benchmark and `visual_tracking_demo` (what `make demo` calls).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cdff/egse/model_perturbation.hpp"
#include "cdff/eval/draws.hpp"
#include "cdff/eval/initial_state.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/polygon_model.hpp"
#include "cdff/types/status.hpp"

namespace cdff::dfpc {
class Dfpc;
}
namespace cdff::egse {
class Simulator;
}

namespace cdff::visual_demo {

struct ApproachOptions {
  std::string scenario = "close_range_approach";  // a library name or a path
  std::vector<std::string> overrides;             // scenario "dotted.key=value" overrides
  std::uint64_t seed = 7;
  std::optional<double> duration;   // s; the scenario's when unset
  double camera_rate = 2.0;         // Hz (the simulated camera does 10)
  bool stereo = false;              // visual_tracking_stereo.yaml on left/right pairs
  std::string dfi = "EdgeTracker";  // or VispMbt
  std::string dfi_parameters;       // YAML map merged into the tracker's parameters
  double initial_range_fraction = 0.05;
  double initial_angle = 5.0 * 3.14159265358979323846 / 180.0;  // rad
  std::uint32_t initial_seed = 1;
  /// When set, the initial state is drawn as `cdff initial-state` draws it
  /// (eval::perturbedInitialState: a Gaussian error, the covariance the filter is told, the twist
  /// sigmas; the fixed-size error above is not used) and stamped at the first image, which is
  /// then not tracked: as with `cdff initial-state --at IMAGE_CHANNEL` and `cdff run`, where the
  /// image comes before the state of the same stamp, the first tracked frame is one camera period
  /// after the initial state, as for a detection that arrives late.
  std::optional<eval::InitialStatePerturbation> initial_error;
  std::string source_dir;  // the repository (dfpcs/); CDFF_SOURCE_DIR when empty
  /// The tracker's model: when empty, the simulator's own target (its .cao export) on the
  /// graph's model input; otherwise this .cao file as the tracker's `model_file` and nothing on
  /// the model input, as a user runs the graph with only the model file changed.
  std::string model_file;
  /// Parameters of the graph's nodes, "NODE.PARAM=VALUE" as `cdff run --set` takes them (e.g.
  /// "consider.range_scale_sigma=0.01", the model's stated accuracy); a setting that addresses no
  /// node of the graph is an error.
  std::vector<std::string> graph_settings;
};

struct ApproachResult {
  eval::PoseEvaluation filtered;      // /cdff/visual_tracking/pose against /truth/target_pose
  eval::PoseEvaluation camera_frame;  // .../camera_pose against /truth/camera_left/target_pose
  eval::PoseEvaluation measurement;   // the tracker's own estimates (camera frame)
  std::vector<double> stamps_s;       // per frame
  std::vector<int> status;            // per frame: 0 tracking, 1 degraded, 2 lost
  /// Per frame: the DFPC's track state then was a track (TRACKING or DEGRADED; not LOST,
  /// ACQUIRING or UNINITIALISED), what `cdff eval` counts as a valid estimate.
  std::vector<bool> valid;
  std::vector<double> range_m;                            // per frame, the true range
  std::vector<double> position_error_m, angle_error_deg;  // per frame, of the filtered pose
  std::size_t frames = 0, lost = 0, degraded = 0;
  /// Frames whose filtered error exceeds 10 % of the range or 10 degrees while the status is
  /// not LOST: divergence the DFPC did not report.
  std::size_t unreported_divergence = 0;
  eval::ErrorStatistics cpu_per_frame_s;  // CPU of all DFN calls of a frame (undistortion,
                                          // tracker, filter), one thread
  double mean_cpu_per_frame_s = 0;
  std::size_t dfn_errors = 0;
  std::size_t late_frames = 0;  // published after a newer frame: dropped
  std::string renderer;
  std::vector<std::string> warnings;  // the DFNs' warnings (why frames were lost), first 20
};

/// Runs the scenario (cameras only) through the DFPC.
Result<ApproachResult> runApproach(const ApproachOptions& options);

/// The options of one draw (data/evaluation/draws.yaml): the simulator's seed and the initial
/// error's, a Gaussian error of RMS `position_fraction` of the range and `angle` (rad) with twist
/// sigmas `linear_velocity_sigma` (m/s) and `angular_velocity_sigma` (rad/s).
ApproachOptions drawOptions(const eval::Draw& draw, const std::string& scenario,
                            std::optional<double> duration, double position_fraction, double angle,
                            double linear_velocity_sigma, double angular_velocity_sigma);

/// The draw sets of data/evaluation/draws.yaml (in `source_dir`, CDFF_SOURCE_DIR when empty).
Result<eval::DrawSets> drawSets(const std::string& source_dir = "");

/// How one run acquired: from the first tracked frame, the time to the first frame reported as a
/// track (valid), and what the track reported afterwards.
struct AcquisitionOutcome {
  bool tracked = false;         // some frame was valid
  double time_to_track_s = -1;  // first valid frame's time - first frame's time (-1: never)
  /// The first acquisition held: the first valid frame is the second one (the acquisition is
  /// reported ACQUIRING until the next frame confirms it).
  bool first_acquisition_confirmed = false;
  std::size_t wrong_frames = 0;      // valid frames off by more than 5 % of the range or 10 degrees
  std::size_t lost_after_track = 0;  // LOST or ACQUIRING frames after the first valid one
  std::size_t valid_frames = 0, frames = 0;
  std::vector<double> position_error_m, position_error_pct, angle_error_deg;  // valid frames
  std::vector<double> nees;  // valid frames: the filtered pose's 6-dof NEES (6 when honest)
};
AcquisitionOutcome acquisitionOutcome(const ApproachResult& r);

/// The left camera's frames of the scenario with the true camera_left_optical_T_target of each,
/// the camera's mounting (servicer_T_camera_left_optical) and the target's model (its .cao
/// export), for benchmarks.
struct SimulatedFrames {
  PolygonModel model;
  std::vector<Image> images;
  std::vector<Transform> truth;
  Transform camera_mounting;
};
Result<SimulatedFrames> simulateFrames(const ApproachOptions& options);

/// The scenario's simulator (cameras only, options.camera_rate) and the DFPC of `options`
/// (graph, DFI and parameters).
Result<std::unique_ptr<egse::Simulator>> makeSimulator(const ApproachOptions& options);
Result<std::unique_ptr<dfpc::Dfpc>> makeDfpc(const ApproachOptions& options);

/// Writes the target of `options`' scenario (as the simulator builds it, with the overrides)
/// with `perturbation` applied, as a .cao file at `path`: a tracker's model that differs from the
/// simulated target. A re-triangulation (flip_diagonals, max_edge) changes the mesh, not the face
/// model's polygons, so the file's faces are then the mesh's triangles, as a CAD export that
/// triangulates gives them.
Status writePerturbedModel(const ApproachOptions& options,
                           const egse::ModelPerturbation& perturbation,
                           const std::filesystem::path& path);

/// Issue 16's runs with a tracker's model or calibrations that are not the simulator's own
/// (docs/visual-tracking.md, "Another target, model errors and calibration errors"); the graph
/// is not edited:
///   - kSecondTarget: the simulator's target is the second procedural target
///     (target.procedural.kind=hexagonal) and the tracker's model_file its committed export,
///     data/models/hexagonal_target.cao;
///   - kModelErrors: the first target's model 1 % larger, without its thrusters (on the aft deck
///     that both approaches see; the antenna is on the +z face, behind the bus at close range),
///     re-triangulated (the mesh's triangles as faces, their diagonals flipped), written to a
///     .cao file as the tracker's model_file;
///   - kCalibrationErrors: the left camera's published mounting off by a Gaussian error of RMS
///     0.2 degrees and 2 mm, its intrinsics (fx, fy, cx, cy) by RMS 0.5 % (the simulator's
///     `calibration_error`, drawn from the run's seed).
enum class ModelVariant { kSecondTarget, kModelErrors, kCalibrationErrors };
const char* toString(ModelVariant v);
/// The model errors of kModelErrors.
egse::ModelPerturbation modelErrors();
/// `options` changed to run `variant`; kModelErrors writes its model file into `directory`
/// (which must exist), named after the scenario.
Result<ApproachOptions> withVariant(ApproachOptions options, ModelVariant variant,
                                    const std::filesystem::path& directory);
/// The variant's errors as a user states them to the graph (its `consider` node's parameters,
/// ApproachOptions::graph_settings): the model 1 % too large as a range scale of 1 %; the
/// calibration's 0.2 degrees, 2 mm and 0.5 %; nothing for the second target (its own model).
std::vector<std::string> statedErrors(ModelVariant variant);

/// One line of figures for a table: frames, lost, p95/max position and angle, CPU per frame.
std::string summaryLine(const std::string& label, const ApproachResult& r);

}  // namespace cdff::visual_demo
