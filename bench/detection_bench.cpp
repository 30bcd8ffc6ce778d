// The detection DFPC (dfpcs/detection.yaml) on simulated stereo frames, through the Orchestrator
// (examples/detection/simulated_views.hpp): each frame a library scenario's lighting and
// background, the target at an attitude uniform on SO(3), a range uniform in 2-17 m and a pointing
// that keeps at least 80 % of it in view; frame k has the seed 900001 + k (the evaluation seeds,
// beyond the tuning draws 1-10000; CDFF_DRAW_SET=tuning: 1 + k). With CDFF_DETECTION_SOURCE=tof,
// the ToF graph (dfpcs/detection_tof.yaml) on the ToF camera's depth maps of the same draws, at
// ranges 2 m to the ToF camera's maximum range.
//
//   Accuracy     detected, right (within 1 % of the range and 2 degrees) and wrong (detected, not
//                right) fractions, by range band; the SPEED score (mean over the detected frames
//                of position error / range + angle error in rad); the NEES of the right ones;
//                the CPU per frame of each node (one thread).
//   NoTarget     the cameras turned away from the target (stars, the Earth, empty space): the
//                fraction of frames with a detection.
//
// Environment: CDFF_DRAW_SET=tuning (seeds 1 on, to tune on), CDFF_DETECTION_SOURCE (stereo or
// tof), CDFF_DETECTION_TEMPLATES (default build/templates/target_stereo.yml.gz, or
// target_tof.yml.gz, written by `make templates`), CDFF_FRAMES (300; NoTarget: a
// third), CDFF_DETECTION_SET ("NODE.PARAM=VALUE" settings of the graph, ';'-separated),
// CDFF_VIEW_SET (scenario overrides of every frame,
// ';'-separated, e.g. target.procedural.kind=hexagonal with the hexagonal target's templates and
// detect.model_file/model.mesh_file), CDFF_MIN_RANGE, CDFF_MAX_RANGE (m, instead of 2 and 17),
// CDFF_VERBOSE=1 (one line per frame).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>

#include "bench_support.hpp"
#include "cdff/egse/range_sensors.hpp"
#include "simulated_views.hpp"

#ifndef CDFF_SOURCE_DIR
#define CDFF_SOURCE_DIR "."
#endif

namespace cdff::detection_demo {
namespace {

constexpr double kDeg = M_PI / 180.0;
using bench::firstSeed;
using bench::splitEnvironment;

DepthSource depthSource() {
  const char* source = std::getenv("CDFF_DETECTION_SOURCE");
  return source && std::string(source) == "tof" ? DepthSource::kTof : DepthSource::kStereo;
}

std::vector<std::string> graphSettings() {
  const char* templates = std::getenv("CDFF_DETECTION_TEMPLATES");
  const char* file = depthSource() == DepthSource::kTof ? "/build/templates/target_tof.yml.gz"
                                                        : "/build/templates/target_stereo.yml.gz";
  std::vector<std::string> s = {
      "detect.template_file=" +
      (templates ? std::string(templates) : std::string(CDFF_SOURCE_DIR) + file)};
  for (const std::string& extra : splitEnvironment("CDFF_DETECTION_SET")) s.push_back(extra);
  return s;
}

std::size_t frameCount(std::size_t fallback) {
  const char* n = std::getenv("CDFF_FRAMES");
  return n ? std::strtoull(n, nullptr, 10) : fallback;
}

bool verbose() {
  return std::getenv("CDFF_VERBOSE") != nullptr;
}

/// The frames' options: the depth source, and for the ToF camera ranges up to its maximum range
/// (nothing farther is measured).
ViewOptions viewOptions() {
  ViewOptions options;
  options.source = depthSource();
  if (options.source == DepthSource::kTof) options.max_range = egse::TofSpec::defaults().max_range;
  options.overrides = splitEnvironment("CDFF_VIEW_SET");
  if (const char* r = std::getenv("CDFF_MIN_RANGE")) options.min_range = std::atof(r);
  if (const char* r = std::getenv("CDFF_MAX_RANGE")) options.max_range = std::atof(r);
  return options;
}

Result<std::unique_ptr<Detector>> makeDetector() {
  return Detector::create(graphSettings(), "", depthSource());
}

void Accuracy(benchmark::State& state) {
  Result<std::unique_ptr<Detector>> detector = makeDetector();
  if (!detector) {
    state.SkipWithError(detector.status().message().c_str());
    return;
  }
  const ViewOptions options = viewOptions();
  const std::size_t frames = frameCount(300);
  struct Band {
    double upto;
    std::size_t frames = 0, right = 0;
  };
  std::vector<Band> bands = {{6.0}, {10.0}, {1e9}};
  std::size_t detected = 0, right = 0, wrong = 0, errors = 0;
  double score = 0, nees = 0, cpu = 0;
  std::map<std::string, double> node_cpu;
  for (auto _ : state) {
    for (std::size_t k = 0; k < frames; ++k) {
      Result<SimulatedView> view = simulateView(options, firstSeed() + k);
      if (!view) {
        state.SkipWithError(view.status().message().c_str());
        return;
      }
      Result<DetectionOutcome> r = (*detector)->run(*view);
      if (!r) {
        state.SkipWithError(r.status().message().c_str());
        return;
      }
      Band& band = *std::find_if(bands.begin(), bands.end(),
                                 [&](const Band& b) { return view->range < b.upto; });
      ++band.frames;
      errors += r->dfn_errors;
      cpu += r->cpu_s;
      for (const auto& [node, s] : r->node_cpu_s) node_cpu[node] += s;
      const bool ok =
          r->detected && r->position_error <= 0.01 * view->range && r->angle_error <= 2 * kDeg;
      if (r->detected) {
        ++detected;
        score += r->position_error / view->range + r->angle_error;
        if (ok) {
          ++right;
          ++band.right;
          nees += r->nees;
        } else {
          ++wrong;
        }
      }
      if (verbose())
        std::printf(
            "frame %llu (%s, %.2f m): detected %d, error %.3f m (%.2f %%) %.2f deg, NEES %.1f, "
            "fitness %.2f, confirmed %.2f, misfit %.2f, rival margin %.2f, inliers %.2f of %d, "
            "%.0f "
            "ms\n",
            static_cast<unsigned long long>(firstSeed() + k), view->lighting.c_str(), view->range,
            r->detected, r->position_error, 100 * r->position_error / view->range,
            r->angle_error / kDeg, r->nees, r->fitness, r->confirmed, r->misfit, r->rival_margin,
            r->inlier_ratio, r->alternatives, r->cpu_s * 1e3);
      if (verbose() && !r->fault.empty()) std::printf("  fault: %s\n", r->fault.c_str());
    }
  }
  const double n = static_cast<double>(frames);
  state.counters["frames"] = n;
  state.counters["detected_pct"] = 100.0 * detected / n;
  state.counters["right_pct"] = 100.0 * right / n;
  state.counters["wrong_pct"] = 100.0 * wrong / n;
  for (std::size_t b = 0; b < bands.size(); ++b)
    state.counters[b == 0   ? "right_pct_2_6m"
                   : b == 1 ? "right_pct_6_10m"
                            : "right_pct_10_17m"] =
        bands[b].frames ? 100.0 * bands[b].right / bands[b].frames : NAN;
  state.counters["speed_score"] = detected ? score / detected : NAN;
  state.counters["nees_right"] = right ? nees / right : NAN;
  state.counters["dfn_errors"] = static_cast<double>(errors);
  state.counters["cpu_ms"] = 1e3 * cpu / n;
  for (const auto& [node, s] : node_cpu) state.counters["cpu_ms_" + node] = 1e3 * s / n;
}
BENCHMARK(Accuracy)->Iterations(1)->Unit(benchmark::kMillisecond);

void NoTarget(benchmark::State& state) {
  Result<std::unique_ptr<Detector>> detector = makeDetector();
  if (!detector) {
    state.SkipWithError(detector.status().message().c_str());
    return;
  }
  const ViewOptions options = viewOptions();
  const std::size_t frames = std::max<std::size_t>(frameCount(300) / 3, 1);
  std::size_t detected = 0;
  double cpu = 0;
  for (auto _ : state) {
    for (std::size_t k = 0; k < frames; ++k) {
      Result<SimulatedView> view = simulateView(options, firstSeed() + k, false);
      if (!view) {
        state.SkipWithError(view.status().message().c_str());
        return;
      }
      Result<DetectionOutcome> r = (*detector)->run(*view);
      if (!r) {
        state.SkipWithError(r.status().message().c_str());
        return;
      }
      detected += r->detected ? 1 : 0;
      cpu += r->cpu_s;
      if (verbose() && r->detected)
        std::printf("frame %llu (%s): a detection without the target\n",
                    static_cast<unsigned long long>(firstSeed() + k), view->lighting.c_str());
    }
  }
  state.counters["frames"] = static_cast<double>(frames);
  state.counters["false_pct"] = 100.0 * detected / frames;
  state.counters["cpu_ms"] = 1e3 * cpu / frames;
}
BENCHMARK(NoTarget)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace cdff::detection_demo

CDFF_BENCHMARK_MAIN();
