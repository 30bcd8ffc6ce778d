// cdff eval OUT.mcap [--json REPORT.json] [--html REPORT.html]
//
// Measures the pose and bearing products of a run against the ground truth recorded beside them and
// gives a verdict per applicable requirement (docs/evaluation.md).
#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <memory>

#include "cdff/eval/recording_evaluation.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

struct EvalArguments {
  std::vector<std::string> inputs;
  std::string json_path, html_path;
  std::string statistic = "p95";
  std::vector<std::string> products;
  std::vector<std::string> pairs;
  double max_truth_gap_s = 0.5;
  std::optional<double> focal_px;
  std::string camera;
  bool check = false;
  bool quiet = false;
};

Status writeFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return ioError("cannot open '{}' for writing", path);
  out << text;
  out.close();
  if (!out) return ioError("writing '{}' failed", path);
  return Status::ok();
}

int evaluate(const EvalArguments& args) {
  eval::RecordingEvaluationOptions options;
  if (args.statistic == "p95") {
    options.statistic = eval::Statistic::kP95;
  } else if (args.statistic == "max") {
    options.statistic = eval::Statistic::kMax;
  } else if (args.statistic == "rmse") {
    options.statistic = eval::Statistic::kRmse;
  } else {
    fmt::print(stderr, "error: --statistic '{}' is not one of p95, max, rmse\n", args.statistic);
    return 2;
  }
  if (!(args.max_truth_gap_s > 0)) {
    fmt::print(stderr, "error: --max-truth-gap {}: expected a positive number of seconds\n",
               args.max_truth_gap_s);
    return 2;
  }
  options.pose.max_truth_gap_s = args.max_truth_gap_s;
  if (args.focal_px) {
    if (!(*args.focal_px > 0) || !std::isfinite(*args.focal_px)) {
      fmt::print(stderr, "error: --focal-px {}: expected a positive number of pixels\n",
                 *args.focal_px);
      return 2;
    }
    options.focal_px = *args.focal_px;
  }
  options.camera_channel = args.camera;
  options.products = args.products;
  for (const std::string& pair : args.pairs) {
    const std::size_t eq = pair.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == pair.size()) {
      fmt::print(stderr, "error: --pair '{}': expected PRODUCT_CHANNEL=TRUTH_CHANNEL\n", pair);
      return 2;
    }
    options.pairs[pair.substr(0, eq)] = pair.substr(eq + 1);
  }

  eval::RecordingEvaluationNotes notes;
  Result<eval::EvaluationReport> report = eval::evaluateRecording(args.inputs, options, &notes);
  for (const std::string& n : notes.notes) fmt::print(stderr, "note: {}\n", n);
  if (!report) {
    fmt::print(stderr, "error: {}\n", report.status().message());
    return 1;
  }
  if (!args.quiet) fmt::print("{}", eval::toText(*report));
  if (!args.json_path.empty()) {
    if (Status s = writeFile(args.json_path, eval::toJson(*report).dump(2) + "\n"); !s.isOk()) {
      fmt::print(stderr, "error: --json: {}\n", s.message());
      return 1;
    }
  }
  if (!args.html_path.empty()) {
    if (Status s = writeFile(args.html_path, eval::toHtml(*report)); !s.isOk()) {
      fmt::print(stderr, "error: --html: {}\n", s.message());
      return 1;
    }
  }
  if (args.check && !report->allPass()) {
    fmt::print(stderr, "a requirement fails (--check)\n");
    return 1;
  }
  return 0;
}

}  // namespace

void addEvalCommand(CLI::App& root, int& exit_code) {
  auto args = std::make_shared<EvalArguments>();
  CLI::App* cmd = root.add_subcommand(
      "eval",
      "Measure a run's pose and bearing products against its ground truth; requirement verdicts");
  cmd->add_option("FILE", args->inputs, "MCAP recording(s) of a run (cdff run -o)")->required();
  cmd->add_option("--json", args->json_path, "Write the report as JSON (docs/evaluation.md)");
  cmd->add_option("--html", args->html_path, "Write the report as a self-contained HTML page");
  cmd->add_option("--statistic", args->statistic,
                  "Statistic of the accuracy verdicts: p95, max or rmse")
      ->capture_default_str();
  cmd->add_option("--product", args->products, "Only this product channel (repeatable)");
  cmd->add_option("--pair", args->pairs,
                  "Measure PRODUCT against TRUTH instead of pairing by frames: PRODUCT=TRUTH");
  cmd->add_option("--max-truth-gap", args->max_truth_gap_s,
                  "Longest truth gap (s) across which truth is interpolated")
      ->capture_default_str();
  cmd->add_option("--focal-px", args->focal_px,
                  "Focal length (px) of bearing errors in pixels (default: the recording's camera "
                  "calibration)");
  cmd->add_option("--camera", args->camera,
                  "Camera calibration channel whose focal length gives bearing errors in pixels");
  cmd->add_flag("--check", args->check, "Exit with status 1 when a requirement fails");
  cmd->add_flag("-q,--quiet", args->quiet, "Do not print the table");
  cmd->callback([args, &exit_code] { exit_code = evaluate(*args); });
}

}  // namespace cdff::app
