#pragma once
// Running a campaign on a Slurm cluster: one array job (`sbatch --array=0-(K-1)`) whose tasks
// run the local pool on their nodes (`cdff campaign FILE -o DIR --slice I/K --claim JOB`) over
// the shared results folder, each claiming runs as it goes (pool.hpp), so that the runs spread
// over the tasks however long each takes; `cdff campaign-report DIR` (or --wait) gathers them.
// Runs already done are skipped by every task, so a job can be resubmitted after an
// interruption.

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
  std::string squeue = "squeue";
  /// The command a task runs, its slice appended: {"/path/cdff", "campaign", FILE, "-o", DIR}.
  std::vector<std::string> task_command;
};

struct SlurmSubmission {
  std::string job_id;
  std::uint64_t tasks = 0;
  std::string command;  // the sbatch command line, for the user to see
  /// With `wait`: the job's wall time from its submission to its end, s.
  double wall_s = 0;
};

/// Submits the array job; an error (kIoError) says why sbatch could not submit it (not
/// installed, the controller unreachable), with sbatch's own message.
Result<SlurmSubmission> submitArrayJob(const Campaign& campaign,
                                       const std::filesystem::path& results,
                                       const SlurmOptions& options);

/// Parses "I/K" (0 <= I < K).
Result<std::pair<std::uint64_t, std::uint64_t>> parseSlice(const std::string& text);

}  // namespace cdff::campaign
