#pragma once
// Replaying recordings through DFPCs: everything `cdff run` does except reading and writing
// files. The command opens its inputs as InputStreams (merged by timestamp) and its output as a
// Sink, and calls replay(); the recording library provides both for MCAP.
//
//   std::vector<std::unique_ptr<InputStream>> inputs = ...;   // one per -i FILE
//   MergedStream input(std::move(inputs));
//   ReplayOptions options;                                   // --realtime, --speed, --map...
//   options.graph_files = {"dfpcs/pose_filtering.yaml"};
//   ProgressBar bar(stderr, isatty(2));
//   options.progress = [&](const RunProgress& p) { bar.update(p); };
//   Result<ReplayResult> result = replay(input, sink, options);
//   bar.finish();

#include <atomic>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cdff/dfpc/orchestrator.hpp"
#include "cdff/dfpc/stereo_pairing.hpp"

namespace cdff::dfpc {

struct ChannelRemap {
  std::string input;    // "dfpc.input", or "input" when only one DFPC has an input so named
  std::string channel;  // the channel that feeds it instead of the graph's
};

/// Parses "dfpc.input=/channel" (or "input=/channel").
Result<ChannelRemap> parseRemap(const std::string& text);

struct ReplayOptions {
  /// One DFPC per graph file, all run together; a run set (run_set.hpp) adds its graphs, maps,
  /// settings, pairs and rules (after the options' own settings, so that a --set overrides it).
  std::vector<std::string> graph_files;
  std::vector<ChannelRemap> remaps;
  /// Stereo pairs made from two image channels of the input (StereoPairStream), for the DFPCs
  /// that take StereoImagePair.
  std::vector<StereoPairing> stereo_pairs;
  /// DFPCs that run only while another's track state is in given states (detection while a
  /// tracker is UNINITIALISED or LOST).
  std::vector<ActivationRule> run_while;
  /// Messages merged into the input by stamp (a user's designation, `cdff run --roi`).
  std::vector<Message> injected;
  /// Instance parameters set without editing the graphs: "[DFPC/]NODE.PARAM=VALUE"
  /// (ParameterSetting); each must address exactly one graph's instance.
  std::vector<std::string> parameter_settings;
  bool realtime = false;   // pace on the clock instead of as fast as possible
  double speed = 1.0;      // with realtime: stream seconds per clock second
  Clock* clock = nullptr;  // the pacing clock (steady when null)
  /// Input channels copied to the output (prefixes or patterns, OrchestratorOptions): the ground
  /// truth and the cameras' calibrations by default (evaluation needs both: a bearing's pixels).
  std::vector<std::string> passthrough_prefixes = {"/truth/", "/chaser/camera/*/calibration"};
  bool record_timing = true;
  std::function<void(const RunProgress&)> progress;
  const std::atomic<bool>* cancel = nullptr;
};

struct ReplayResult {
  RunSummary summary;
  std::vector<DfpcStatus> dfpcs;  // at the end of the run
};

/// The options with every run set of graph_files replaced by its graphs, its maps, settings,
/// pairs and rules added (replay() and externalInputs() do it themselves).
Result<ReplayOptions> expandRunSets(const ReplayOptions& options);

/// Everything replay() checks before it reads the input: the run sets, graphs, settings,
/// remaps and rules (`cdff dfpc check` on a run set).
Status checkRun(const ReplayOptions& options);

/// Loads the graphs, applies the remaps, checks the input's channels, runs the input to its end
/// and flushes the sink. Errors: a graph that does not load (every problem, with file:line), a
/// remap that names no input, a channel the input lacks, a message of the wrong type, a failed
/// write, a run-while rule that names a DFPC not loaded, an image without its mounting (pairs).
Result<ReplayResult> replay(InputStream& input, Sink& sink, const ReplayOptions& options);

/// The graphs of `options` loaded, with their parameter settings and remaps applied (what
/// replay() runs; `cdff node` hands them to the external API). Errors: as replay()'s.
Result<std::vector<GraphSpec>> loadGraphs(const ReplayOptions& options);

/// The channels that the graphs of `options` (with their settings and remaps) read from outside
/// the run, with their types: every DFPC input whose channel no loaded DFPC's output produces.
/// What a live input must provide (`cdff node` subscribes to them). Errors: as replay()'s.
Result<std::vector<ChannelInfo>> externalInputs(const ReplayOptions& options);

/// A one-line progress bar on a terminal ("[#####.....]  52.0 %  t = 12.30 s  4 517 messages"),
/// redrawn at most every `interval_s` of steady time; nothing when disabled (not a terminal).
class ProgressBar {
 public:
  ProgressBar(std::FILE* out, bool enabled, double interval_s = 0.1);
  void update(const RunProgress& progress);
  /// Draws the final state and ends the line.
  void finish();
  /// The line for a progress state (without the carriage return).
  static std::string render(const RunProgress& progress, int width = 30);

 private:
  std::FILE* out_;
  bool enabled_;
  Timestamp interval_;
  Timestamp last_draw_ = 0;
  std::optional<RunProgress> last_;
};

}  // namespace cdff::dfpc
