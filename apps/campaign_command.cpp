// cdff campaign CAMPAIGN.yaml -o DIR [--jobs N] [-q]       runs a verification campaign
// cdff campaign-report DIR [--json FILE] [-q]               its report, from the results folder
//
// docs/campaigns.md. Each run is a child process (`cdff campaign FILE -o DIR --run INDEX`), so a
// run that crashes takes only itself down; runs already done are not redone.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "cdff/campaign/pool.hpp"
#include "cdff/campaign/report.hpp"
#include "cdff/campaign/run.hpp"
#include "cdff/campaign/slurm.hpp"
#include "commands.hpp"

namespace cdff::app {
namespace {

namespace fs = std::filesystem;

struct CampaignArgs {
  std::string file, output, json;
  int jobs = 0;
  std::int64_t run = -1;
  bool quiet = false, check_only = false;
  // Slurm
  bool slurm = false, wait = false, fallback_local = false;
  std::string partition, slice, claim, sbatch = "sbatch";
  std::uint64_t tasks = 0;
  int cpus_per_task = 1;
};

std::string selfExecutable() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("cdff") : self.string();
}

int fail(const Status& s) {
  fmt::print(stderr, "error: {}\n", s.message());
  return 1;
}

int writeReport(const campaign::Campaign& c, const fs::path& dir, const std::string& json_path,
                bool quiet) {
  Result<nlohmann::json> report = campaign::campaignReport(c, dir);
  if (!report) return fail(report.status());
  const std::string path = json_path.empty() ? (dir / "report.json").string() : json_path;
  std::ofstream out(path);
  out << report->dump(1) << "\n";
  if (!out) return fail(ioError("cannot write '{}'", path));
  const std::string html_path = (dir / "report.html").string();
  std::ofstream html(html_path);
  html << campaign::reportHtml(*report);
  if (!html) return fail(ioError("cannot write '{}'", html_path));
  if (!quiet) fmt::print("{}report: {}, {}\n", campaign::reportText(*report), path, html_path);
  return (*report)["runs"]["failed"].get<int>() > 0 ? 1 : 0;
}

constexpr int kRunLocally = -1;

/// Submits the campaign as a Slurm array job; with --wait, reports when it has ended. Returns
/// kRunLocally when Slurm cannot take it and --fallback-local asks for the local pool.
int submitToSlurm(const campaign::Campaign& c, const CampaignArgs& args) {
  campaign::SlurmOptions options;
  options.partition = args.partition;
  options.tasks = args.tasks;
  options.cpus_per_task = args.cpus_per_task;
  options.wait = args.wait;
  options.sbatch = args.sbatch;
  options.task_command = {selfExecutable(), "campaign", fs::absolute(args.file).string(), "-o",
                          fs::absolute(args.output).string()};
  Result<campaign::SlurmSubmission> job = campaign::submitArrayJob(c, args.output, options);
  if (!job) {
    if (!args.fallback_local) return fail(job.status());
    fmt::print(stderr, "warning: {}\ncdff campaign: running on this machine (--fallback-local)\n",
               job.status().message());
    return kRunLocally;
  }
  const std::string after =
      args.wait ? " ended" : " submitted; when it has ended: cdff campaign-report " + args.output;
  fmt::print(stderr, "cdff campaign: Slurm job {} ({} array tasks){}\n  {}\n", job->job_id,
             job->tasks, after, job->command);
  if (!args.wait) return 0;
  fmt::print(stderr, "cdff campaign: Slurm job {}: {:.1f} s from its submission to its end\n",
             job->job_id, job->wall_s);
  return writeReport(c, args.output, args.json, args.quiet);
}

int runCampaign(const CampaignArgs& args) {
  Result<campaign::Campaign> c = campaign::loadCampaign(args.file);
  if (!c) return fail(c.status());
  const fs::path dir = args.output;
  if (args.run >= 0) {  // one run, in this process (the pool's child)
    if (static_cast<std::uint64_t>(args.run) >= c->runs)
      return fail(invalidInput("--run {}: the campaign has runs 0 to {}", args.run, c->runs - 1));
    if (Status s = campaign::prepareResults(*c, dir); !s) return fail(s);
    Result<nlohmann::json> r = campaign::executeRun(*c, static_cast<std::uint64_t>(args.run), dir);
    if (!r) return fail(r.status());
    fmt::print("{}\n", r->dump(1));
    return 0;
  }
  // A Slurm array task's campaign was checked when it was submitted: its tasks start at once.
  if (args.slice.empty())
    if (Status s = campaign::checkCampaign(*c); !s) return fail(s);
  if (args.check_only) {
    std::size_t own = 0;  // the scenario entries' own dispersions
    for (const campaign::ScenarioEntry& s : c->scenarios) own += s.dispersions.size();
    fmt::print("{}: ok ({} runs, {} scenarios, {} dispersions{}, {} graphs)\n", args.file, c->runs,
               c->scenarios.size(), c->dispersions.size(),
               own ? fmt::format(" + {} of scenario entries", own) : std::string(),
               c->dfpcs.size());
    return 0;
  }
  if (Status s = campaign::prepareResults(*c, dir); !s) return fail(s);
  if (args.slurm) {
    const int status = submitToSlurm(*c, args);
    if (status != kRunLocally) return status;
  }
  campaign::PoolOptions options;
  options.jobs = args.jobs > 0 ? args.jobs : static_cast<int>(std::thread::hardware_concurrency());
  options.run_command = {selfExecutable(), "campaign", args.file, "-o", dir.string(), "--run"};
  options.progress = !args.quiet;
  if (!args.slice.empty()) {  // a Slurm array task: its share of the runs, no report
    Result<std::pair<std::uint64_t, std::uint64_t>> slice = campaign::parseSlice(args.slice);
    if (!slice) return fail(slice.status());
    std::tie(options.slice_index, options.slice_count) = *slice;
    if (args.claim.find_first_not_of(
            "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") !=
        std::string::npos)
      return fail(
          invalidParameter("--claim '{}': expected letters, digits, '_' or '-' (a file "
                           "name's suffix)",
                           args.claim));
    options.claim_group = args.claim;
    Result<campaign::PoolSummary> done = campaign::runPool(*c, dir, options);
    return done ? 0 : fail(done.status());
  }
  Result<campaign::PoolSummary> summary = campaign::runPool(*c, dir, options);
  if (!summary) return fail(summary.status());
  if (!args.quiet)
    fmt::print(stderr,
               "cdff campaign: {} runs done now ({} failed, {} retried), {} done before, "
               "{:.1f} s with {} jobs\n",
               summary->completed, summary->failed, summary->retried, summary->skipped,
               summary->wall_s, options.jobs);
  return writeReport(*c, dir, args.json, args.quiet);
}

int reportCampaign(const CampaignArgs& args) {
  const fs::path dir = args.output;
  const fs::path copy = dir / "campaign.yaml";
  if (!fs::exists(copy))
    return fail(
        notFound("'{}' is not a campaign's results folder (no campaign.yaml in it)", dir.string()));
  Result<campaign::Campaign> c = campaign::loadCampaign(copy.string());
  if (!c) return fail(c.status());
  return writeReport(*c, dir, args.json, args.quiet);
}

}  // namespace

void addCampaignCommands(CLI::App& root, int& exit_code) {
  auto args = std::make_shared<CampaignArgs>();
  CLI::App* run = root.add_subcommand(
      "campaign", "Run a verification campaign: Monte-Carlo runs simulated, run and evaluated");
  run->add_option("CAMPAIGN", args->file, "The campaign file (YAML, docs/campaigns.md)")
      ->required();
  run->add_option("-o,--output", args->output, "The results folder (resumed when it exists)");
  run->add_option("-j,--jobs", args->jobs, "Runs at a time (default: the number of cores)")
      ->check(CLI::Range(1, 1024));
  run->add_option("--run", args->run, "Only this run, in this process (what the pool starts)")
      ->check(CLI::NonNegativeNumber);
  run->add_flag("--check", args->check_only,
                "Check the campaign (scenarios with their dispersions, graphs) and stop");
  run->add_flag("-q,--quiet", args->quiet, "No progress line and no report text");
  run->add_option("--json", args->json, "Write the report here (default: DIR/report.json)");
  run->add_flag("--slurm", args->slurm, "Submit the runs as a Slurm array job (sbatch --array)");
  run->add_option("--partition", args->partition, "With --slurm: the partition");
  run->add_option("--tasks", args->tasks, "With --slurm: array tasks (default: one per 10 runs)")
      ->check(CLI::Range(1, 100000));
  run->add_option("--cpus-per-task", args->cpus_per_task,
                  "With --slurm: cores per task (its local pool's jobs)")
      ->check(CLI::Range(1, 1024));
  run->add_flag("--wait", args->wait, "With --slurm: wait for the job's end, then report");
  run->add_flag("--fallback-local", args->fallback_local,
                "With --slurm: run on this machine when Slurm cannot take the job");
  run->add_option("--sbatch", args->sbatch, "With --slurm: the sbatch command (default: sbatch)");
  run->add_option("--slice", args->slice,
                  "Slurm array task I of K (I/K): start at run I*runs/K, no report");
  run->add_option("--claim", args->claim,
                  "With --slice: claim runs as the group NAME (the tasks of one job share them)");
  run->callback([args, &exit_code] {
    if (args->output.empty() && !args->check_only) {
      fmt::print(stderr, "error: cdff campaign {}: expected -o DIR (the results folder)\n",
                 args->file);
      exit_code = 2;
      return;
    }
    exit_code = runCampaign(*args);
  });

  auto report_args = std::make_shared<CampaignArgs>();
  CLI::App* report = root.add_subcommand(
      "campaign-report", "The report of a campaign's results folder (pass rates, intervals)");
  report->add_option("DIR", report_args->output, "The results folder")->required();
  report->add_option("--json", report_args->json,
                     "Write the report here (default: DIR/report.json)");
  report->add_flag("-q,--quiet", report_args->quiet, "No report text");
  report->callback([report_args, &exit_code] { exit_code = reportCampaign(*report_args); });
}

}  // namespace cdff::app
