#pragma once
// Run sets: several DFPC graphs run together with the Orchestrator's hand-overs between them,
// written once in a YAML file instead of on the command line (`cdff run`'s --map, --set, --pair
// and --run-while). `cdff run`, `cdff node`, `cdff dfpc check`, campaigns and Python's
// `cdff.dfpc.run` take a run set wherever they take a graph file:
//
//   name: rendezvous
//   doc: ...
//   graphs: [far_range_tracking.yaml, lidar_tracking.yaml]   # relative to this file
//   map: [visual_tracking.initial_pose=/cdff/lidar_to_visual/initial_pose]
//   set: [far_range_tracking/predict.use_imu=true]
//   pair: [/chaser/stereo/pair=/chaser/camera/left/image,/chaser/camera/right/image]
//   run_while:
//     - "lidar_to_visual: lidar_tracking.track_state == TRACKING and lidar_tracking.range < 6"
//
// A file is a run set when its top level has `graphs`. Errors in the one format (file:line).

#include <string>
#include <vector>

#include "cdff/dfpc/orchestrator.hpp"
#include "cdff/dfpc/replay.hpp"
#include "cdff/dfpc/stereo_pairing.hpp"
#include "cdff/types/status.hpp"

namespace cdff::dfpc {

struct RunSet {
  std::string name;
  std::string doc;
  std::vector<std::string> graph_files;   // resolved against the run set's folder
  std::vector<ChannelRemap> maps;         // "DFPC.INPUT=/channel", as --map
  std::vector<std::string> settings;      // "[DFPC/]NODE.PARAM=VALUE", as --set
  std::vector<StereoPairing> pairs;       // "/pair=/left,/right", as --pair
  std::vector<ActivationRule> run_while;  // rules, as --run-while
};

/// Whether `path` is a readable YAML file whose top level has `graphs` (a run set, not a graph).
bool isRunSetFile(const std::string& path);

/// Reads a run set; every word is checked as its command-line option would be (a map, a
/// setting, a pair, a rule), at its line.
Result<RunSet> loadRunSet(const std::string& path);

}  // namespace cdff::dfpc
