#pragma once
// Shared by the benchmark programs.

#include <memory>
#include <string>

#include <benchmark/benchmark.h>
#include <yaml-cpp/yaml.h>
#include <opencv2/core.hpp>

#include "cdff/dfn/registry.hpp"

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
