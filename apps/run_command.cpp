// cdff run GRAPH.yaml... -i IN.mcap [-i MORE.mcap] -o OUT.mcap [--set NODE.PARAM=VALUE ...]
//          [--map DFPC.INPUT=/channel] [--pair /pair=/left,/right] [--run-while RULE]
//          [--roi X,Y,W,H@TIME]
// A GRAPH may be a run set (graphs, maps, settings, pairs and rules in one file; docs/dfpc.md).
//
// Replays recordings through one or several DFPCs and records the ground truth of the inputs,
// every product, every event and one timing record per DFN call into OUT.
#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <memory>

#include "cdff/dfpc/designation.hpp"
#include "cdff/dfpc/recording_streams.hpp"
#include "cdff/dfpc/replay.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

struct RunArguments {
  std::vector<std::string> graphs;
  std::vector<std::string> inputs;
  std::string output;
  bool realtime = false;
  double speed = 1.0;
  std::vector<std::string> maps;
  std::vector<std::string> pairs;
  std::vector<std::string> run_while;
  std::vector<std::string> rois;
  std::vector<std::string> settings;
  std::vector<std::string> passthrough = dfpc::ReplayOptions{}.passthrough_prefixes;
  bool no_timing = false;
  std::string compression = "lz4";
  std::optional<double> start_s, end_s;
  bool quiet = false;
};

// Ctrl-C stops the replay between two messages; the output is then closed properly, so that
// everything recorded so far stays readable.
std::atomic<bool> interrupted{false};
extern "C" void onInterrupt(int) {
  interrupted.store(true);
}

std::string formatSeconds(Timestamp us) {
  return fmt::format("{:.3f} s", us * 1e-6);
}

// --set, --map, --pair and --run-while, each checked before anything is opened.
bool parseRepeatedOptions(const RunArguments& args, dfpc::ReplayOptions& options) {
  const auto fail = [](const char* option, const Status& s) {
    fmt::print(stderr, "error: {}{}\n", option, s.message());
    return false;
  };
  for (const std::string& text : args.settings)
    if (Result<dfpc::ParameterSetting> s = dfpc::parseParameterSetting(text); !s)
      return fail("", s.status());
  for (const std::string& text : args.maps) {
    Result<dfpc::ChannelRemap> remap = dfpc::parseRemap(text);
    if (!remap) return fail("--map: ", remap.status());
    options.remaps.push_back(std::move(remap).value());
  }
  for (const std::string& text : args.pairs) {
    Result<dfpc::StereoPairing> pairing = dfpc::parseStereoPairing(text);
    if (!pairing) return fail("--pair: ", pairing.status());
    options.stereo_pairs.push_back(std::move(pairing).value());
  }
  for (const std::string& text : args.rois)
    if (Result<dfpc::Designation> d = dfpc::parseDesignation(text); !d)
      return fail("--roi: ", d.status());
  for (const std::string& text : args.run_while) {
    Result<dfpc::ActivationRule> rule = dfpc::parseActivationRule(text);
    if (!rule) return fail("--run-while: ", rule.status());
    options.run_while.push_back(std::move(rule).value());
  }
  return true;
}

int runGraphs(const RunArguments& args) {
  dfpc::ReplayOptions options;
  options.graph_files = args.graphs;
  options.realtime = args.realtime;
  options.speed = args.speed;
  options.passthrough_prefixes = args.passthrough;
  options.parameter_settings = args.settings;
  options.record_timing = !args.no_timing;
  options.cancel = &interrupted;
  if (args.speed <= 0 || !std::isfinite(args.speed)) {
    fmt::print(stderr, "error: --speed {}: expected a positive number\n", args.speed);
    return 2;
  }
  if (!parseRepeatedOptions(args, options)) return 2;
  const auto compression = io::compressionFromString(args.compression);
  if (!compression) {
    fmt::print(stderr, "error: --compression '{}' is not one of none, lz4, zstd\n",
               args.compression);
    return 2;
  }

  dfpc::McapInputStream input;
  io::ReplayOptions window;
  // A window keeps what was recorded once at the beginning (the mountings a graph needs).
  window.keep_static = true;
  {
    // --start/--end and --roi are seconds from the beginning of the inputs: open once to learn it.
    if (args.start_s || args.end_s || !args.rois.empty()) {
      io::Replay probe;
      if (Status s = probe.open(args.inputs); !s.isOk()) {
        fmt::print(stderr, "error: {}\n", s.message());
        return 1;
      }
      const Timestamp t0 = probe.startTime();
      if (args.start_s) window.start = t0 + static_cast<Timestamp>(*args.start_s * 1e6);
      if (args.end_s) window.end = t0 + static_cast<Timestamp>(*args.end_s * 1e6);
      for (const std::string& text : args.rois) {
        dfpc::Designation d = dfpc::parseDesignation(text).value();
        d.region.stamp = t0 + static_cast<Timestamp>(std::llround(d.time_s * 1e6));
        options.injected.push_back(
            dfpc::Message::of(dfpc::kDesignationChannel, d.region.stamp, d.region));
      }
    }
  }
  if (Status s = input.open(args.inputs, window); !s.isOk()) {
    fmt::print(stderr, "error: {}\n", s.message());
    return 1;
  }

  dfpc::McapSink sink;
  dfpc::McapSinkOptions sink_options;
  sink_options.writer.compression = *compression;
  if (Status s = sink.open(args.output, sink_options); !s.isOk()) {
    fmt::print(stderr, "error: {}\n", s.message());
    return 1;
  }

  const bool terminal = !args.quiet && isatty(2) == 1;
  dfpc::ProgressBar bar(stderr, terminal);
  options.progress = [&bar](const dfpc::RunProgress& p) { bar.update(p); };

  interrupted.store(false);
  auto previous = std::signal(SIGINT, onInterrupt);
  const auto wall_start = std::chrono::steady_clock::now();
  Result<dfpc::ReplayResult> result = dfpc::replay(input, sink, options);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  std::signal(SIGINT, previous);
  bar.finish();

  // The run's failure is recorded as an event too, so that the output file says why it ends.
  int status = 0;
  if (!result) {
    fmt::print(stderr, "error: {}\n", result.status().message());
    dfpc::Event failure;
    failure.type = dfpc::EventType::kRecoveryFailed;
    failure.dfpc = "cdff run";
    failure.message = fmt::format("the run stopped: {}", result.status().message());
    (void)sink.writeEvent(failure);
    status = 1;
  }
  if (Status s = sink.close(); !s.isOk()) {
    fmt::print(stderr, "error: closing '{}': {}\n", args.output, s.message());
    return 1;
  }
  if (!result) {
    fmt::print(stderr, "{}: what was produced before the error is recorded\n", args.output);
    return status;
  }

  const dfpc::RunSummary& s = result->summary;
  const Timestamp span = s.first && s.last ? *s.last - *s.first : 0;
  fmt::print("{}{} messages read ({} of stream time in {:.2f} s wall, {:.1f}x real time)\n",
             s.cancelled ? "interrupted: " : "", s.messages, formatSeconds(span), wall_s,
             wall_s > 0 ? span * 1e-6 / wall_s : 0.0);
  fmt::print("{} products, {} copied through, {} events ({} faults, {} recoveries) -> {}\n",
             s.products, s.passed_through, s.events, s.faults, s.recoveries, args.output);
  for (const dfpc::DfpcStatus& d : result->dfpcs) {
    fmt::print("  {}: {}{}, {} messages, {} products, {} faults{}\n", d.name, toString(d.state),
               d.track_state ? fmt::format(" (track {})", toString(*d.track_state)) : "",
               d.messages, d.products, d.faults,
               d.last_fault.empty() ? "" : fmt::format(", last fault: {}", d.last_fault));
  }
  for (const auto& [channel, why] : input.skippedChannels())
    fmt::print("  not replayed: {} ({})\n", channel, why);
  return s.cancelled ? 130 : 0;
}

}  // namespace

void addRunCommand(CLI::App& root, int& exit_code) {
  auto args = std::make_shared<RunArguments>();
  CLI::App* run = root.add_subcommand(
      "run", "Replay MCAP recordings through DFPC graphs; record products, events, timings");
  run->add_option("GRAPH", args->graphs, "DFPC graph files or run sets (YAML), run together")
      ->required();
  run->add_option("-i,--input", args->inputs, "Input MCAP file (repeatable; merged by time)")
      ->required();
  run->add_option("-o,--output", args->output, "Output MCAP file")->required();
  run->add_flag("--realtime", args->realtime, "Pace the replay on the clock");
  run->add_option("--speed", args->speed, "With --realtime: stream seconds per clock second")
      ->capture_default_str();
  run->add_option("--map", args->maps,
                  "Feed a DFPC input from another channel: DFPC.INPUT=/channel (repeatable)");
  run->add_option("--pair", args->pairs,
                  "Make stereo pairs from two image channels: /pair=/left/image,/right/image "
                  "(repeatable)");
  run->add_option("--run-while", args->run_while,
                  "Run a DFPC only while a rule holds: DFPC=TRACKER:STATE[,STATE] (another's "
                  "track state), or 'DFPC: CONDITION' over the DFPCs' track_state, range and "
                  "outputs, e.g. 'visual_tracking: lidar_tracking.range < 5' (repeatable)");
  run->add_option("--roi", args->rois,
                  "Designate the target: the box X,Y,W,H (pixels) of the image at TIME s from "
                  "the start, sent on /cdff/designation (far-range tracking; repeatable)");
  run->add_option("--set", args->settings,
                  "Set an instance's parameter without editing the graph: "
                  "[DFPC/]NODE.PARAM=VALUE, the value YAML (repeatable)");
  run->add_option("--passthrough", args->passthrough,
                  "Copy input channels with this prefix, or matching this pattern (with * ? "
                  "[]), to the output (repeatable)")
      ->capture_default_str();
  run->add_flag("--no-timing", args->no_timing, "Do not record a timing record per DFN call");
  run->add_option("--compression", args->compression, "Output chunks: none, lz4 or zstd")
      ->capture_default_str();
  run->add_option("--start", args->start_s, "Start at this time, s from the inputs' beginning");
  run->add_option("--end", args->end_s, "End at this time, s from the inputs' beginning");
  run->add_flag("-q,--quiet", args->quiet, "No progress bar");
  run->callback([args, &exit_code] { exit_code = runGraphs(*args); });
}

}  // namespace cdff::app
