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
  /// Only the runs i with i mod slice_count == slice_index (a Slurm array task's share).
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
