#pragma once
// Verification campaigns (docs/campaigns.md): Monte-Carlo runs of scenarios x DFPC graphs, each
// run simulated, processed and evaluated against its ground truth, every run reproducible from
// the campaign file and its index.
//
//   Result<Campaign> campaign = loadCampaign("data/campaigns/lidar_tracking_smoke.yaml");
//   RunPlan plan = planRun(*campaign, 7);   // the draw, the scenario and the dispersed keys
//
// A campaign file names the scenarios (taken in turn: run i simulates scenario i mod S), the
// dispersions (scenario keys drawn per run: uniform, normal or a choice), the DFPC graphs run
// over each simulated recording, the number of runs and the first draw number. Run i is draw
// first_draw + i: the simulator's seed is the draw number and each dispersion draws from a
// stream of its own derived from it, so adding a dispersion never changes another's values.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "cdff/types/status.hpp"

namespace cdff::campaign {

enum class DistributionKind { kUniform, kNormal, kChoice };

struct Dispersion {
  std::string key;  // a scenario key, dotted ("sensors.lidar.range_noise")
  DistributionKind kind = DistributionKind::kUniform;
  double low = 0, high = 0;         // uniform
  double mean = 0, sigma = 0;       // normal
  std::vector<std::string> values;  // choice (YAML scalars, as written)
  SourceLocation where;             // the dispersion's place in the campaign file
};

struct ScenarioEntry {
  std::string name;                // a library scenario or a YAML file
  std::string label;               // names the entry in the report (by default its name)
  std::optional<double> duration;  // s; the scenario's own when absent
  std::vector<std::string> set;    // fixed overrides, "dotted.key=value"
  /// Drawn for this scenario only, after the campaign's: keys only it has (its faults' times and
  /// sizes: faults.0.fraction).
  std::vector<Dispersion> dispersions;
};

/// A tracker started from the truth with an error drawn as a detection's would be (`cdff
/// initial-state`): written on `channel` at the first message of `at`, the error's size an RMS
/// fraction of the range and an RMS angle, drawn from the run's initial-error stream.
struct InitialStateEntry {
  std::string channel;                       // e.g. /cdff/visual_tracking/initial_state
  std::string at = "/chaser/lidar/points";   // the state is at this channel's first message
  std::string truth = "/truth/target_pose";  // the truth perturbed (its frame is the state's)
  double position_fraction = 0.10;
  double angle_deg = 10.0;
  double velocity_sigma = 0.3;  // m/s, the (zero) twist's stated uncertainty
  double angular_velocity_sigma_deg = 5.729577951308232;  // deg/s (0.1 rad/s)
  bool fixed_size = false;  // exactly the sizes in random directions instead of the Gaussian
};

struct DfpcEntry {
  std::string graph;                   // a DFPC graph file
  std::vector<std::string> settings;   // "[DFPC/]NODE.PARAM=VALUE", as `cdff run --set`
  std::vector<std::string> maps;       // "DFPC.INPUT=/channel", as `cdff run --map`
  std::vector<std::string> pairs;      // "/pair=/left,/right", as `cdff run --pair`
  std::vector<std::string> run_while;  // "DFPC=TRACKER:STATE,...", as `cdff run --run-while`
  std::optional<InitialStateEntry> initial_state;
};

/// What a campaign keeps of each run besides its result (result.json): nothing more, or the
/// simulated recording and the DFPCs' output too.
enum class Keep { kEvaluation, kAll };

struct Campaign {
  std::string name;
  std::string doc;
  std::uint64_t runs = 0;
  std::uint64_t first_draw = 0;
  Keep keep = Keep::kEvaluation;
  std::vector<ScenarioEntry> scenarios;
  std::vector<Dispersion> dispersions;
  std::vector<DfpcEntry> dfpcs;
  std::string source;  // the file it was read from
  std::string text;    // its text, for the results folder's copy and identity
  /// Hash of the text: a results folder belongs to one campaign.
  std::uint64_t identity() const;
};

/// Reads and checks a campaign file. Paths in it (scenario files, graphs) are relative to the
/// working directory, as on the command line. Errors in the one format, with file:line.
Result<Campaign> loadCampaign(const std::string& path);
Result<Campaign> parseCampaign(const std::string& text, const std::string& source);

/// One run, fully determined by the campaign and its index.
struct RunPlan {
  std::uint64_t index = 0;
  std::uint64_t draw = 0;  // the simulator's seed
  const ScenarioEntry* scenario = nullptr;
  std::vector<std::string> overrides;  // the scenario's fixed ones, then the dispersed ones
  std::vector<std::pair<std::string, std::string>> dispersed;  // key, value drawn
};

RunPlan planRun(const Campaign& campaign, std::uint64_t index);

/// Builds the simulator of every scenario with every dispersion at its extremes (low and high,
/// each choice), so that a key the scenario does not have, or a value it refuses, is found
/// before any run starts; the error is located at the dispersion in the campaign file. Also
/// loads every graph with its settings.
Status checkCampaign(const Campaign& campaign);

/// A word quoted for a POSIX shell when it needs to be.
std::string shellQuoted(const std::string& word);

/// The shell command that reproduces a run on its own (simulate, run, evaluate).
std::string reproduceCommand(const Campaign& campaign, const RunPlan& plan);

}  // namespace cdff::campaign
