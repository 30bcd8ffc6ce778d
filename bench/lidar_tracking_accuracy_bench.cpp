// The LIDAR tracking DFPC's accuracy over the evaluation draws (data/evaluation/draws.yaml): each
// draw simulates the scenario with its own seed (scan noise, dropped scans) and starts the DFPC
// from its own Gaussian initial error of RMS 10 % of the range and 10 degrees. One benchmark per
// scenario runs every evaluation draw once. Environment: CDFF_DRAWS=N runs the first N;
// CDFF_DRAW_SET=tuning the first N tuning draws instead, the ones to tune on;
// CDFF_DRAW_NUMBERS=A,B,... only those of them, CDFF_FROM_DRAW=K those from K on
// (bench::drawsFromEnvironment); CDFF_VERBOSE=1 prints the track state changes and wrong locks,
// CDFF_VERBOSE=2 also every scan's registration and filter step and every pose's error;
// CDFF_SCENARIO_SET="KEY=VALUE;..." changes the scenario as `cdff sim --set` does (e.g.
// target.procedural.kind=hexagonal, the second target); CDFF_GRAPH_SET="NODE.PARAM=VALUE;..."
// changes the graph's parameters as `cdff run --set` does, CDFF_LIDAR_GRAPH=FILE runs an edited
// copy of the graph instead, CDFF_MODEL_FILE=FILE tracks with that model instead of the
// simulator's own mesh (`cdff model perturb`). It reports, besides the time per draw, the
// accuracy counters quoted in docs/lidar-tracking.md:
//   draws_within_goal  fraction of draws whose p95 errors and tracked fraction meet the goal
//   wrong_lock_draws   draws with a pose reported TRACKING > 10 deg or 5 % of the range off
//                      (the p95s cover every pose product after the first second, whatever its
//                      track state: what a user of the pose sees)
//   pos_p95_pct / pos_p95_m / angle_p95_deg   p95 over every draw's matched poses together
//   worst_pos_p95_* / worst_angle_p95_deg     the worst draw's p95
// BM_NoPrior_*: the same draws with no initial state at all, 4 s each: the fraction TRACKING
// within 2 s of the first scan (tracking_in_2s) and the draws with a pose reported TRACKING more
// than 5 % of the range or 5 degrees off (wrong_tracking_draws), for dfpcs/lidar_tracking.yaml
// and, on the mid-range approach, dfpcs/model_tracking_3d.yaml (issue 19's goal: >= 99 %, none).
// Each draw's figures are printed on stderr. The goals are the LIDAR tracking issue's
// (mid range: position p95 <= 0.5 % of the range, angle p95 <= 1 deg; close range: 10 mm,
// 0.5 deg; tumbling acquisition: twice the mid-range goals), with >= 99 % of scans tracked.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "bench_support.hpp"
#include "lidar_tracking_support.hpp"

namespace cdff {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct Goal {
  double position_pct = 1e9;  // p95, % of the range
  double position_m = 1e9;    // p95, m
  double angle_deg = 1e9;     // p95
  double tracked = 0.99;
};

struct Case {
  std::string scenario;
  double duration = 0;  // 0: the scenario's
  std::string extra_yaml;
  Goal goal;
};

// CDFF_VERBOSE=2: every scan's registration ("measured": its error against the truth and its
// reported sigma) and filter step, and every pose product's error against the truth with its
// track state, the filter's angular velocity (rad/s) and that velocity's error (deg/s).
void printTrace(const lidar_tracking::TrackingResult& r, const lidar_tracking::SimulatedRun& run,
                Timestamp t0) {
  std::map<Timestamp, std::string> rows;
  for (const dfpc::Message& m : r.products) {
    std::string& row = rows[m.stamp];
    if (m.channel == "/cdff/lidar_tracking/fitness")
      if (const double* v = m.as<double>()) row += fmt::format(" | scan fitness {:.2f}", *v);
    if (m.channel == "/cdff/lidar_tracking/visibility")
      if (const double* v = m.as<double>(); v && std::isfinite(*v))
        row += fmt::format(" visibility {:.2f}", *v);
    if (m.channel == "/cdff/lidar_tracking/acquisition_fitness")
      if (const double* v = m.as<double>(); v && std::isfinite(*v))
        row += fmt::format(" | acquisition fitness {:.2f}", *v);
    if (m.channel == "/cdff/lidar_tracking/acquisition_visibility")
      if (const double* v = m.as<double>(); v && std::isfinite(*v))
        row += fmt::format(" visibility {:.2f}", *v);
    if (m.channel == "/cdff/lidar_tracking/nis")
      if (const double* v = m.as<double>(); v && std::isfinite(*v))
        row += fmt::format(" NIS {:.1f}", *v);
    if (m.channel == "/cdff/lidar_tracking/accepted")
      if (const bool* v = m.as<bool>(); v && *v) row += " fused";
    if (m.channel == "/cdff/lidar_tracking/track_state")
      if (const TrackState* v = m.as<TrackState>()) row += fmt::format(" {}", toString(*v));
    if (m.channel == "/cdff/lidar_tracking/measurement")
      if (const PoseWithCovariance* v = m.as<PoseWithCovariance>())
        if (const std::optional<Transform> truth = eval::truthAt(run.truth, m.stamp, {})) {
          // The attitude error split about the line of sight and across it.
          const Eigen::AngleAxisd error(v->pose.rotation * truth->rotation.inverse());
          const Eigen::Vector3d rotation = error.axis() * error.angle();
          const Eigen::Vector3d line_of_sight = truth->translation.normalized();
          row += fmt::format(
              " | measured {:.2f} deg (about the line of sight {:.2f}, across {:.2f}) {:.3f} m "
              "off, sigma {:.2f} deg (about {:.2f}) {:.3f} m",
              error.angle() / kDeg, rotation.dot(line_of_sight) / kDeg,
              rotation.cross(line_of_sight).norm() / kDeg,
              (v->pose.translation - truth->translation).norm(),
              std::sqrt(v->covariance.bottomRightCorner<3, 3>().trace()) / kDeg,
              std::sqrt(
                  line_of_sight.dot(v->covariance.bottomRightCorner<3, 3>() * line_of_sight)) /
                  kDeg,
              std::sqrt(v->covariance.topLeftCorner<3, 3>().trace()));
        }
    if (m.channel == "/cdff/lidar_tracking/pose")
      if (const RigidBodyState* v = m.as<RigidBodyState>())
        if (const std::optional<Transform> truth = eval::truthAt(run.truth, m.stamp, {})) {
          row += fmt::format(
              " | pose {:.2f} deg {:.3f} m off, w ({:.3f} {:.3f} {:.3f})",
              Eigen::AngleAxisd(v->pose.rotation * truth->rotation.inverse()).angle() / kDeg,
              (v->pose.translation - truth->translation).norm(), v->twist.angular.x(),
              v->twist.angular.y(), v->twist.angular.z());
          // The true relative angular velocity (parent frame) by a central difference.
          constexpr Timestamp kHalfStep = 25'000;
          const std::optional<Transform> before = eval::truthAt(run.truth, m.stamp - kHalfStep, {});
          const std::optional<Transform> after = eval::truthAt(run.truth, m.stamp + kHalfStep, {});
          if (before && after) {
            const Eigen::AngleAxisd turn(after->rotation * before->rotation.inverse());
            const Eigen::Vector3d w_true = turn.axis() * turn.angle() / toSeconds(2 * kHalfStep);
            row += fmt::format(" err {:.2f} deg/s", (v->twist.angular - w_true).norm() / kDeg);
          }
        }
  }
  for (const auto& [stamp, row] : rows)
    if (!row.empty()) std::fprintf(stderr, "  %6.2f s%s\n", toSeconds(stamp - t0), row.c_str());
}

void runDraws(benchmark::State& state, const Case& c) {
  const eval::DrawSets& sets = lidar_tracking::drawSets();
  Result<std::vector<eval::Draw>> selected = bench::drawsFromEnvironment(sets, 50);
  if (!selected) return state.SkipWithError(selected.status().message().c_str());
  const std::vector<eval::Draw>& draws = *selected;
  const std::vector<std::string> scenario_settings =
      lidar_tracking::settingsFromEnvironment("CDFF_SCENARIO_SET");
  std::vector<double> pct, metres, angle;
  double within = 0, wrong = 0, worst_pct = 0, worst_m = 0, worst_deg = 0;
  for (auto _ : state) {
    for (const eval::Draw& draw : draws) {
      Result<lidar_tracking::DrawnRun> d = lidar_tracking::simulateDraw(
          draw, c.scenario, c.duration, 0.10, 10.0 * kDeg, c.extra_yaml, scenario_settings);
      if (!d) return state.SkipWithError(d.status().message().c_str());
      // CDFF_MODEL_FILE: the tracker's model instead of the simulator's own mesh (a model with
      // errors, `cdff model perturb`), as a user runs the graph with another model file.
      if (const char* model = std::getenv("CDFF_MODEL_FILE")) d->run.mesh_file = model;
      Result<lidar_tracking::TrackingResult> r =
          lidar_tracking::track(d->run, d->run.messages, d->initial, 1.0);
      if (!r) return state.SkipWithError(r.status().message().c_str());
      const eval::PoseEvaluation& e = r->evaluation;
      for (const eval::MatchedError& m : e.errors) {
        pct.push_back(100.0 * m.position_error_m / m.range_m);
        metres.push_back(m.position_error_m);
        angle.push_back(m.angle_error_deg);
      }
      // Wrong locks among the poses reported TRACKING, from the initial state on.
      Result<lidar_tracking::ReportedTracking> reported =
          lidar_tracking::reportedTracking(*r, d->run.truth);
      if (!reported) return state.SkipWithError(reported.status().message().c_str());
      const std::size_t wrong_locks = reported->wrong_locks;
      if (std::getenv("CDFF_VERBOSE")) {
        const Timestamp t0 = d->run.scans.front().stamp;
        for (const dfpc::Event& ev : r->events)
          if (ev.type == dfpc::EventType::kTrackStateChanged)
            std::fprintf(stderr, "  %.2f s: %s\n", toSeconds(ev.stamp - t0), ev.message.c_str());
        if (std::string(std::getenv("CDFF_VERBOSE")) == "2") printTrace(*r, d->run, t0);
        double last_wrong = -1;
        for (const eval::MatchedError& m : reported->errors)
          if (m.angle_error_deg > lidar_tracking::kWrongLockDeg ||
              100.0 * m.position_error_m / m.range_m > lidar_tracking::kWrongLockPct) {
            const double t = toSeconds(m.stamp - t0);
            if (t > last_wrong + 0.5)
              std::fprintf(stderr, "  %.2f s: wrong lock %.1f deg, %.2f %% of range\n", t,
                           m.angle_error_deg, 100.0 * m.position_error_m / m.range_m);
            last_wrong = t;
          }
      }
      const bool ok = e.position_error_pct_range.p95 <= c.goal.position_pct &&
                      e.position_error_m.p95 <= c.goal.position_m &&
                      e.angle_error_deg.p95 <= c.goal.angle_deg &&
                      r->tracked_fraction >= c.goal.tracked && wrong_locks == 0;
      within += ok;
      wrong += wrong_locks > 0;
      worst_pct = std::max(worst_pct, e.position_error_pct_range.p95);
      worst_m = std::max(worst_m, e.position_error_m.p95);
      worst_deg = std::max(worst_deg, e.angle_error_deg.p95);
      // The draw's initial error, to tell a hard draw from a regression.
      double error_pct = 0, error_deg = 0;
      if (const std::optional<Transform> t =
              eval::truthAt(d->run.truth, d->initial.pose.stamp, {})) {
        error_pct =
            100.0 * (d->initial.pose.translation - t->translation).norm() / t->translation.norm();
        error_deg =
            Eigen::AngleAxisd(d->initial.pose.rotation * t->rotation.inverse()).angle() / kDeg;
      }
      std::fprintf(stderr,
                   "%s draw %llu (initial error %.1f %% of range, %.1f deg): position p95 %.4f m "
                   "(%.3f %% of range), angle p95 %.3f deg, tracked %.1f %%, %zu wrong-lock "
                   "poses%s\n",
                   c.scenario.c_str(), static_cast<unsigned long long>(draw.number), error_pct,
                   error_deg, e.position_error_m.p95, e.position_error_pct_range.p95,
                   e.angle_error_deg.p95, 100.0 * r->tracked_fraction, wrong_locks,
                   ok ? "" : "  (goal missed)");
    }
  }
  const double count = static_cast<double>(draws.size());
  state.counters["draws"] = count;
  state.counters["draws_within_goal"] = within / count;
  state.counters["wrong_lock_draws"] = wrong;
  state.counters["pos_p95_pct"] = eval::ErrorStatistics::of(pct).p95;
  state.counters["pos_p95_m"] = eval::ErrorStatistics::of(metres).p95;
  state.counters["angle_p95_deg"] = eval::ErrorStatistics::of(angle).p95;
  state.counters["worst_pos_p95_pct"] = worst_pct;
  state.counters["worst_pos_p95_m"] = worst_m;
  state.counters["worst_angle_p95_deg"] = worst_deg;
}

const std::string kDroppedScans =
    "faults:\n  - {type: dropped_frames, sensor: lidar, start: 0, end: 1000, probability: 0.2}";

/// No initial state: TRACKING within 2 s and no TRACKING pose beyond 5 % / 5 degrees (issue 19).
void runNoPriorDraws(benchmark::State& state, const std::string& scenario,
                     const std::string& extra_yaml, const std::string& graph) {
  const eval::DrawSets& sets = lidar_tracking::drawSets();
  Result<std::vector<eval::Draw>> selected = bench::drawsFromEnvironment(sets, 50);
  if (!selected) return state.SkipWithError(selected.status().message().c_str());
  double in_time = 0, wrong = 0;
  for (auto _ : state) {
    for (const eval::Draw& draw : *selected) {
      Result<lidar_tracking::SimulatedRun> run =
          lidar_tracking::simulate(scenario, 4.0, extra_yaml, draw.simulator_seed);
      if (!run) return state.SkipWithError(run.status().message().c_str());
      Result<lidar_tracking::TrackingResult> r =
          lidar_tracking::trackWithoutPrior(*run, run->messages, 0, {}, graph);
      if (!r) return state.SkipWithError(r.status().message().c_str());
      double seconds = -1;
      for (const dfpc::Event& ev : r->events)
        if (ev.type == dfpc::EventType::kTrackStateChanged && ev.message.ends_with("-> TRACKING")) {
          seconds = toSeconds(ev.stamp - run->scans.front().stamp);
          break;
        }
      Result<lidar_tracking::ReportedTracking> reported =
          lidar_tracking::reportedTracking(*r, run->truth);
      if (!reported) return state.SkipWithError(reported.status().message().c_str());
      std::size_t off = 0;
      for (const eval::MatchedError& m : reported->errors)
        off += m.angle_error_deg > 5.0 || 100.0 * m.position_error_m / m.range_m > 5.0;
      in_time += seconds >= 0 && seconds <= 2.0;
      wrong += off > 0;
      std::fprintf(stderr,
                   "%s %s draw %llu: TRACKING after %.1f s, %zu of %zu TRACKING poses off\n",
                   graph.c_str(), scenario.c_str(), static_cast<unsigned long long>(draw.number),
                   seconds, off, reported->errors.size());
    }
  }
  state.counters["draws"] = static_cast<double>(selected->size());
  state.counters["tracking_in_2s"] = in_time / static_cast<double>(selected->size());
  state.counters["wrong_tracking_draws"] = wrong;
}

void BM_NoPrior_MidRange(benchmark::State& state) {
  runNoPriorDraws(state, "mid_range_approach", "", "lidar_tracking");
}
void BM_NoPrior_CloseRange(benchmark::State& state) {
  runNoPriorDraws(state, "close_range_approach", "", "lidar_tracking");
}
void BM_NoPrior_Tumbling(benchmark::State& state) {
  runNoPriorDraws(state, "tumbling_target", kDroppedScans, "lidar_tracking");
}
void BM_NoPrior_ModelTracking3d_MidRange(benchmark::State& state) {
  runNoPriorDraws(state, "mid_range_approach", "", "model_tracking_3d");
}

void BM_LidarAccuracy_MidRange(benchmark::State& state) {
  runDraws(state, {"mid_range_approach", 0, "", {0.5, 1e9, 1.0, 0.99}});
}
void BM_LidarAccuracy_CloseRange(benchmark::State& state) {
  runDraws(state, {"close_range_approach", 0, "", {1e9, 0.010, 0.5, 0.99}});
}
void BM_LidarAccuracy_TumblingAcquisition(benchmark::State& state) {
  runDraws(state, {"tumbling_target", 30, kDroppedScans, {2 * 0.5, 1e9, 2 * 1.0, 0.99}});
}
BENCHMARK(BM_LidarAccuracy_MidRange)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_LidarAccuracy_CloseRange)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_LidarAccuracy_TumblingAcquisition)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_NoPrior_MidRange)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_NoPrior_CloseRange)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_NoPrior_Tumbling)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_NoPrior_ModelTracking3d_MidRange)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace cdff

CDFF_BENCHMARK_MAIN();
