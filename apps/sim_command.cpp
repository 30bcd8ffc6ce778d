// cdff sim SCENARIO -o OUT.mcap [--seed N] [--duration S] [--set key=value ...]
// cdff sim --list | SCENARIO --check | SCENARIO --export-model DIR
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cdff/egse/mcap_sink.hpp"
#include "cdff/egse/model_io.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/simulator.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

struct SimOptions {
  std::string scenario;
  std::string output;
  std::string export_dir;
  std::uint64_t seed = 0;
  bool seed_given = false;
  double duration = 0;
  std::vector<std::string> overrides;
  std::string renderer;
  bool list = false, check = false, quiet = false, digest = false;
  std::string snapshot_dir;
  std::vector<double> snapshot_times;
  double snapshot_scale = 1.0;
};

// Writes the camera images (and ToF depth, scaled to 8 bits) nearest to the requested times as
// PNG, for looking at a scenario without a viewer.
class SnapshotSink final : public egse::SimulationSink {
 public:
  SnapshotSink(std::string directory, std::string scenario, std::vector<double> times, double scale)
      : directory_(std::move(directory)),
        scenario_(std::move(scenario)),
        times_(std::move(times)),
        scale_(scale) {}
  Status begin(const egse::SimulationMetadata&) override {
    std::error_code ec;
    std::filesystem::create_directories(directory_, ec);
    if (ec) return ioError("cannot create '{}': {}", directory_, ec.message());
    return Status::ok();
  }
  Status write(const egse::SimMessage& m) override {
    const Image* image = std::get_if<Image>(&m.payload);
    const DepthMap* depth = std::get_if<DepthMap>(&m.payload);
    if (depth && m.channel.rfind("/chaser/", 0) == 0) image = &depth->image;
    if (!image || m.channel.rfind("/chaser/", 0) != 0) return Status::ok();
    for (double t : times_) {
      const Timestamp wanted = fromSeconds(t);
      auto& best = best_[{m.channel, wanted}];
      if (best.has_value() && std::llabs(best->stamp - wanted) <= std::llabs(image->stamp - wanted))
        continue;
      best = *image;
    }
    return Status::ok();
  }
  Status end() override {
    for (const auto& [key, image] : best_) {
      if (!image) continue;
      cv::Mat mat;
      if (image->format == PixelFormat::kFloat32) {
        cv::Mat z(image->height, image->width, CV_32FC1,
                  const_cast<std::uint8_t*>(image->pixels.data()), image->stride_bytes);
        double lo = 0, hi = 0;
        cv::minMaxLoc(z, &lo, &hi, nullptr, nullptr, z > 0);
        z.convertTo(mat, CV_8UC1, hi > lo ? -200.0 / (hi - lo) : 0,
                    hi > lo ? 230.0 + 200.0 * lo / (hi - lo) : 0);
        mat.setTo(0, z <= 0);
      } else {
        mat = cv::Mat(image->height, image->width,
                      image->format == PixelFormat::kBgr8 ? CV_8UC3 : CV_8UC1,
                      const_cast<std::uint8_t*>(image->pixels.data()), image->stride_bytes)
                  .clone();
      }
      if (scale_ != 1.0) cv::resize(mat, mat, cv::Size(), scale_, scale_, cv::INTER_AREA);
      std::string stream = key.first.substr(8);  // without "/chaser/"
      for (char& c : stream)
        if (c == '/') c = '_';
      const std::string path = fmt::format("{}/{}_{}_{:.1f}s.png", directory_, scenario_, stream,
                                           toSeconds(image->stamp));
      if (!cv::imwrite(path, mat, {cv::IMWRITE_PNG_COMPRESSION, 9}))
        return ioError("cannot write '{}'", path);
      fmt::print("wrote {}\n", path);
    }
    return Status::ok();
  }

 private:
  std::string directory_, scenario_;
  std::vector<double> times_;
  double scale_;
  std::map<std::pair<std::string, Timestamp>, std::optional<Image>> best_;
};

int listLibrary() {
  const auto library = egse::listScenarios();
  if (library.empty()) {
    fmt::print(stderr, "error: no scenarios in {} (set CDFF_SCENARIO_DIR)\n",
               egse::scenarioDirectory().string());
    return 1;
  }
  for (const auto& s : library)
    fmt::print("{:<24} {:>7.0f} s  {}\n", s.name, s.duration, s.description);
  return 0;
}

// A progress bar on stderr: redrawn in place on a terminal, a line per 10 % otherwise.
class Progress {
 public:
  explicit Progress(bool quiet)
      : quiet_(quiet),
        tty_(isatty(fileno(stderr)) != 0),
        start_(std::chrono::steady_clock::now()) {}
  void operator()(double t, double duration) {
    if (quiet_) return;
    const double fraction = duration > 0 ? t / duration : 1.0;
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    if (tty_) {
      const int width = 40, filled = static_cast<int>(fraction * width + 0.5);
      fmt::print(stderr, "\r[{}{}] {:5.1f}%  sim {:.1f}/{:.1f} s  wall {:.0f} s",
                 std::string(filled, '#'), std::string(width - filled, ' '), 100 * fraction, t,
                 duration, wall);
      if (fraction >= 1.0) fmt::print(stderr, "\n");
    } else {
      const int decile = static_cast<int>(fraction * 10 + 1e-9);
      if (decile > last_decile_) {
        last_decile_ = decile;
        fmt::print(stderr, "cdff sim: {:3d}%  sim {:.1f}/{:.1f} s  wall {:.0f} s\n", decile * 10, t,
                   duration, wall);
      }
    }
  }

 private:
  bool quiet_, tty_;
  std::chrono::steady_clock::time_point start_;
  int last_decile_ = -1;
};

int runSim(const SimOptions& options) {
  if (options.list) return listLibrary();
  if (options.scenario.empty()) {
    fmt::print(stderr,
               "error: cdff sim needs a SCENARIO (a name from `cdff sim --list` or a YAML file)\n");
    return 2;
  }
  if (options.output.empty() && !options.check && options.export_dir.empty() && !options.digest &&
      options.snapshot_dir.empty()) {
    fmt::print(stderr,
               "error: cdff sim {}: nothing to do; expected -o OUT.mcap, --check, --digest or "
               "--export-model DIR\n",
               options.scenario);
    return 2;
  }
  auto path = egse::resolveScenario(options.scenario);
  if (!path) {
    fmt::print(stderr, "error: {}\n", path.status().message());
    return 1;
  }
  std::vector<std::string> overrides = options.overrides;
  if (!options.renderer.empty()) overrides.push_back("renderer.backend=" + options.renderer);
  auto scenario = egse::loadScenario(*path, overrides);
  if (!scenario) {
    fmt::print(stderr, "error: {}\n", scenario.status().message());
    return 1;
  }
  if (!options.export_dir.empty()) {
    Result<egse::TargetModel> model = egse::makeScenarioTarget(*scenario);
    if (!model) {
      fmt::print(stderr, "error: {}\n", model.status().message());
      return 1;
    }
    auto files = egse::exportModel(*model, options.export_dir, "target");
    if (!files) {
      fmt::print(stderr, "error: {}\n", files.status().message());
      return 1;
    }
    for (const auto& f :
         {files->obj, files->mtl, files->ply, files->points_ply, files->cao, files->edges})
      fmt::print("wrote {}\n", f.string());
  }
  if (!options.check && options.output.empty() && !options.digest && options.snapshot_dir.empty())
    return 0;
  std::optional<std::uint64_t> seed;
  if (options.seed_given) seed = options.seed;
  std::optional<double> duration;
  if (options.duration > 0) duration = options.duration;
  auto sim = egse::Simulator::create(*scenario, seed, duration);
  if (!sim) {
    fmt::print(stderr, "error: {}: {}\n", path->string(), sim.status().message());
    return 1;
  }
  if (options.check) {
    fmt::print("{}: ok\n  {}\n  duration {} s, seed {}, renderer {}\n", path->string(),
               scenario->description, (*sim)->duration(), (*sim)->seed(),
               (*sim)->rendererDescription());
    const egse::TargetModel& target = (*sim)->target();
    fmt::print("  target model '{}', {} triangles, parts: {}\n", target.name,
               target.mesh.triangles.size(),
               target.parts.empty() ? std::string("none")
                                    : fmt::format("{}", fmt::join(target.parts, ", ")));
    const egse::CalibrationErrorSpec& ce = scenario->calibration_error;
    if (ce.active())
      fmt::print(
          "  calibration error ({}): extrinsics {} deg, {} m; intrinsics {}\n",
          ce.distribution == egse::CalibrationErrorDistribution::kFixed ? "fixed" : "gaussian",
          ce.extrinsic_angle * 180.0 / M_PI, ce.extrinsic_position, ce.intrinsics_fraction);
    for (const auto& s : scenario->sensors)
      if (s.enabled)
        fmt::print("  {:<14} {:<7} {:>6.1f} Hz  frame {:<22} {}\n", s.name, egse::toString(s.type),
                   s.rate, s.frame(), s.channelPrefix());
    for (const auto& f : scenario->faults)
      fmt::print("  fault {:<16} on {:<14} from {} s\n", egse::toString(f.type), f.sensor, f.start);
    if (options.output.empty() && !options.digest && options.snapshot_dir.empty()) return 0;
  }
  if (!options.snapshot_dir.empty()) {
    std::vector<double> times = options.snapshot_times;
    if (times.empty()) times.push_back(0.0);
    SnapshotSink snapshots(options.snapshot_dir, scenario->name, times, options.snapshot_scale);
    // Only what the snapshots need: cameras and ToF from the first requested time on, up to the
    // last one; the other sensors off.
    const double first = *std::min_element(times.begin(), times.end());
    const double last = *std::max_element(times.begin(), times.end());
    egse::Scenario snapshot_scenario = *scenario;
    for (auto& s : snapshot_scenario.sensors) {
      if (s.type == egse::SensorType::kCamera || s.type == egse::SensorType::kTof)
        s.phase = std::max(s.phase, first);
      else
        s.enabled = false;
    }
    auto short_sim =
        egse::Simulator::create(snapshot_scenario, seed, std::min((*sim)->duration(), last + 0.05));
    if (!short_sim) {
      fmt::print(stderr, "error: {}\n", short_sim.status().message());
      return 1;
    }
    const Status status = (*short_sim)->run(snapshots);
    if (!status) {
      fmt::print(stderr, "error: {}\n", status.message());
      return 1;
    }
    if (options.output.empty() && !options.digest) return 0;
  }
  if (options.digest) {
    // Runs without writing: the digest of every message compares runs across machines.
    egse::DigestSink digest;
    Progress progress(options.quiet);
    const auto start = std::chrono::steady_clock::now();
    const Status status = (*sim)->run(digest, [&](double t, double d) { progress(t, d); });
    if (!status) {
      fmt::print(stderr, "\nerror: {}\n", status.message());
      return 1;
    }
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    fmt::print("{} seed {} duration {} s: {} messages, digest {:016x} ({:.1f} s wall)\n",
               scenario->name, (*sim)->seed(), (*sim)->duration(), digest.messages(),
               digest.digest(), wall);
    return 0;
  }
  auto sink = egse::openMcapSink(options.output);
  if (!sink) {
    fmt::print(stderr, "error: {}\n", sink.status().message());
    return 1;
  }
  if (!options.quiet)
    fmt::print(stderr, "cdff sim: {} -> {} (seed {}, renderer {})\n", scenario->name,
               options.output, (*sim)->seed(), (*sim)->rendererDescription());
  Progress progress(options.quiet);
  const Status status = (*sim)->run(**sink, [&](double t, double d) { progress(t, d); });
  if (!status) {
    fmt::print(stderr, "\nerror: {}\n", status.message());
    return 1;
  }
  return 0;
}

}  // namespace

void addSimCommand(CLI::App& root, int& exit_code) {
  CLI::App* sim = root.add_subcommand(
      "sim", "Simulate a scenario of the trajectory library (EGSE) into an MCAP recording");
  auto options = std::make_shared<SimOptions>();
  sim->add_option("SCENARIO", options->scenario,
                  "A library scenario name (cdff sim --list) or a YAML file");
  sim->add_option("-o,--output", options->output, "The MCAP file to write");
  sim->add_option("--seed", options->seed,
                  "Random seed (default: the scenario's); the same seed gives the same file")
      ->each([options](const std::string&) { options->seed_given = true; });
  sim->add_option("--duration", options->duration, "Simulated seconds (default: the scenario's)")
      ->check(CLI::PositiveNumber);
  sim->add_option("--set", options->overrides,
                  "Override a scenario key: dotted.key=value (repeatable)");
  sim->add_option("--renderer", options->renderer, "Camera renderer (default: the scenario's, cpu)")
      ->check(CLI::IsMember({"cpu", "opengl", "auto"}));
  sim->add_flag("--list", options->list, "List the scenario library");
  sim->add_flag("--check", options->check,
                "Validate the scenario and build the simulator, print a summary");
  sim->add_option("--export-model", options->export_dir,
                  "Write the target model (OBJ, PLY, dense point cloud, ViSP .cao, edges) to DIR");
  sim->add_flag("--digest", options->digest,
                "Run without writing and print a digest of all messages (determinism checks)");
  sim->add_option("--snapshot", options->snapshot_dir,
                  "Write the camera and ToF images at --at times as PNG to DIR");
  sim->add_option("--at", options->snapshot_times, "Snapshot times (s), default 0");
  sim->add_option("--snapshot-scale", options->snapshot_scale, "Scale of the snapshot PNGs")
      ->check(CLI::Range(0.05, 1.0));
  sim->add_flag("-q,--quiet", options->quiet, "No progress bar");
  sim->callback([options, &exit_code] { exit_code = runSim(*options); });
}

}  // namespace cdff::app
