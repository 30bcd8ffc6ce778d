// The local pool of run processes (pool.hpp).

#include "cdff/campaign/pool.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cdff/campaign/run.hpp"

extern char** environ;

namespace cdff::campaign {
namespace {

namespace fs = std::filesystem;

Result<pid_t> spawnRun(const PoolOptions& options, std::uint64_t index, const fs::path& log) {
  std::vector<std::string> args = options.run_command;
  args.push_back(std::to_string(index));
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return ioError("cannot start '{}': {}", args[0], std::strerror(rc));
  return pid;
}

/// Creates `dir`/claim.<group> if no one has: true when this process now has the run.
bool claim(const fs::path& dir, const std::string& group) {
  const fs::path file = dir / ("claim." + group);
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
  if (fd < 0) return false;
  const std::string who = fmt::format("{}\n", getpid());
  (void)!::write(fd, who.data(), who.size());
  ::close(fd);
  return true;
}

/// Waits until one of this pool's own run processes ends (never another child of the program,
/// which may run other pools or processes of its own): its pid and wait status.
Result<pid_t> waitForOne(const std::map<pid_t, std::uint64_t>& running, int& status) {
  while (true) {
    for (const auto& [pid, index] : running) {
      const pid_t ended = waitpid(pid, &status, WNOHANG);
      if (ended == pid) return pid;
      if (ended < 0) return ioError("waiting for run {}: {}", index, std::strerror(errno));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

std::string exitReason(int status) {
  if (WIFSIGNALED(status))
    return fmt::format("killed by signal {} ({})", WTERMSIG(status), strsignal(WTERMSIG(status)));
  return fmt::format("exit status {}", WEXITSTATUS(status));
}

class ProgressLine {
 public:
  ProgressLine(bool enabled, std::uint64_t total)
      : enabled_(enabled),
        tty_(isatty(STDERR_FILENO) != 0),
        total_(total),
        start_(std::chrono::steady_clock::now()) {}
  void update(std::uint64_t done, std::uint64_t failed) {
    if (!enabled_ || total_ == 0) return;
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double eta = done > 0 ? elapsed / done * (total_ - done) : 0;
    const int width = 30, filled = static_cast<int>(width * done / total_);
    const std::string line = fmt::format("[{}{}] {}/{} runs, {} failed, {:.0f} s, ETA {:.0f} s",
                                         std::string(filled, '#'), std::string(width - filled, '.'),
                                         done, total_, failed, elapsed, eta);
    if (tty_) {
      fmt::print(stderr, "\r{}{}", line, done == total_ ? "\n" : "");
    } else if (done * 10 / total_ > last_decile_ || done == total_) {
      last_decile_ = done * 10 / total_;
      fmt::print(stderr, "cdff campaign: {}\n", line);
    }
  }

 private:
  bool enabled_, tty_;
  std::uint64_t total_;
  std::chrono::steady_clock::time_point start_;
  std::uint64_t last_decile_ = 0;
};

}  // namespace

Status prepareResults(const Campaign& campaign, const fs::path& results) {
  std::error_code ec;
  fs::create_directories(results / "runs", ec);
  if (ec) return ioError("cannot create '{}': {}", results.string(), ec.message());
  const fs::path identity = results / "campaign.json";
  if (fs::exists(identity)) {
    nlohmann::json held = nlohmann::json::parse(std::ifstream(identity), nullptr, false);
    if (held.is_discarded() ||
        held.value("identity", std::string()) != fmt::format("{:016x}", campaign.identity()))
      return invalidInput(
          "'{}' holds the results of campaign '{}' ({}); expected those of '{}' (from '{}') or "
          "a new folder",
          results.string(), held.is_discarded() ? "unreadable" : held.value("name", "?"),
          held.is_discarded() ? identity.string() : held.value("source", "?"), campaign.name,
          campaign.source);
    return Status::ok();
  }
  std::ofstream(results / "campaign.yaml") << campaign.text;
  std::ofstream out(identity);
  out << nlohmann::json({{"name", campaign.name},
                         {"source", campaign.source},
                         {"runs", campaign.runs},
                         {"identity", fmt::format("{:016x}", campaign.identity())}})
             .dump(1)
      << "\n";
  if (!out) return ioError("cannot write '{}'", identity.string());
  return Status::ok();
}

Result<PoolSummary> runPool(const Campaign& campaign, const fs::path& results,
                            const PoolOptions& options) {
  PoolSummary summary;
  summary.runs = campaign.runs;
  const auto start = std::chrono::steady_clock::now();
  std::deque<std::uint64_t> todo;
  const std::uint64_t first =
      options.slice_index * campaign.runs / std::max<std::uint64_t>(1, options.slice_count);
  for (std::uint64_t k = 0; k < campaign.runs; ++k) {
    const std::uint64_t i = (first + k) % campaign.runs;
    if (fs::exists(resultFile(results, i)))
      ++summary.skipped;
    else
      todo.push_back(i);
  }
  ProgressLine progress(options.progress, todo.size());
  std::map<pid_t, std::uint64_t> running;
  std::map<std::uint64_t, int> attempts;
  const int jobs = std::max(1, options.jobs);
  while (!todo.empty() || !running.empty()) {
    while (!todo.empty() && static_cast<int>(running.size()) < jobs) {
      const std::uint64_t index = todo.front();
      todo.pop_front();
      std::error_code ec;
      fs::create_directories(runDirectory(results, index), ec);
      if (!options.claim_group.empty() && attempts[index] == 0 &&
          !claim(runDirectory(results, index), options.claim_group))
        continue;  // another process of the group has it
      Result<pid_t> pid = spawnRun(options, index, runDirectory(results, index) / "log.txt");
      if (!pid) return pid.status();
      running[*pid] = index;
      ++attempts[index];
    }
    if (running.empty()) continue;  // every remaining run was claimed by another process
    int status = 0;
    Result<pid_t> ended = waitForOne(running, status);
    if (!ended) return ended.status();
    const auto it = running.find(*ended);
    const std::uint64_t index = it->second;
    running.erase(it);
    if (!fs::exists(resultFile(results, index))) {
      if (attempts[index] < 2) {
        ++summary.retried;
        todo.push_front(index);
        continue;
      }
      const RunPlan plan = planRun(campaign, index);
      CDFF_RETURN_IF_ERROR(writeResult(
          results, index,
          {{"index", index},
           {"draw", plan.draw},
           {"scenario", plan.scenario->name},
           {"status", "failed"},
           {"stage", "process"},
           {"error",
            fmt::format("the run's process ended without a result twice ({}); its "
                        "output is in {}",
                        exitReason(status), (runDirectory(results, index) / "log.txt").string())},
           {"reproduce", reproduceCommand(campaign, plan)}}));
    }
    ++summary.completed;
    nlohmann::json r =
        nlohmann::json::parse(std::ifstream(resultFile(results, index)), nullptr, false);
    const std::string outcome = r.is_discarded() ? "" : r.value("status", "");
    if (outcome != "ok" && outcome != "no_product") ++summary.failed;
    progress.update(summary.completed, summary.failed);
  }
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace cdff::campaign
