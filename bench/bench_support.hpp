#pragma once
// Shared by the benchmark programs.

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <yaml-cpp/yaml.h>
#include <opencv2/core.hpp>

#include "cdff/dfn/registry.hpp"
#include "cdff/eval/draws.hpp"
#include "cdff/types/status.hpp"

namespace cdff::bench {

/// A DFI typed as its DFN's generated class and configured from inline YAML; null on failure
/// (the benchmark then reports the error with SkipWithError).
template <typename Dfn>
std::unique_ptr<Dfn> createConfigured(const std::string& dfn, const std::string& dfi,
                                      const std::string& yaml = "{}") {
  auto node = dfn::Registry::instance().createAs<Dfn>(dfn, dfi);
  if (!node || !node.value()->configure(YAML::Load(yaml))) return nullptr;
  return std::move(node).value();
}

/// The first simulator seed of a benchmark's frames: the evaluation seeds (data/evaluation/
/// draws.yaml: 900001 on), or with CDFF_DRAW_SET=tuning the tuning ones (1 on), which the
/// parameters may be tuned on. CDFF_FIRST_SEED=N starts at seed N (to look at one frame again).
inline std::uint64_t firstSeed() {
  if (const char* first = std::getenv("CDFF_FIRST_SEED")) return std::strtoull(first, nullptr, 10);
  const char* set = std::getenv("CDFF_DRAW_SET");
  return set && std::string(set) == "tuning" ? 1 : 900001;
}

/// The ';'-separated items of an environment variable (none when unset).
inline std::vector<std::string> splitEnvironment(const char* name) {
  std::vector<std::string> out;
  const char* value = std::getenv(name);
  if (!value) return out;
  std::stringstream in(value);
  for (std::string item; std::getline(in, item, ';');)
    if (!item.empty()) out.push_back(item);
  return out;
}

/// The draws an accuracy benchmark runs, from the environment: CDFF_DRAW_SET=evaluation (the
/// default) or tuning; CDFF_DRAWS=N the set's first N (all evaluation draws when unset,
/// `tuning_default` tuning draws); CDFF_FROM_DRAW=K drops those numbered below K;
/// CDFF_DRAW_NUMBERS=A,B,... keeps only those numbers (of the draws above).
inline Result<std::vector<eval::Draw>> drawsFromEnvironment(const eval::DrawSets& sets,
                                                            std::uint64_t tuning_default) {
  const char* count = std::getenv("CDFF_DRAWS");
  const std::uint64_t n = count ? std::strtoull(count, nullptr, 10) : 0;
  const char* set = std::getenv("CDFF_DRAW_SET");
  const std::string which = set ? set : "evaluation";
  if (which != "evaluation" && which != "tuning")
    return invalidParameter("CDFF_DRAW_SET is '{}', expected 'evaluation' or 'tuning'", which);
  std::vector<eval::Draw> draws =
      which == "tuning" ? sets.tuningDraws(n > 0 ? n : tuning_default) : sets.evaluationDraws(n);
  if (const char* from = std::getenv("CDFF_FROM_DRAW")) {
    const std::uint64_t first = std::strtoull(from, nullptr, 10);
    std::erase_if(draws, [&](const eval::Draw& d) { return d.number < first; });
  }
  if (const char* list = std::getenv("CDFF_DRAW_NUMBERS")) {
    std::vector<std::uint64_t> keep;
    for (const char* c = list; *c;) {
      char* end = nullptr;
      keep.push_back(std::strtoull(c, &end, 10));
      if (end == c)
        return invalidParameter(
            "CDFF_DRAW_NUMBERS is '{}', expected a comma-separated list of draw numbers", list);
      c = *end ? end + 1 : end;
    }
    std::erase_if(draws, [&](const eval::Draw& d) {
      return std::find(keep.begin(), keep.end(), d.number) == keep.end();
    });
  }
  if (draws.empty()) return invalidParameter("no draws selected (CDFF_DRAW_* variables)");
  return draws;
}

}  // namespace cdff::bench

/// main() of the benchmark programs: OpenCV runs on one thread, so that every figure is the
/// cost on one core (the CPU time column) and a DFI and the library call it wraps compare
/// fairly whatever else the machine is doing.
#define CDFF_BENCHMARK_MAIN()                                         \
  int main(int argc, char** argv) {                                   \
    cv::setNumThreads(1);                                             \
    benchmark::Initialize(&argc, argv);                               \
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1; \
    benchmark::RunSpecifiedBenchmarks();                              \
    benchmark::Shutdown();                                            \
    return 0;                                                         \
  }
