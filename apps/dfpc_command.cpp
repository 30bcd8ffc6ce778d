// cdff dfpc check GRAPH.yaml... | graph GRAPH.yaml
#include <fmt/format.h>

#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/graph.hpp"
#include "cdff/dfpc/replay.hpp"
#include "cdff/dfpc/run_set.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

// A run set: its graphs, settings, maps and rules, as `cdff run` would load them.
bool checkRunSet(const std::string& path) {
  Result<dfpc::RunSet> set = dfpc::loadRunSet(path);
  dfpc::ReplayOptions options;
  options.graph_files = {path};
  const Status status = set ? dfpc::checkRun(options) : set.status();
  if (!status) {
    fmt::print(stderr, "{}: {}\n", path, status.message());
    return false;
  }
  fmt::print("{}: ok: run set '{}', {} DFPCs, {} rules\n", path, set->name, set->graph_files.size(),
             set->run_while.size());
  return true;
}

// Every problem of each graph (structure, DFNs, types, connections, cycles, conditions,
// recoveries, then parameters); 0 when all are sound, 1 otherwise.
int checkGraphs(const std::vector<std::string>& paths) {
  int failures = 0;
  for (const std::string& path : paths) {
    if (dfpc::isRunSetFile(path)) {
      failures += checkRunSet(path) ? 0 : 1;
      continue;
    }
    Result<dfpc::GraphSpec> spec = dfpc::loadGraphFile(path);
    if (!spec) {
      fmt::print(stderr, "{}\n", spec.status().message());
      ++failures;
      continue;
    }
    const std::vector<Status> problems = dfpc::checkGraph(*spec);
    for (const Status& s : problems) fmt::print(stderr, "{}\n", s.message());
    if (!problems.empty()) {
      ++failures;
      continue;
    }
    // The instances are created and configured: parameter errors are graph errors too.
    Result<std::unique_ptr<dfpc::Dfpc>> dfpc = dfpc::Dfpc::create(*spec);
    if (!dfpc) {
      fmt::print(stderr, "{}\n", dfpc.status().message());
      ++failures;
      continue;
    }
    fmt::print("{}: ok: DFPC '{}', {} instances, {} connections, {} inputs, {} outputs\n", path,
               spec->name, spec->instances.size(), spec->connections.size(), spec->inputs.size(),
               spec->outputs.size());
  }
  return failures ? 1 : 0;
}

int printGraph(const std::string& path) {
  Result<dfpc::GraphSpec> spec = dfpc::loadGraphFile(path);
  if (!spec) {
    fmt::print(stderr, "{}\n", spec.status().message());
    return 1;
  }
  fmt::print("{}", dfpc::toDot(*spec));
  return 0;
}

}  // namespace

void addDfpcCommands(CLI::App& root, int& exit_code) {
  CLI::App* dfpc = root.add_subcommand("dfpc", "Check and draw DFPC graphs (dfpcs/*.yaml)");
  dfpc->require_subcommand(1);

  CLI::App* check = dfpc->add_subcommand(
      "check", "Validate DFPC graphs: DFNs, ports, types, cycles, conditions, parameters");
  auto paths = std::make_shared<std::vector<std::string>>();
  check->add_option("GRAPH", *paths, "DFPC graph files or run sets (YAML)")->required();
  check->callback([paths, &exit_code] { exit_code = checkGraphs(*paths); });

  CLI::App* graph = dfpc->add_subcommand("graph", "Print a DFPC graph as Graphviz DOT");
  auto path = std::make_shared<std::string>();
  graph->add_option("GRAPH", *path, "DFPC graph file (YAML)")->required();
  graph->callback([path, &exit_code] { exit_code = printGraph(*path); });
}

}  // namespace cdff::app
