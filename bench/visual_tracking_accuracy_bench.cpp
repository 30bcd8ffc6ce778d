// The visual tracking DFPC's acquisition over the evaluation draws (data/evaluation/draws.yaml):
// each draw simulates the scenario with its own seed (image noise, lighting jitter) and starts the
// DFPC from its own Gaussian initial error of RMS 5 % of the range and 5 degrees with an unknown
// twist (sigmas 0.3 m/s and 0.1 rad/s), stamped at the first image, which is not tracked (as
// `cdff initial-state` and `cdff run` do it). The camera runs at 2 Hz. One benchmark per scenario
// runs every evaluation draw once (CDFF_DRAWS=N runs the first N; CDFF_DRAW_SET=tuning the first
// N tuning draws instead, 10 by default, for choosing rules) over its first CDFF_DURATION seconds
// (10 by default) and reports, besides the time per draw, the counters quoted in
// docs/visual-tracking.md:
//   first_confirmed   fraction of draws whose first acquisition was confirmed by the next frame
//   tracked_2s        fraction of draws tracked (a valid frame, right or wrong: see wrong_frames)
//                     within 2 s of the first frame
//   tracked           fraction of draws tracked at all
//   worst_time_to_track_s  the slowest draw's time from the first frame to its first valid one
//                     (1e9 when a draw never has one)
//   wrong_frames      valid frames (TRACKING or DEGRADED) off by > 5 % of the range or 10 deg
//   lost_after_track  LOST or ACQUIRING frames after a draw's first valid one, all draws
//   pos_p95_pct / pos_p95_mm / angle_p95_deg   p95 over every draw's valid frames together
//   slowest_frame_cpu_ms  the DFPC's largest CPU time on one frame, all draws (an acquisition
//                     frame with restarts; the tracker's budget is 40 ms of wall time)
//   valid             fraction of the frames that are valid, all draws
//   nees_mean         mean 6-dof NEES of the filtered pose over every draw's valid frames (6 when
//                     the covariance is honest)
// The same over the whole approach (CDFF_DURATION shortens it) with a tracker's model or
// calibrations that are not the simulator's own (visual_demo::ModelVariant: the second target,
// model errors, calibration errors; issue 16): runDraws/SecondTarget_*, runDraws/ModelErrors_*,
// runDraws/CalibrationErrors_*; with the stereo graph BM_Acquisition_*_Stereo and
// runDraws/Stereo_*. Their goals are those of the first target's accuracy tests (close range
// p95 10 mm and 0.5 deg, mid range 1 % of the range and 1 deg), twice those with model or
// calibration errors; the errors are stated to the graph (visual_demo::statedErrors), so
// nees_mean is that of a user who states them.
// Each draw's figures are printed on stderr; CDFF_VERBOSE=1 adds each frame (status, validity,
// error) and the tracker's reasons, CDFF_FROM_DRAW=N skips the draws numbered below N,
// CDFF_DRAW_NUMBERS=A,B,... keeps only those (of the set's first CDFF_DRAWS). The goal
// (issue 16): acquisition succeeds in >= 98 % of draws and a failed one recovers within 2 s, with
// no wrong acquisition reported as a track.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>

#include <unistd.h>

#include "bench_support.hpp"
#include "simulated_approach.hpp"

namespace cdff {
namespace {

constexpr double kDeg = M_PI / 180.0;

double p95(std::vector<double> v) {
  return v.empty() ? 0.0 : eval::ErrorStatistics::of(v).p95;
}

double mean(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

// `variant`: none, the first target with its own model and calibrations over the first 10 s (the
// acquisition); else that variant over the whole approach. `stereo`: the stereo graph on the
// left/right pairs.
void runDraws(benchmark::State& state, const std::string& scenario,
              std::optional<visual_demo::ModelVariant> variant = std::nullopt,
              bool stereo = false) {
  Result<eval::DrawSets> sets = visual_demo::drawSets();
  if (!sets) return state.SkipWithError(sets.status().message().c_str());
  Result<std::vector<eval::Draw>> selected = bench::drawsFromEnvironment(*sets, 10);
  if (!selected) return state.SkipWithError(selected.status().message().c_str());
  const std::vector<eval::Draw>& draws = *selected;
  const char* d = std::getenv("CDFF_DURATION");
  std::optional<double> duration;
  if (d)
    duration = std::strtod(d, nullptr);
  else if (!variant)
    duration = 10.0;
  const std::filesystem::path scratch =
      std::filesystem::temp_directory_path() /
      ("cdff_visual_accuracy_bench_" + std::to_string(::getpid()));
  std::filesystem::create_directories(scratch);
  std::vector<double> pct, mm, deg, nees;
  double first = 0, within = 0, tracked = 0, worst_time = 0, wrong = 0, lost = 0;
  double slowest_frame = 0, valid = 0, frames = 0;
  for (auto _ : state) {
    for (const eval::Draw& draw : draws) {
      Result<visual_demo::ApproachOptions> o =
          visual_demo::drawOptions(draw, scenario, duration, 0.05, 5 * kDeg, 0.3, 0.1);
      o->stereo = stereo;
      if (variant) o = visual_demo::withVariant(std::move(o).value(), *variant, scratch);
      if (!o) return state.SkipWithError(o.status().message().c_str());
      // The variant's errors stated to the graph, as a user states them (its `consider` node).
      if (variant) o->graph_settings = visual_demo::statedErrors(*variant);
      Result<visual_demo::ApproachResult> r = visual_demo::runApproach(*o);
      if (!r) return state.SkipWithError(r.status().message().c_str());
      const visual_demo::AcquisitionOutcome a = visual_demo::acquisitionOutcome(*r);
      if (std::getenv("CDFF_VERBOSE")) {
        for (std::size_t i = 0; i < r->frames; ++i)
          std::fprintf(stderr, "  %.1f s status %d valid %d: %.1f mm %.2f deg\n", r->stamps_s[i],
                       r->status[i], static_cast<int>(r->valid[i]), 1e3 * r->position_error_m[i],
                       r->angle_error_deg[i]);
        for (const std::string& w : r->warnings) std::fprintf(stderr, "  %s\n", w.c_str());
      }
      first += a.first_acquisition_confirmed;
      within += a.tracked && a.time_to_track_s <= 2.0;
      tracked += a.tracked;
      worst_time = std::max(worst_time, a.tracked ? a.time_to_track_s : 1e9);
      wrong += static_cast<double>(a.wrong_frames);
      lost += static_cast<double>(a.lost_after_track);
      pct.insert(pct.end(), a.position_error_pct.begin(), a.position_error_pct.end());
      for (double m : a.position_error_m) mm.push_back(1e3 * m);
      deg.insert(deg.end(), a.angle_error_deg.begin(), a.angle_error_deg.end());
      nees.insert(nees.end(), a.nees.begin(), a.nees.end());
      valid += static_cast<double>(a.valid_frames);
      frames += static_cast<double>(a.frames);
      std::fprintf(stderr,
                   "%s%s%s%s draw %llu: %zu frames, %zu valid, time to track %.1f s%s, %zu wrong, "
                   "%zu lost after, p95 %.3f %% / %.2f mm / %.3f deg, NEES mean %.2f, slowest "
                   "frame %.1f ms CPU\n",
                   stereo ? "stereo " : "", variant ? visual_demo::toString(*variant) : "",
                   variant ? " " : "", scenario.c_str(),
                   static_cast<unsigned long long>(draw.number), a.frames, a.valid_frames,
                   a.time_to_track_s, a.first_acquisition_confirmed ? " (first acquisition)" : "",
                   a.wrong_frames, a.lost_after_track, p95(a.position_error_pct),
                   1e3 * p95(a.position_error_m), p95(a.angle_error_deg), mean(a.nees),
                   1e3 * r->cpu_per_frame_s.max);
      slowest_frame = std::max(slowest_frame, r->cpu_per_frame_s.max);
    }
  }
  const double runs = static_cast<double>(draws.size() * state.iterations());
  state.counters["draws"] = static_cast<double>(draws.size());
  state.counters["first_confirmed"] = first / runs;
  state.counters["tracked_2s"] = within / runs;
  state.counters["tracked"] = tracked / runs;
  state.counters["worst_time_to_track_s"] = worst_time;
  state.counters["wrong_frames"] = wrong;
  state.counters["lost_after_track"] = lost;
  state.counters["pos_p95_pct"] = p95(pct);
  state.counters["pos_p95_mm"] = p95(mm);
  state.counters["angle_p95_deg"] = p95(deg);
  state.counters["slowest_frame_cpu_ms"] = 1e3 * slowest_frame;
  state.counters["valid"] = frames > 0 ? valid / frames : 0.0;
  state.counters["nees_mean"] = mean(nees);
  std::error_code ignored;
  std::filesystem::remove_all(scratch, ignored);
}

void BM_Acquisition_CloseRange(benchmark::State& state) {
  runDraws(state, "close_range_approach");
}
void BM_Acquisition_MidRange(benchmark::State& state) {
  runDraws(state, "mid_range_approach");
}

void BM_Acquisition_CloseRange_Stereo(benchmark::State& state) {
  runDraws(state, "close_range_approach", std::nullopt, true);
}
void BM_Acquisition_MidRange_Stereo(benchmark::State& state) {
  runDraws(state, "mid_range_approach", std::nullopt, true);
}

BENCHMARK(BM_Acquisition_CloseRange)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_Acquisition_MidRange)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_Acquisition_CloseRange_Stereo)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_Acquisition_MidRange_Stereo)->Iterations(1)->Unit(benchmark::kSecond);

// The tracker's model or the calibrations differ from the simulated target's
// (docs/visual-tracking.md, "Another target, model errors and calibration errors").
using visual_demo::ModelVariant;
#define CDFF_VARIANT_BENCHMARK(name, scenario, variant)                           \
  BENCHMARK_CAPTURE(runDraws, name, std::string(scenario), ModelVariant::variant) \
      ->Iterations(1)                                                             \
      ->Unit(benchmark::kSecond)
CDFF_VARIANT_BENCHMARK(SecondTarget_CloseRange, "close_range_approach", kSecondTarget);
CDFF_VARIANT_BENCHMARK(SecondTarget_MidRange, "mid_range_approach", kSecondTarget);
CDFF_VARIANT_BENCHMARK(ModelErrors_CloseRange, "close_range_approach", kModelErrors);
CDFF_VARIANT_BENCHMARK(ModelErrors_MidRange, "mid_range_approach", kModelErrors);
CDFF_VARIANT_BENCHMARK(CalibrationErrors_CloseRange, "close_range_approach", kCalibrationErrors);
CDFF_VARIANT_BENCHMARK(CalibrationErrors_MidRange, "mid_range_approach", kCalibrationErrors);
// The stereo graph with another target or model errors (the calibration-error variant perturbs
// the left camera's published calibration only, not the pair's).
#define CDFF_STEREO_VARIANT_BENCHMARK(name, scenario, variant)                          \
  BENCHMARK_CAPTURE(runDraws, name, std::string(scenario), ModelVariant::variant, true) \
      ->Iterations(1)                                                                   \
      ->Unit(benchmark::kSecond)
CDFF_STEREO_VARIANT_BENCHMARK(Stereo_SecondTarget_CloseRange, "close_range_approach",
                              kSecondTarget);
CDFF_STEREO_VARIANT_BENCHMARK(Stereo_SecondTarget_MidRange, "mid_range_approach", kSecondTarget);
CDFF_STEREO_VARIANT_BENCHMARK(Stereo_ModelErrors_CloseRange, "close_range_approach", kModelErrors);
CDFF_STEREO_VARIANT_BENCHMARK(Stereo_ModelErrors_MidRange, "mid_range_approach", kModelErrors);

}  // namespace
}  // namespace cdff

BENCHMARK_MAIN();
