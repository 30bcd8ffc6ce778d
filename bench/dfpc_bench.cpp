// The DFPC framework's own cost per DFN call: a chain of 10 trivial DFNs (the test probe
// ProbeRelay: out = a + offset) run as a DFPC graph, against the same 10 DFNs called by hand in
// the same run. The difference per call is what the framework adds (issue target: < 2 us).
#include <benchmark/benchmark.h>

#include <fmt/format.h>

#include "ProbeRelay.gen.hpp"
#include "bench_support.hpp"
#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/orchestrator.hpp"

namespace {

using namespace cdff;
constexpr int kNodes = 10;

std::string chainGraph() {
  std::string g =
      "name: chain\ninputs: [{name: x, type: Double, channel: /in/x}]\n"
      "outputs: [{name: y, type: Double}]\nnodes:\n";
  for (int i = 0; i < kNodes; ++i) g += fmt::format("  n{}: {{dfn: ProbeRelay, dfi: Plain}}\n", i);
  g += "connections:\n  - x -> n0.a\n";
  for (int i = 1; i < kNodes; ++i) g += fmt::format("  - n{}.result -> n{}.a\n", i - 1, i);
  g += fmt::format("  - n{}.result -> y\n", kNodes - 1);
  return g;
}

std::unique_ptr<dfpc::Dfpc> chain() {
  Result<dfpc::GraphSpec> spec = dfpc::parseGraph(chainGraph(), "chain.yaml");
  if (!spec) return nullptr;
  Result<std::unique_ptr<dfpc::Dfpc>> d = dfpc::Dfpc::create(std::move(spec).value());
  if (!d || !d.value()->start()) return nullptr;
  return std::move(d).value();
}

void perCall(benchmark::State& state) {
  state.counters["per_dfn_call"] = benchmark::Counter(
      kNodes, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// The baseline: each node's process(), its output handed to the next node's input.
void BM_TenDfnsCalledByHand(benchmark::State& state) {
  std::vector<std::unique_ptr<dfn::ProbeRelay>> nodes;
  for (int i = 0; i < kNodes; ++i) {
    nodes.push_back(bench::createConfigured<dfn::ProbeRelay>("ProbeRelay", "Plain"));
    if (!nodes.back()) return state.SkipWithError("ProbeRelay/Plain is not registered");
  }
  auto x = std::make_shared<const double>(1.0);
  for (auto _ : state) {
    nodes[0]->in.a.set(x);
    (void)nodes[0]->process();
    for (int i = 1; i < kNodes; ++i) {
      nodes[i]->in.a.set(nodes[i - 1]->out.result.shared());
      (void)nodes[i]->process();
    }
    benchmark::DoNotOptimize(nodes.back()->out.result.get());
  }
  perCall(state);
}
BENCHMARK(BM_TenDfnsCalledByHand);

// The same chain as a DFPC graph: one message per iteration through Dfpc::deliver().
void BM_TenDfnsInADfpcGraph(benchmark::State& state) {
  auto dfpc = chain();
  if (!dfpc) return state.SkipWithError("the chain graph does not load");
  dfpc::Message m = dfpc::Message::of<double>("/in/x", 0, 1.0);
  for (auto _ : state) {
    ++m.stamp;
    benchmark::DoNotOptimize(dfpc->deliver(0, m));
  }
  perCall(state);
}
BENCHMARK(BM_TenDfnsInADfpcGraph);

// Through the Orchestrator (channel routing, stream time for every DFPC, products into the Data
// Product Manager), without a sink.
void BM_TenDfnsThroughTheOrchestrator(benchmark::State& state) {
  dfpc::Orchestrator o;
  if (!o.add(chain()) || !o.startAll()) return state.SkipWithError("the chain does not load");
  dfpc::Message m = dfpc::Message::of<double>("/in/x", 0, 1.0);
  for (auto _ : state) {
    ++m.stamp;
    benchmark::DoNotOptimize(o.process(m));
  }
  perCall(state);
}
BENCHMARK(BM_TenDfnsThroughTheOrchestrator);

// As above, recording: a sink that receives (and drops) one timing record per call and the
// product, as `cdff run` does before encoding them.
class CountingSink final : public dfpc::Sink {
 public:
  Status writeMessage(const dfpc::Message&) override { return ++messages, Status::ok(); }
  Status writeEvent(const dfpc::Event&) override { return ++events, Status::ok(); }
  Status writeTiming(const dfpc::TimingRecord& t) override {
    benchmark::DoNotOptimize(t.wall_s);
    return ++timings, Status::ok();
  }
  std::uint64_t messages = 0, events = 0, timings = 0;
};

void BM_TenDfnsThroughTheOrchestratorRecording(benchmark::State& state) {
  CountingSink sink;
  dfpc::OrchestratorOptions options;
  options.sink = &sink;
  dfpc::Orchestrator o(options);
  if (!o.add(chain()) || !o.startAll()) return state.SkipWithError("the chain does not load");
  dfpc::Message m = dfpc::Message::of<double>("/in/x", 0, 1.0);
  for (auto _ : state) {
    ++m.stamp;
    benchmark::DoNotOptimize(o.process(m));
  }
  perCall(state);
}
BENCHMARK(BM_TenDfnsThroughTheOrchestratorRecording);

}  // namespace

CDFF_BENCHMARK_MAIN();
