#pragma once
// Running a campaign's runs on one machine: a pool of child processes, each running one run
// (`cdff campaign FILE -o DIR --run INDEX`), so that a run that crashes takes only itself down.
// Runs whose result.json exists are not redone (an interrupted campaign resumes); a run whose
// process ends without a result is retried once, then recorded as failed with the reason.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "cdff/campaign/campaign.hpp"

namespace cdff::campaign {

struct PoolOptions {
  int jobs = 1;
  /// The command that runs one run, its index appended: {"/path/cdff", "campaign", FILE, "-o",
  /// DIR, "--run"}.
  std::vector<std::string> run_command;
  bool progress = true;  // a progress line with the ETA on stderr
  /// Processes that share the runs (a Slurm array job's tasks) claim each run before running
  /// it: the first to create DIR/runs/NNNNNN/claim.<claim_group> runs it, the others go on to
  /// the next run, so that a task that is done early takes runs a slower one has not reached.
  /// Empty: no claims (the only process on the folder). Claims of another group (an earlier
  /// job) are ignored: a resubmitted job redoes what an interrupted one left unfinished.
  std::string claim_group;
  /// Where in the run order this process starts (task I of K starts at run I * runs / K), so
  /// that the processes of a group start apart.
  std::uint64_t slice_index = 0, slice_count = 1;
};

struct PoolSummary {
  std::uint64_t runs = 0;       // in the campaign
  std::uint64_t skipped = 0;    // already done before this call
  std::uint64_t completed = 0;  // done by this call (ok or failed)
  std::uint64_t failed = 0;     // of those, failed
  std::uint64_t retried = 0;    // processes that ended without a result and were run again
  double wall_s = 0;
};

/// Prepares `results` for `campaign`: creates it, or checks that it holds this campaign's
/// results (a folder of another campaign is refused), and keeps a copy of the campaign file.
Status prepareResults(const Campaign& campaign, const std::filesystem::path& results);

/// Runs every run of the campaign without a result yet, `jobs` at a time.
Result<PoolSummary> runPool(const Campaign& campaign, const std::filesystem::path& results,
                            const PoolOptions& options);

}  // namespace cdff::campaign
