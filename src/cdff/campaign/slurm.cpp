// Campaigns on Slurm (slurm.hpp).

#include "cdff/campaign/slurm.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

#include <fmt/format.h>

namespace cdff::campaign {
namespace {

namespace fs = std::filesystem;

/// Runs a shell command line; its exit status and its output (stdout and stderr).
std::pair<int, std::string> runCommand(const std::string& line) {
  std::FILE* pipe = popen((line + " 2>&1").c_str(), "r");
  if (!pipe) return {-1, "cannot start a shell"};
  std::string output;
  char buffer[4096];
  while (std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
  const int status = pclose(pipe);
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  while (!output.empty() && (output.back() == '\n' || output.back() == ' ')) output.pop_back();
  return {code, output};
}

}  // namespace

Result<std::pair<std::uint64_t, std::uint64_t>> parseSlice(const std::string& text) {
  unsigned long long index = 0, count = 0;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%llu/%llu%c", &index, &count, &extra) != 2 || count == 0 ||
      index >= count)
    return invalidParameter(
        "--slice '{}': expected I/K with 0 <= I < K (a Slurm array task's "
        "share of the runs)",
        text);
  return std::pair<std::uint64_t, std::uint64_t>{index, count};
}

Result<SlurmSubmission> submitArrayJob(const Campaign& campaign, const fs::path& results,
                                       const SlurmOptions& options) {
  SlurmSubmission s;
  s.tasks = options.tasks > 0 ? options.tasks
                              : std::clamp<std::uint64_t>((campaign.runs + 9) / 10, 1, 1000);
  s.tasks = std::min(s.tasks, campaign.runs);
  std::error_code ec;
  fs::create_directories(results / "slurm", ec);
  std::string task;
  for (const std::string& word : options.task_command) task += shellQuoted(word) + " ";
  task +=
      fmt::format("--slice \"$SLURM_ARRAY_TASK_ID/{}\" --claim \"job$SLURM_ARRAY_JOB_ID\" -j {} -q",
                  s.tasks, options.cpus_per_task);
  s.command = fmt::format(
      "{} --parsable --array=0-{} --job-name={} --output={} --chdir={} --cpus-per-task={}{} "
      "--wrap={}",
      shellQuoted(options.sbatch), s.tasks - 1, shellQuoted("cdff-" + campaign.name),
      shellQuoted((fs::absolute(results) / "slurm" / "%A_%a.log").string()),
      shellQuoted(fs::current_path().string()), options.cpus_per_task,
      options.partition.empty() ? "" : " --partition=" + shellQuoted(options.partition),
      shellQuoted(task));
  const auto submitted_at = std::chrono::steady_clock::now();
  const auto [code, output] = runCommand(s.command);
  // --parsable prints "jobid[;cluster]".
  const std::string first_line = output.substr(0, output.find('\n'));
  s.job_id = first_line.substr(0, first_line.find(';'));
  const bool submitted =
      !s.job_id.empty() && s.job_id.find_first_not_of("0123456789") == std::string::npos;
  if (!submitted)
    return ioError(
        "sbatch could not submit the campaign's array job (exit status {}): {}; is "
        "Slurm reachable (`sinfo`)? Without --slurm, or with --fallback-local, the "
        "campaign runs on this machine",
        code, output.empty() ? "no output" : output);
  if (!options.wait) return s;
  // The job has ended when squeue no longer lists it. Asking squeue costs the controller and a
  // process each time, so while runs are missing their results (a stat each) are what is
  // watched every second, and squeue is asked every 15 s (a task that died leaves runs without
  // results); once every run has one, squeue is asked every 0.2 s, so that the report follows
  // the job's end at once.
  bool all_done = false;
  for (int tick = 0;; ++tick) {
    if (!all_done) {
      all_done = true;
      for (std::uint64_t i = 0; i < campaign.runs && all_done; ++i)
        all_done = fs::exists(results / "runs" / fmt::format("{:06d}", i) / "result.json");
    }
    if (all_done || tick % 15 == 14) {
      const auto [status, listed] =
          runCommand(fmt::format("{} -h -j {} -o %i", shellQuoted(options.squeue), s.job_id));
      const bool gone = listed.empty() || listed.find("Invalid job id") != std::string::npos;
      if (status != 0 && !gone)
        return ioError("squeue could not tell the state of job {} (exit status {}): {}", s.job_id,
                       status, listed);
      if (gone) break;
    }
    std::this_thread::sleep_for(all_done ? std::chrono::milliseconds(200)
                                         : std::chrono::milliseconds(1000));
  }
  s.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - submitted_at).count();
  return s;
}

}  // namespace cdff::campaign
