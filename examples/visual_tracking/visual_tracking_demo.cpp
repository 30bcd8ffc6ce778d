// Visual tracking on a simulated approach, both chains side by side: the DFPC with CDFF's edge
// tracker and with ViSP's vpMbGenericTracker, from the same perturbed initial pose, evaluated
// against the simulator's ground truth. What `make demo` runs for visual tracking:
//
//   visual_tracking_demo [--scenario close_range_approach] [--rate 2] [--duration 60]
//                        [--dfi both|EdgeTracker|VispMbt] [--stereo] [--seed 7] [--verbose]
//                        [--tracker '{yaml: parameters}'] [--initial-error 5 5]
//
// Prints one table row per chain (the last column counts frames whose pose was more than 10 % of
// the range or 10 degrees off while the status was not LOST); exits with 1 on a bad argument or
// a failed run.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "simulated_approach.hpp"

int main(int argc, char** argv) {
  cdff::visual_demo::ApproachOptions options;
  std::string dfi = "both";
  bool verbose = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        fmt::print(stderr, "visual_tracking_demo: {} needs a value\n", a);
        std::exit(1);
      }
      return argv[++i];
    };
    const auto number = [&](const std::string& text) {
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (text.empty() || *end != '\0' || !(v > 0)) {
        fmt::print(stderr, "visual_tracking_demo: {} '{}' is not a positive number\n", a, text);
        std::exit(1);
      }
      return v;
    };
    if (a == "--scenario")
      options.scenario = value();
    else if (a == "--rate")
      options.camera_rate = number(value());
    else if (a == "--duration")
      options.duration = number(value());
    else if (a == "--seed")
      options.seed = static_cast<std::uint64_t>(number(value()));
    else if (a == "--stereo")
      options.stereo = true;
    else if (a == "--tracker")
      options.dfi_parameters = value();
    else if (a == "--initial-error") {
      options.initial_range_fraction = number(value()) / 100;
      options.initial_angle = number(value()) * M_PI / 180;
    } else if (a == "--verbose")
      verbose = true;
    else if (a == "--dfi") {
      dfi = value();
      if (dfi != "both" && dfi != "EdgeTracker" && dfi != "VispMbt") {
        fmt::print(stderr,
                   "visual_tracking_demo: --dfi '{}'; expected both, EdgeTracker or VispMbt\n",
                   dfi);
        return 1;
      }
    } else {
      fmt::print(
          stderr,
          "visual_tracking_demo: unknown argument '{}'; expected --scenario NAME, --rate HZ, "
          "--duration S, --dfi both|EdgeTracker|VispMbt, --stereo, --seed N, --tracker YAML, "
          "--initial-error PERCENT DEG, --verbose\n",
          a);
      return 1;
    }
  }
  std::vector<std::string> chains;
  if (dfi == "both" || dfi == "EdgeTracker") chains.push_back("EdgeTracker");
  if (dfi == "both" || dfi == "VispMbt") chains.push_back("VispMbt");
  fmt::print(
      "visual tracking DFPC on '{}' ({}, camera at {} Hz), initial pose off by 5 % of the "
      "range and 5 deg\n",
      options.scenario, options.stereo ? "stereo" : "mono", options.camera_rate);
  fmt::print(
      "| chain | frames | degraded | lost | position p95 / max | % of range p95 / max | "
      "angle p95 / max | CPU per frame mean / p95 | diverged without LOST |\n");
  fmt::print("|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& chain : chains) {
    options.dfi = chain;
    cdff::Result<cdff::visual_demo::ApproachResult> r = cdff::visual_demo::runApproach(options);
    if (!r) {
      fmt::print(stderr, "visual_tracking_demo: {}: {}\n", chain, r.status().toString());
      return 1;
    }
    fmt::print("{}\n", cdff::visual_demo::summaryLine(chain, *r));
    if (verbose)
      for (const std::string& w : r->warnings) fmt::print("  {}\n", w);
    std::fflush(stdout);
  }
  return 0;
}
