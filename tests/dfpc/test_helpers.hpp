#pragma once
// Helpers of the DFPC framework tests: graphs from inline YAML, messages, runs in memory.
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/orchestrator.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfpc::testing {

/// Every error of a graph text: parse errors, checkGraph() errors, then Dfpc::create() errors
/// (parameters), one per line; "" when the graph is sound.
inline std::string graphErrors(const std::string& yaml, const std::string& file = "graph.yaml") {
  Result<GraphSpec> spec = parseGraph(yaml, file);
  if (!spec) return spec.status().message();
  std::string out;
  for (const Status& s : checkGraph(*spec)) out += s.message() + "\n";
  if (!out.empty()) return out;
  Result<std::unique_ptr<Dfpc>> dfpc = Dfpc::create(*spec);
  return dfpc ? "" : dfpc.status().message();
}

/// A DFPC from inline YAML (the test fails if it does not load).
inline std::unique_ptr<Dfpc> makeDfpc(const std::string& yaml) {
  Result<GraphSpec> spec = parseGraph(yaml, "graph.yaml");
  EXPECT_TRUE(spec.isOk()) << spec.status().toString();
  if (!spec) return nullptr;
  Result<std::unique_ptr<Dfpc>> dfpc = Dfpc::create(std::move(spec).value());
  EXPECT_TRUE(dfpc.isOk()) << dfpc.status().toString();
  return dfpc ? std::move(dfpc).value() : nullptr;
}

inline Message number(const std::string& channel, double seconds, double value) {
  return Message::of<double>(channel, fromSeconds(seconds), value);
}

/// The Double values of a channel in a sink, in order.
inline std::vector<double> values(const MemorySink& sink, const std::string& channel) {
  std::vector<double> out;
  for (const Message& m : sink.messages(channel)) out.push_back(*m.as<double>());
  return out;
}

inline std::vector<Timestamp> stamps(const MemorySink& sink, const std::string& channel) {
  std::vector<Timestamp> out;
  for (const Message& m : sink.messages(channel)) out.push_back(m.stamp);
  return out;
}

/// An orchestrator with one DFPC from inline YAML, started, writing to `sink`.
inline std::unique_ptr<Orchestrator> runningOrchestrator(const std::string& yaml, MemorySink& sink,
                                                         OrchestratorOptions options = {}) {
  options.sink = &sink;
  auto orchestrator = std::make_unique<Orchestrator>(options);
  auto dfpc = makeDfpc(yaml);
  if (!dfpc) return nullptr;
  EXPECT_TRUE(orchestrator->add(std::move(dfpc)).isOk());
  EXPECT_TRUE(orchestrator->startAll().isOk());
  return orchestrator;
}

}  // namespace cdff::dfpc::testing
