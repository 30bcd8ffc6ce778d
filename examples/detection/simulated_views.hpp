#pragma once
// Single frames of the simulator for the detection DFPCs (dfpcs/detection.yaml: a stereo pair;
// dfpcs/detection_tof.yaml: a ToF camera's depth map): each frame
// is a scenario of the library (for its lighting and background: side light over deep space, the
// sunlit Earth behind the target, specular glare, back light...) with the servicer held on that
// scenario's line of sight at a drawn range, the target at an attitude drawn uniformly on SO(3)
// and the camera's pointing offset by a drawn angle, so that the target is anywhere in the image
// with at least `min_in_view` of it in view. A frame without the target points the cameras away
// from it (stars, the Earth, empty space). Every draw is a function of its seed. Used by the
// detection's end-to-end test and benchmark.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/lidar_info.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff::detection_demo {

/// The sensor a frame is taken with.
enum class DepthSource {
  kStereo,  // the Prosilica pair (camera_left, camera_right): dfpcs/detection.yaml
  kTof,     // the ToF camera (tof): dfpcs/detection_tof.yaml
  kLidar,   // the LIDAR (lidar): one revolution's scan, for the 3D model detection
};

struct ViewOptions {
  DepthSource source = DepthSource::kStereo;
  /// Library scenarios whose lighting and background the frames take, one drawn per frame.
  std::vector<std::string> lighting = {"mid_range_approach", "close_range_approach",
                                       "earth_background",   "specular_glare",
                                       "under_illuminated",  "tumbling_target"};
  double min_range = 2.0, max_range = 17.0;  // m, camera to the target's bounding centre
  /// Fraction of the target's surface (area-weighted samples, occlusion ignored) that must
  /// project into the left image (the ToF camera's; the LIDAR's: lie within its lasers'
  /// elevations and range).
  double min_in_view = 0.8;
  /// Scenario "dotted.key=value" overrides of every frame (e.g. another target:
  /// "target.procedural.kind=hexagonal").
  std::vector<std::string> overrides;
};

struct SimulatedView {
  DepthSource source = DepthSource::kStereo;
  StereoImagePair pair;  // kStereo: as the simulator's cameras give it (distorted, unrectified)
  DepthMap depth;        // kTof: the ToF camera's depth map (with its calibration)
  PointCloud scan;       // kLidar: the scan, in the LIDAR's frame
  LidarInfo lidar;       // kLidar: the LIDAR's description
  /// The detecting sensor's mounting: servicer_T_camera_left_optical
  /// (/chaser/tf/camera_left_optical), servicer_T_tof_optical (/chaser/tf/tof_optical) or
  /// servicer_T_lidar (/chaser/tf/lidar).
  Transform camera_mounting;
  Transform truth;         // servicer_T_target (/truth/target_pose), at the frame's stamp
  Transform camera_truth;  // camera_left_optical_T_target, tof_optical_T_target or lidar_T_target
  std::string lighting;    // the scenario it was lit as
  double range = 0;        // m, the sensor to the target's bounding centre
  bool target_in_view = true;
};

/// The frame of `seed`: the target in view (`with_target`), or the cameras turned away from it.
Result<SimulatedView> simulateView(const ViewOptions& options, std::uint64_t seed,
                                   bool with_target = true);

/// What the detection DFPC made of one frame.
struct DetectionOutcome {
  bool detected = false;
  /// camera_left_optical_T_target (the stereo graph's camera_pose), or, for a graph without a
  /// camera_pose output (the ToF graph), servicer_T_target; when detected.
  PoseWithCovariance camera_pose;
  RigidBodyState pose;                            // servicer_T_target, when detected
  double fitness = 0, confirmed = 0, misfit = 0;  // of the depth refinement's best pose (NaN: none)
  double rival_margin = 0;    // the depth refinement's (NaN: none, or a graph without it)
  double inlier_ratio = 0;    // of the edge refinement's chosen pose (NaN: none)
  int alternatives = 0;       // distinct poses the edge refinement compared
  double position_error = 0;  // m, of camera_pose against the truth in its frame, when detected
  double angle_error = 0;     // rad
  double nees = 0;            // camera_pose's 6-dof NEES
  double cpu_s = 0;           // CPU of all DFN calls of the frame, one thread
  std::vector<std::pair<std::string, double>> node_cpu_s;  // per instance, CPU s
  std::size_t dfn_errors = 0;
  std::string fault;  // the DFPC's last fault, when a DFN failed on this frame
};

/// The detection graph of `source` (dfpcs/detection.yaml or dfpcs/detection_tof.yaml in
/// `source_dir`, CDFF_SOURCE_DIR when empty) in an Orchestrator of its own, fed one simulated
/// frame at a time (each a second of stream time after the last: the frames are independent
/// draws). Relative file parameters are the repository's.
class Detector {
 public:
  /// `settings`: "NODE.PARAM=VALUE", as `cdff run --set` takes them.
  static Result<std::unique_ptr<Detector>> create(const std::vector<std::string>& settings,
                                                  const std::string& source_dir = "",
                                                  DepthSource source = DepthSource::kStereo);
  ~Detector();
  /// Runs the frame through the DFPC and compares what it detected with the truth.
  Result<DetectionOutcome> run(const SimulatedView& view);

 private:
  struct State;
  explicit Detector(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace cdff::detection_demo
