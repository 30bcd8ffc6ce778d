// One run of a campaign (run.hpp).

#include "cdff/campaign/run.hpp"

#include <chrono>
#include <fstream>

#include <fmt/format.h>

#include "cdff/dfpc/recording_streams.hpp"
#include "cdff/dfpc/replay.hpp"
#include "cdff/egse/mcap_sink.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/egse/simulator.hpp"
#include "cdff/eval/draws.hpp"
#include "cdff/eval/initial_state.hpp"
#include "cdff/eval/recording_evaluation.hpp"
#include "cdff/eval/report.hpp"
#include "cdff/io/replay.hpp"

namespace cdff::campaign {
namespace {

namespace fs = std::filesystem;

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Status simulate(const RunPlan& plan, const fs::path& output) {
  Result<fs::path> path = egse::resolveScenario(plan.scenario->name);
  if (!path) return path.status();
  Result<egse::Scenario> scenario = egse::loadScenario(*path, plan.overrides);
  if (!scenario) return scenario.status();
  auto sim = egse::Simulator::create(*scenario, plan.draw, plan.scenario->duration);
  if (!sim) return sim.status();
  auto sink = egse::openMcapSink(output.string());
  if (!sink) return sink.status();
  return (*sim)->run(**sink);
}

/// The initial states the DFPCs that need one start from (one file each), drawn from the run's
/// initial-error stream (eval::drawOf), as `cdff initial-state` would.
Result<std::vector<std::string>> initialStates(const Campaign& campaign, const RunPlan& plan,
                                               const fs::path& sim, const fs::path& dir) {
  std::vector<std::string> files;
  for (std::size_t k = 0; k < campaign.dfpcs.size(); ++k) {
    const std::optional<InitialStateEntry>& i = campaign.dfpcs[k].initial_state;
    if (!i) continue;
    eval::InitialStateFromRecording from;
    from.channel = i->channel;
    from.at_channel = i->at;
    from.truth_channel = i->truth;
    from.perturbation.position_fraction = i->position_fraction;
    from.perturbation.angle_rad = i->angle_deg * M_PI / 180.0;
    from.perturbation.linear_velocity_sigma = i->velocity_sigma;
    from.perturbation.angular_velocity_sigma = i->angular_velocity_sigma_deg * M_PI / 180.0;
    from.perturbation.distribution = i->fixed_size ? eval::InitialErrorDistribution::kFixedSize
                                                   : eval::InitialErrorDistribution::kGaussian;
    from.perturbation.seed = eval::drawOf(plan.draw).initial_error_seed;
    const fs::path file = dir / fmt::format("init{}.mcap", k);
    Result<eval::WrittenInitialState> written =
        eval::writeInitialState(sim.string(), file.string(), from);
    if (!written) return written.status();
    files.push_back(file.string());
  }
  return files;
}

/// Each word parsed as `cdff run` parses its option, appended to `out`.
template <typename Parse, typename T>
Status parsedInto(const std::vector<std::string>& words, Parse parse, std::vector<T>& out) {
  for (const std::string& word : words) {
    Result<T> parsed = parse(word);
    if (!parsed) return parsed.status();
    out.push_back(std::move(*parsed));
  }
  return Status::ok();
}

/// Runs the campaign's DFPCs over the run's inputs, as `cdff run` would with the entries' options.
Result<dfpc::ReplayResult> process(const Campaign& campaign, const std::vector<std::string>& inputs,
                                   const fs::path& output) {
  dfpc::ReplayOptions options;
  for (const DfpcEntry& e : campaign.dfpcs) {
    options.graph_files.push_back(e.graph);
    options.parameter_settings.insert(options.parameter_settings.end(), e.settings.begin(),
                                      e.settings.end());
    CDFF_RETURN_IF_ERROR(parsedInto(e.maps, dfpc::parseRemap, options.remaps));
    CDFF_RETURN_IF_ERROR(parsedInto(e.pairs, dfpc::parseStereoPairing, options.stereo_pairs));
    CDFF_RETURN_IF_ERROR(parsedInto(e.run_while, dfpc::parseActivationRule, options.run_while));
  }
  return dfpc::replayFiles(inputs, output.string(), options);
}

/// What each DFPC reported at the end of the run: its faults and recoveries (an injected sensor
/// fault shows there), its products and its last track state.
nlohmann::json dfpcOutcomes(const dfpc::ReplayResult& result) {
  nlohmann::json out = nlohmann::json::array();
  for (const dfpc::DfpcStatus& d : result.dfpcs) {
    nlohmann::json j = {{"name", d.name},
                        {"products", d.products},
                        {"faults", d.faults},
                        {"recoveries", d.recoveries}};
    if (d.track_state) j["track_state"] = std::string(toString(*d.track_state));
    if (!d.last_fault.empty()) j["last_fault"] = d.last_fault;
    out.push_back(std::move(j));
  }
  return out;
}

/// Whether some evaluated product holds a valid estimate: a tracker that never acquired, or that
/// faulted on every frame, publishes only invalid ones, and the requirements then do not apply
/// to it; such a run is counted as one without a pose.
bool hasValidEstimate(const eval::EvaluationReport& report) {
  for (const eval::PoseEvaluation& p : report.products)
    if (p.valid_frames > 0) return true;
  return false;
}

/// Whether the DFPCs' output holds a pose product (what evaluation measures): a DFPC that never
/// produced one (a tracker that never acquired) leaves none.
Result<bool> hasPoseProduct(const fs::path& output) {
  io::Replay replay;
  CDFF_RETURN_IF_ERROR(replay.open({output.string()}));
  for (const io::ReplayChannel& c : replay.channels()) {
    const bool pose = c.type == TypeId::of<PoseWithCovariance>() ||
                      c.type == TypeId::of<RigidBodyState>() || c.type == TypeId::of<Transform>();
    if (pose && c.topic.rfind("/cdff/", 0) == 0 && c.message_count > 0) return true;
  }
  return false;
}

}  // namespace

fs::path runDirectory(const fs::path& results, std::uint64_t index) {
  return results / "runs" / fmt::format("{:06d}", index);
}

fs::path resultFile(const fs::path& results, std::uint64_t index) {
  return runDirectory(results, index) / "result.json";
}

Status writeResult(const fs::path& results, std::uint64_t index, const nlohmann::json& result) {
  const fs::path file = resultFile(results, index);
  std::error_code ec;
  fs::create_directories(file.parent_path(), ec);
  if (ec) return ioError("cannot create '{}': {}", file.parent_path().string(), ec.message());
  const fs::path partial = file.string() + ".partial";
  {
    std::ofstream out(partial);
    out << result.dump(1) << "\n";
    if (!out) return ioError("cannot write '{}'", partial.string());
  }
  fs::rename(partial, file, ec);
  if (ec)
    return ioError("cannot rename '{}' to '{}': {}", partial.string(), file.string(), ec.message());
  return Status::ok();
}

Result<nlohmann::json> executeRun(const Campaign& campaign, std::uint64_t index,
                                  const fs::path& results) {
  const RunPlan plan = planRun(campaign, index);
  const fs::path dir = runDirectory(results, index);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return ioError("cannot create '{}': {}", dir.string(), ec.message());
  nlohmann::json r = {{"index", index},
                      {"draw", plan.draw},
                      {"scenario", plan.scenario->name},
                      {"label", plan.scenario->label},
                      {"dispersed", nlohmann::json::object()},
                      {"reproduce", reproduceCommand(campaign, plan)}};
  for (const auto& [key, value] : plan.dispersed) r["dispersed"][key] = value;
  const fs::path sim = dir / "sim.mcap", out = dir / "out.mcap";
  auto fail = [&](const char* stage, const Status& s) {
    r["status"] = "failed";
    r["stage"] = stage;
    r["error"] = s.message();
  };
  auto start = std::chrono::steady_clock::now();
  if (Status s = simulate(plan, sim); !s) {
    fail("simulate", s);
  } else {
    r["wall_s"]["simulate"] = secondsSince(start);
    start = std::chrono::steady_clock::now();
    Result<std::vector<std::string>> inputs = initialStates(campaign, plan, sim, dir);
    if (inputs) inputs->insert(inputs->begin(), sim.string());
    if (!inputs) {
      fail("initial state", inputs.status());
    } else if (Result<dfpc::ReplayResult> p = process(campaign, *inputs, out); !p) {
      fail("run", p.status());
    } else {
      r["wall_s"]["run"] = secondsSince(start);
      r["dfpcs"] = dfpcOutcomes(*p);
      start = std::chrono::steady_clock::now();
      Result<bool> produced = hasPoseProduct(out);
      eval::RecordingEvaluationNotes notes;
      Result<eval::EvaluationReport> report = Status::ok();
      if (produced && !*produced) {
        r["status"] = "no_product";  // ran to its end without producing a pose: not a fault
      } else if (!produced) {
        fail("evaluate", produced.status());
      } else if (report = eval::evaluateRecording({out.string()}, {}, &notes); !report) {
        fail("evaluate", report.status());
      } else {
        r["wall_s"]["evaluate"] = secondsSince(start);
        r["status"] = hasValidEstimate(*report) ? "ok" : "no_product";
        r["evaluation"] = eval::toJson(*report);
        r["evaluation"]["notes"] = notes.notes;
      }
    }
  }
  if (campaign.keep == Keep::kEvaluation)
    for (const fs::directory_entry& file : fs::directory_iterator(dir, ec))
      if (file.path().extension() == ".mcap") fs::remove(file.path(), ec);
  CDFF_RETURN_IF_ERROR(writeResult(results, index, r));
  return r;
}

}  // namespace cdff::campaign
