#include "lidar_tracking_support.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "cdff/dfpc/orchestrator.hpp"
#include "cdff/egse/model_io.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/egse/simulator.hpp"
#include "cdff/egse/sink.hpp"
#include "cdff/eval/initial_state.hpp"

namespace cdff::lidar_tracking {

Result<SimulatedRun> simulate(const std::string& name, double duration,
                              const std::string& extra_yaml, std::uint64_t seed,
                              const std::vector<std::string>& overrides) {
  Result<std::filesystem::path> file = egse::resolveScenario(name);
  if (!file) return file.status();
  std::ifstream in(*file);
  std::stringstream text;
  text << in.rdbuf() << "\n" << extra_yaml << "\n";
  std::vector<std::string> lidar_only = {"sensors.camera_left.enabled=false",
                                         "sensors.camera_right.enabled=false",
                                         "sensors.tof.enabled=false", "sensors.imu.enabled=false"};
  lidar_only.insert(lidar_only.end(), overrides.begin(), overrides.end());
  Result<egse::Scenario> scenario =
      egse::parseScenario(text.str(), file->string(), lidar_only, file->parent_path());
  if (!scenario) return scenario.status();
  Result<std::unique_ptr<egse::Simulator>> sim = egse::Simulator::create(
      *scenario, seed, duration > 0 ? std::optional(duration) : std::nullopt);
  if (!sim) return sim.status();
  egse::MemorySink sink;
  CDFF_RETURN_IF_ERROR((*sim)->run(sink));

  SimulatedRun run;
  run.mesh_file = std::filesystem::temp_directory_path() /
                  ("cdff_lidar_tracking_" + std::to_string(::getpid()) + "_" + name + ".ply");
  CDFF_RETURN_IF_ERROR(egse::writePly((*sim)->target(), run.mesh_file));
  for (const egse::SimMessage& m : sink.messages()) {
    if (const auto* cloud = std::get_if<PointCloud>(&m.payload);
        cloud && m.channel == "/chaser/lidar/points") {
      run.scans.push_back(*cloud);
      run.messages.push_back(dfpc::Message::of(m.channel, cloud->stamp, *cloud));
    } else if (const auto* depth = std::get_if<DepthMap>(&m.payload);
               depth && m.channel == "/chaser/tof/depth") {
      run.depth_stamps.push_back(depth->image.stamp);
      run.messages.push_back(dfpc::Message::of(m.channel, depth->image.stamp, *depth));
    } else if (const auto* info = std::get_if<LidarInfo>(&m.payload);
               info && m.channel == "/chaser/lidar/info") {
      run.messages.push_back(dfpc::Message::of(m.channel, info->stamp, *info));
    } else if (const auto* t = std::get_if<Transform>(&m.payload);
               t && m.channel.starts_with("/chaser/tf/")) {
      run.messages.push_back(dfpc::Message::of(m.channel, t->stamp, *t));
    } else if (const auto* a = std::get_if<PoseWithCovariance>(&m.payload);
               a && m.channel == "/chaser/ahrs/attitude") {
      run.messages.push_back(dfpc::Message::of(m.channel, a->pose.stamp, *a));
    } else if (const auto* s = std::get_if<PoseWithCovariance>(&m.payload);
               s && m.channel == "/truth/target_pose") {
      run.truth.push_back(s->pose);
      run.messages.push_back(dfpc::Message::of(m.channel, s->pose.stamp, *s));
    }
  }
  std::stable_sort(
      run.messages.begin(), run.messages.end(),
      [](const dfpc::Message& a, const dfpc::Message& b) { return a.stamp < b.stamp; });
  std::sort(run.truth.begin(), run.truth.end(),
            [](const Transform& a, const Transform& b) { return a.stamp < b.stamp; });
  return run;
}

RigidBodyState perturbedInitialState(const std::vector<Transform>& truth, Timestamp stamp,
                                     double position_fraction, double angle_rad,
                                     std::uint64_t seed) {
  eval::InitialStatePerturbation perturbation;
  perturbation.position_fraction = position_fraction;
  perturbation.angle_rad = angle_rad;
  perturbation.seed = seed;
  Result<RigidBodyState> state = eval::perturbedInitialState(truth, stamp, perturbation);
  return state ? std::move(state).value() : RigidBodyState{};
}

const eval::DrawSets& drawSets() {
  static const eval::DrawSets sets = [] {
    Result<eval::DrawSets> s =
        eval::loadDrawSets(std::string(CDFF_SOURCE_DIR) + "/data/evaluation/draws.yaml");
    if (!s) std::fprintf(stderr, "%s\n", s.status().message().c_str());
    return s ? std::move(s).value() : eval::DrawSets{};
  }();
  return sets;
}

Result<DrawnRun> simulateDraw(const eval::Draw& draw, const std::string& scenario, double duration,
                              double position_fraction, double angle_rad,
                              const std::string& extra_yaml,
                              const std::vector<std::string>& overrides) {
  Result<SimulatedRun> run =
      simulate(scenario, duration, extra_yaml, draw.simulator_seed, overrides);
  if (!run) return run.status();
  if (run->scans.empty()) return invalidInput("draw {}: the simulation has no scan", draw.number);
  eval::InitialStatePerturbation perturbation;
  perturbation.position_fraction = position_fraction;
  perturbation.angle_rad = angle_rad;
  perturbation.seed = draw.initial_error_seed;
  Result<RigidBodyState> initial =
      eval::perturbedInitialState(run->truth, run->scans.front().stamp, perturbation);
  if (!initial) return initial.status();
  return DrawnRun{draw, std::move(run).value(), std::move(initial).value()};
}

std::vector<std::string> settingsFromEnvironment(const char* name) {
  std::vector<std::string> settings;
  if (const char* env = std::getenv(name)) {
    std::stringstream list(env);
    for (std::string text; std::getline(list, text, ';');)
      if (!text.empty()) settings.push_back(text);
  }
  return settings;
}

Result<std::unique_ptr<dfpc::Dfpc>> loadGraph(const std::filesystem::path& mesh_file,
                                              const GraphEdit& edit, const std::string& graph) {
  // CDFF_GRAPH_SET: NODE.PARAM=VALUE settings (as `cdff run --set`), for the benchmark's runs on
  // the tuning draws.
  const std::vector<std::string> settings = settingsFromEnvironment("CDFF_GRAPH_SET");
  // CDFF_LIDAR_GRAPH: another graph file (an edited copy), for experiments on the tuning draws
  // with rules that settings cannot change (active_when, diverged_when, connections).
  const char* graph_file = std::getenv("CDFF_LIDAR_GRAPH");
  Result<dfpc::GraphSpec> spec =
      dfpc::loadGraphFile(graph_file ? std::string(graph_file)
                                     : std::string(CDFF_SOURCE_DIR) + "/dfpcs/" + graph + ".yaml",
                          settings);
  if (!spec) return spec.status().withContext("CDFF_GRAPH_SET");
  for (dfpc::InstanceSpec& instance : spec->instances)
    if (instance.name == "model") instance.parameters["mesh_file"] = mesh_file.string();
  if (edit) edit(*spec);
  return dfpc::Dfpc::create(*spec);
}

namespace {

/// The stamps of the run's sensor frames: its LIDAR scans, or its depth maps when it has none.
std::vector<Timestamp> frameStamps(const SimulatedRun& run) {
  std::vector<Timestamp> stamps;
  for (const PointCloud& scan : run.scans) stamps.push_back(scan.stamp);
  return stamps.empty() ? run.depth_stamps : stamps;
}

/// Runs the graph over `messages`, evaluating the pose products from `from` on.
Result<TrackingResult> runAndEvaluate(const SimulatedRun& run, std::vector<dfpc::Message> messages,
                                      Timestamp from, const GraphEdit& edit,
                                      const std::string& graph_name = "lidar_tracking") {
  Result<std::unique_ptr<dfpc::Dfpc>> graph = loadGraph(run.mesh_file, edit, graph_name);
  if (!graph) return graph.status();
  dfpc::MemorySink sink;
  dfpc::OrchestratorOptions options;
  options.sink = &sink;
  options.record_timing = false;
  dfpc::Orchestrator orchestrator(std::move(options));
  CDFF_RETURN_IF_ERROR(orchestrator.add(std::move(graph).value()));
  CDFF_RETURN_IF_ERROR(orchestrator.startAll());
  dfpc::MemoryStream stream(std::move(messages));
  Result<dfpc::RunSummary> summary = orchestrator.run(stream);
  if (!summary) return summary.status();

  TrackingResult result;
  result.graph = graph_name;
  const std::string products = "/cdff/" + graph_name + "/";
  result.events = sink.events();
  result.products = sink.messages();
  std::vector<eval::EstimateSample> estimates;
  for (const dfpc::Message& m : sink.messages(products + "pose"))
    if (const RigidBodyState* s = m.as<RigidBodyState>(); s && m.stamp >= from)
      estimates.push_back({s->pose, true, std::nullopt, s->covariance.topLeftCorner<6, 6>()});
  const std::vector<Timestamp> frames = frameStamps(run);
  for (const Timestamp stamp : frames)
    if (stamp >= from) ++result.scans;
  // Scans whose registration passed the DFPC's checks and that the EKF fused (a prediction tick
  // reports false; a gated-out measurement too; an AHRS sample, at its own stamp, is not a scan).
  std::set<Timestamp> scan_stamps(frames.begin(), frames.end());
  for (const dfpc::Message& m : sink.messages(products + "accepted"))
    if (const bool* fused = m.as<bool>();
        fused && *fused && m.stamp >= from && scan_stamps.erase(m.stamp))
      ++result.accepted;
  result.tracked_fraction =
      result.scans ? static_cast<double>(result.accepted) / static_cast<double>(result.scans) : 0;
  Result<eval::PoseEvaluation> evaluation = eval::evaluatePoses(estimates, run.truth);
  if (!evaluation) return evaluation.status();
  result.evaluation = std::move(evaluation).value();
  return result;
}

}  // namespace

Result<TrackingResult> track(const SimulatedRun& run, std::vector<dfpc::Message> messages,
                             const RigidBodyState& initial, double settle_s,
                             const GraphEdit& edit) {
  // The initial state comes just before the scan it was made for (and the LIDAR description
  // that comes with the scan).
  auto at = std::find_if(messages.begin(), messages.end(), [&](const dfpc::Message& m) {
    return m.stamp >= initial.pose.stamp &&
           (m.channel == "/chaser/lidar/points" || m.channel == "/chaser/lidar/info");
  });
  messages.insert(
      at, dfpc::Message::of("/cdff/lidar_tracking/initial_state", initial.pose.stamp, initial));
  return runAndEvaluate(run, std::move(messages), initial.pose.stamp + fromSeconds(settle_s), edit);
}

Result<TrackingResult> trackWithoutPrior(const SimulatedRun& run,
                                         std::vector<dfpc::Message> messages, double settle_s,
                                         const GraphEdit& edit, const std::string& graph) {
  const std::vector<Timestamp> frames = frameStamps(run);
  if (frames.empty()) return invalidInput("the simulated run has no scan and no depth map");
  return runAndEvaluate(run, std::move(messages), frames.front() + fromSeconds(settle_s), edit,
                        graph);
}

std::vector<std::pair<Transform, std::string>> posesWithTrackState(const TrackingResult& r) {
  std::vector<Transform> poses;
  std::vector<std::string> states;
  for (const dfpc::Message& m : r.products) {
    if (m.channel == "/cdff/" + r.graph + "/pose")
      if (const RigidBodyState* s = m.as<RigidBodyState>()) poses.push_back(s->pose);
    if (m.channel == "/cdff/" + r.graph + "/track_state")
      if (const TrackState* s = m.as<TrackState>()) states.push_back(std::string(toString(*s)));
  }
  std::vector<std::pair<Transform, std::string>> out;
  for (std::size_t i = 0; i < std::min(poses.size(), states.size()); ++i)
    out.emplace_back(poses[i], states[i]);
  return out;
}

Result<ReportedTracking> reportedTracking(const TrackingResult& r,
                                          const std::vector<Transform>& truth) {
  std::vector<eval::EstimateSample> tracking;
  for (const auto& [pose, state] : posesWithTrackState(r))
    if (state == "TRACKING") tracking.push_back({pose, true, {}, {}});
  ReportedTracking out;
  if (tracking.empty()) return out;
  Result<eval::PoseEvaluation> e = eval::evaluatePoses(tracking, truth);
  if (!e) return e.status().withContext("the poses reported TRACKING");
  out.errors = std::move(e->errors);
  for (const eval::MatchedError& m : out.errors) {
    const double pct = 100.0 * m.position_error_m / m.range_m;
    out.worst_deg = std::max(out.worst_deg, m.angle_error_deg);
    out.worst_pct = std::max(out.worst_pct, pct);
    out.wrong_locks += m.angle_error_deg > kWrongLockDeg || pct > kWrongLockPct;
  }
  return out;
}

}  // namespace cdff::lidar_tracking
