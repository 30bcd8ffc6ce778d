#pragma once
// Running a campaign on a Slurm cluster: one array job (`sbatch --array=0-(K-1)`) whose task I
// runs the runs i with i mod K == I through the local pool on its node (`cdff campaign FILE -o
// DIR --slice I/K`), writing into the shared results folder; `cdff campaign-report DIR` (or
// --wait) gathers them. Runs already done are skipped by every task, so a job can be
// resubmitted after an interruption.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "cdff/campaign/campaign.hpp"

namespace cdff::campaign {

struct SlurmOptions {
  std::string partition;    // "" : the cluster's default
  std::uint64_t tasks = 0;  // array tasks; 0: one per 10 runs, at most 1000
  int cpus_per_task = 1;    // each task's local pool runs this many at a time
  bool wait = false;        // return when the job has ended (sbatch --wait)
  std::string sbatch = "sbatch";
  /// The command a task runs, its slice appended: {"/path/cdff", "campaign", FILE, "-o", DIR}.
  std::vector<std::string> task_command;
};

struct SlurmSubmission {
  std::string job_id;
  std::uint64_t tasks = 0;
  std::string command;  // the sbatch command line, for the user to see
  /// With `wait`: sbatch's exit status once the job ended (0: every task succeeded) and what it
  /// said.
  int end_status = 0;
  std::string end_output;
};

/// Submits the array job; an error (kIoError) says why sbatch could not submit it (not
/// installed, the controller unreachable), with sbatch's own message.
Result<SlurmSubmission> submitArrayJob(const Campaign& campaign,
                                       const std::filesystem::path& results,
                                       const SlurmOptions& options);

/// Parses "I/K" (0 <= I < K).
Result<std::pair<std::uint64_t, std::uint64_t>> parseSlice(const std::string& text);

/// A word quoted for a POSIX shell when it needs to be.
std::string shellQuoted(const std::string& word);

}  // namespace cdff::campaign
