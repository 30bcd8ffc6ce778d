// DFPC graphs: the YAML front end, the C++ builder, and every kind of load error with its
// location (file:line:column).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "test_helpers.hpp"

namespace cdff::dfpc {
namespace {

using testing::graphErrors;

// Line numbers below refer to this text (line 1 is "name: chain").
const std::string kChain = R"(name: chain
inputs:
  - {name: x, type: Double, channel: /in/x}
outputs:
  - {name: y, type: Double}
nodes:
  first: {dfn: ProbeRelay, dfi: Plain}
  second:
    dfn: ProbeRelay
    dfi: Plain
    parameters: {offset: 1}
connections:
  - x -> first.a
  - first.result -> second.a
  - second.result -> y
)";

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

#define EXPECT_CONTAINS(text, fragment)                          \
  EXPECT_NE(std::string(text).find(fragment), std::string::npos) \
      << "'" << (fragment) << "' not in:\n"                      \
      << (text)

TEST(GraphYaml, ASoundGraphLoadsIntoItsSpec) {
  EXPECT_EQ(graphErrors(kChain), "");
  Result<GraphSpec> spec = parseGraph(kChain, "graph.yaml");
  ASSERT_OK(spec.status());
  EXPECT_EQ(spec->name, "chain");
  ASSERT_EQ(spec->instances.size(), 2u);
  EXPECT_EQ(spec->instances[1].dfn, "ProbeRelay");
  EXPECT_EQ(spec->instances[1].parameters["offset"].as<double>(), 1.0);
  ASSERT_EQ(spec->connections.size(), 3u);
  EXPECT_EQ(spec->connections[1].from.toString(), "first.result");
  EXPECT_EQ(spec->connections[1].to.toString(), "second.a");
  EXPECT_EQ(spec->connections[1].at.line, 14);
  EXPECT_EQ(spec->outputChannel(spec->outputs[0]), "/cdff/chain/y");
}

TEST(GraphYaml, UnknownDfnNamesTheLineAndTheKnownDfns) {
  const std::string e = graphErrors(replaced(kChain, "dfn: ProbeRelay\n", "dfn: ProbeRelya\n"));
  EXPECT_CONTAINS(e, "graph.yaml:9:10: instance 'second': unknown DFN 'ProbeRelya'");
  EXPECT_CONTAINS(e, "ProbeRelay");
  EXPECT_CONTAINS(e, "EstimationFilter");
}

TEST(GraphYaml, UnknownDfiNamesTheLineAndTheDfnsImplementations) {
  const std::string e = graphErrors(replaced(kChain, "dfi: Plain\n", "dfi: Fancy\n"));
  EXPECT_CONTAINS(e,
                  "graph.yaml:10:10: instance 'second': DFN 'ProbeRelay' has no "
                  "implementation 'Fancy'; expected one of {Plain, Alternative}");
}

TEST(GraphYaml, TypeMismatchBetweenConnectedPortsNamesBothTypes) {
  const std::string e =
      graphErrors(replaced(kChain, "first.result -> second.a", "first.calls -> second.a"));
  EXPECT_CONTAINS(e,
                  "graph.yaml:14:5: type mismatch: 'first.calls' is Int but 'second.a' is "
                  "Double");
}

TEST(GraphYaml, UnconnectedRequiredInputIsAnError) {
  const std::string e = graphErrors(replaced(kChain, "  - first.result -> second.a\n", ""));
  EXPECT_CONTAINS(e,
                  "graph.yaml:8:3: instance 'second' (ProbeRelay): required input 'a' "
                  "(Double) is not connected");
}

TEST(GraphYaml, CycleWithoutDelayIsAnErrorAndADelayBreaksIt) {
  const std::string cyclic = replaced(kChain, "  - second.result -> y\n",
                                      "  - second.result -> y\n  - second.result -> first.b\n");
  const std::string e = graphErrors(cyclic);
  EXPECT_CONTAINS(e, "graph.yaml:16:5: cycle without a delay: first -> second -> first");
  const std::string delayed =
      replaced(kChain, "  - second.result -> y\n",
               "  - second.result -> y\n  - {from: second.result, to: first.b, delay: 1}\n");
  EXPECT_EQ(graphErrors(delayed), "");
  const std::string self = replaced(kChain, "  - second.result -> y\n",
                                    "  - second.result -> y\n  - second.result -> second.b\n");
  EXPECT_CONTAINS(graphErrors(self), "instance 'second' feeds itself without a delay");
}

TEST(GraphYaml, UnknownPortsAndInstancesInConnections) {
  EXPECT_CONTAINS(
      graphErrors(replaced(kChain, "first.result -> second.a", "first.output -> second.a")),
      "graph.yaml:14:5: connection source 'first.output': ProbeRelay has no output "
      "'output'; expected one of {result, calls}");
  EXPECT_CONTAINS(
      graphErrors(replaced(kChain, "first.result -> second.a", "third.out -> second.a")),
      "graph.yaml:14:5: connection source 'third.out' names unknown instance 'third'");
  EXPECT_CONTAINS(graphErrors(replaced(kChain, "x -> first.a", "z -> first.a")),
                  "graph.yaml:13:5: connection source 'z' is not a DFPC input");
}

TEST(GraphYaml, DfpcPortsMustBeUsedAndOutputsFedOnce) {
  EXPECT_CONTAINS(graphErrors(replaced(kChain, "  - second.result -> y\n", "")),
                  "graph.yaml:5:12: DFPC output 'y' is not connected; expected a connection");
  EXPECT_CONTAINS(graphErrors(replaced(kChain, "outputs:",
                                       "  - {name: w, type: Double, channel: /in/w}\n"
                                       "outputs:")),
                  "graph.yaml:4:12: DFPC input 'w' feeds nothing");
  EXPECT_CONTAINS(
      graphErrors(replaced(kChain, "type: Double, channel: /in/x", "type: Duoble, channel: /in/x")),
      "graph.yaml:3:12: DFPC input 'x': unknown type 'Duoble'; expected one of {Image,");
  EXPECT_EQ(
      graphErrors(replaced(kChain, "type: Double, channel: /in/x", "type: Duoble, channel: /in/x"))
          .find("type mismatch"),
      std::string::npos);
}

TEST(GraphYaml, StructuralErrorsNameLineAndColumn) {
  EXPECT_CONTAINS(
      graphErrors(replaced(kChain, "    parameters:", "    paramters:")),
      "graph.yaml:11:5: nodes.second.paramters: unknown key; expected one of {dfn, dfi, "
      "parameters, trigger, active_when, diverged_when, budget_s, fallback, on_fault} "
      "(did you mean 'parameters'?)");
  EXPECT_CONTAINS(
      graphErrors(replaced(kChain, "first.result -> second.a", "first.result => second.a")),
      "graph.yaml:14:5: connections.1 = first.result => second.a: expected 'from -> to'");
  EXPECT_CONTAINS(
      graphErrors(replaced(kChain, "  - x -> first.a\n", "  - {from: x, to: first.a, delay: 2}\n")),
      "graph.yaml:13:35: connections.0.delay = 2: out of range; expected an integer in [0, 1]");
  EXPECT_CONTAINS(graphErrors(replaced(kChain, "name: chain", "name: chain\nname: again")),
                  "graph.yaml:");
  EXPECT_CONTAINS(graphErrors("name: broken\nnodes: {a: [1, 2}\n"), "graph.yaml:2:");
  EXPECT_CONTAINS(graphErrors("name: n\n"),
                  "graph.yaml:1:1: nodes: missing; expected its DFN instances");
}

// A pose output's goals: a bound on a statistic within a band of range, checked by campaigns.
TEST(GraphYaml, GoalsAreReadWithTheirBoundAndBand) {
  const std::string goals =
      "  - name: y\n    type: Double\n    goals:\n"
      "      - {quantity: angle_error_deg, below: 0.5, range_m: [0, 5]}\n"
      "      - {quantity: tracked_fraction, at_least: 0.9}\n";
  // on a number: refused, goals are measured against the truth pose
  EXPECT_CONTAINS(graphErrors(replaced(kChain, "  - {name: y, type: Double}\n", goals)),
                  "graph.yaml:8:9: DFPC output 'y' has goals but type Double; expected a pose");
  // the chain's output as a pose, fed by a pose-typed relay, would need other DFNs: the goals
  // are read from the spec here
  const std::string text = replaced(kChain, "  - {name: y, type: Double}\n", goals);
  Result<GraphSpec> spec = parseGraph(text, "graph.yaml");
  ASSERT_OK(spec.status());
  ASSERT_EQ(spec->outputs[0].goals.size(), 2u);
  const GoalSpec& angle = spec->outputs[0].goals[0];
  EXPECT_EQ(angle.quantity, "angle_error_deg");
  EXPECT_DOUBLE_EQ(angle.threshold, 0.5);
  EXPECT_DOUBLE_EQ(angle.max_range_m, 5.0);
  EXPECT_FALSE(angle.atLeast());
  EXPECT_TRUE(spec->outputs[0].goals[1].atLeast());
  EXPECT_CONTAINS(graphErrors(replaced(text, "angle_error_deg,", "angle_eror_deg,")),
                  "graph.yaml:8:20: outputs.0.goals.0.quantity = angle_eror_deg");
  EXPECT_CONTAINS(graphErrors(replaced(text, "at_least: 0.9", "below: 0.9")),
                  "graph.yaml:9:9: outputs.0.goals.1 = {quantity: tracked_fraction, below: 0.9}: "
                  "expected 'at_least' for tracked_fraction (the only bound it takes)");
  EXPECT_CONTAINS(graphErrors(replaced(text, "range_m: [0, 5]", "range_m: [5, 0]")),
                  "expected [min, max] with min < max");
}

TEST(GraphYaml, ParameterErrorsPointIntoTheGraphFile) {
  const std::string e = graphErrors(replaced(kChain, "{offset: 1}", "{offest: 1}"));
  EXPECT_CONTAINS(e,
                  "graph.yaml:11:18: instance 'second' (ProbeRelay/Plain): chain.second: offest: "
                  "unknown key; expected one of {fail_above, duration_s, offset} (did you mean "
                  "'offset'?)");
}

TEST(GraphYaml, ParametersMayComeFromAFileBesideTheGraph) {
  const auto dir = std::filesystem::temp_directory_path() / "cdff_graph_params";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "second.yaml") << "offset: 5\n";
  std::ofstream(dir / "graph.yaml") << replaced(kChain, "{offset: 1}", "second.yaml");
  Result<GraphSpec> spec = loadGraphFile((dir / "graph.yaml").string());
  ASSERT_OK(spec.status());
  EXPECT_EQ(spec->instances[1].parameters["offset"].as<double>(), 5.0);
  std::ofstream(dir / "second.yaml") << "offset: [5\n";
  Result<GraphSpec> bad = loadGraphFile((dir / "graph.yaml").string());
  EXPECT_CONTAINS(bad.status().message(), "second.yaml:");
  EXPECT_CONTAINS(loadGraphFile((dir / "missing.yaml").string()).status().message(),
                  "cannot open DFPC graph file");
}

TEST(GraphYaml, ConditionErrorsPointAtTheCharacter) {
  const std::string bad_syntax = replaced(kChain, "    parameters: {offset: 1}\n",
                                          "    parameters: {offset: 1}\n"
                                          "    active_when: first.result in [1, 2\n");
  EXPECT_CONTAINS(graphErrors(bad_syntax),
                  "graph.yaml:12:39: condition 'first.result in [1, 2': expected ',' or ']', got "
                  "'<end>' (at character 22)");
  const std::string bad_type = replaced(kChain, "    parameters: {offset: 1}\n",
                                        "    parameters: {offset: 1}\n"
                                        "    active_when: first.result in [LOST]\n");
  EXPECT_CONTAINS(graphErrors(bad_type),
                  "'first.result' is a Double; expected a number or unset, "
                  "got 'LOST' (at character 18)");
  const std::string bad_ref = replaced(kChain, "    parameters: {offset: 1}\n",
                                       "    parameters: {offset: 1}\n"
                                       "    active_when: first.value > 3\n");
  EXPECT_CONTAINS(graphErrors(bad_ref), "ProbeRelay has no output 'value'");
}

TEST(GraphYaml, RecoveriesMustNameWhatTheyActOn) {
  auto with = [&](const std::string& extra) {
    return graphErrors(
        replaced(kChain, "    parameters: {offset: 1}\n", "    parameters: {offset: 1}\n" + extra));
  };
  EXPECT_CONTAINS(with("    on_fault: {error: [switch_dfi]}\n"),
                  "recovery 'switch_dfi' on instance 'second', which has no 'fallback'");
  EXPECT_CONTAINS(with("    on_fault: {error: [{wake: first}]}\n"),
                  "recovery 'wake' on instance 'first', which never sleeps");
  EXPECT_CONTAINS(with("    on_fault: {over_budget: [reinitialise]}\n"),
                  "on_fault.over_budget needs budget_s > 0");
  EXPECT_CONTAINS(with("    on_fault: {error: [{reinitialise: nobody}]}\n"),
                  "recovery 'reinitialise' names unknown instance 'nobody'");
  EXPECT_CONTAINS(with("    on_fault: {error: [restart]}\n"),
                  "nodes.second.on_fault.error.0 = restart: expected a recovery: one of "
                  "{reinitialise, wake, switch_dfi, set_track_state}");
  EXPECT_EQ(
      with("    fallback: {dfi: Alternative}\n    budget_s: 0.01\n"
           "    on_fault: {over_budget: [switch_dfi], error: {after: 3, do: [reinitialise]}}\n"),
      "");
}

TEST(GraphYaml, TriggerErrors) {
  auto with = [&](const std::string& trigger) {
    return graphErrors(replaced(kChain, "    parameters: {offset: 1}\n",
                                "    parameters: {offset: 1}\n    trigger: " + trigger + "\n"));
  };
  EXPECT_CONTAINS(with("{on: [c]}"), "trigger port 'c' is not an input of ProbeRelay");
  EXPECT_CONTAINS(with("{on: [a], sync: exact}"), "sync: exact needs at least two ports");
  EXPECT_CONTAINS(with("{on: [a, b], sync: nearest}"), "sync: nearest needs tolerance_s > 0");
  EXPECT_CONTAINS(with("{on: [a, b], sync: exact, tolerance_s: 0.1}"),
                  "trigger.tolerance_s = 0.1: expected no tolerance_s with sync: exact");
  EXPECT_CONTAINS(with("{on: [a], time_input: a, period_s: 1}"),
                  "time_input 'a' has type Double; expected Timestamp");
  EXPECT_EQ(with("{on: [a, b], sync: nearest, tolerance_s: 0.005, queue: 4}"), "");
}

TEST(GraphBuilder, ErrorsPointAtTheCppLine) {
  GraphBuilder g("built");
  g.input("x", "Double", "/in/x");
  g.output("y", "Double");
  g.node("first", "ProbeRelay", "Plain");
  const int line = __LINE__ + 1;
  g.connect("x", "first.b");
  g.connect("first.result", "y");
  std::vector<Status> errors = checkGraph(g.spec());
  ASSERT_FALSE(errors.empty());
  std::string all;
  for (const auto& s : errors) all += s.message() + "\n";
  EXPECT_CONTAINS(all, "required input 'a' (Double) is not connected");
  // The connection itself is fine; the instance line is where node() was called.
  EXPECT_CONTAINS(all, "graph_test.cpp:" + std::to_string(line - 2));
}

TEST(GraphBuilder, BuildsTheSameGraphAsItsYaml) {
  GraphBuilder g("chain");
  g.input("x", "Double", "/in/x");
  g.output("y", "Double");
  g.node("first", "ProbeRelay", "Plain");
  g.node("second", "ProbeRelay", "Plain").parameters("{offset: 1}");
  g.connect("x", "first.a").connect("first.result", "second.a").connect("second.result", "y");
  EXPECT_TRUE(checkGraph(g.spec()).empty());
  Result<GraphSpec> yaml = parseGraph(kChain, "graph.yaml");
  ASSERT_OK(yaml.status());
  EXPECT_EQ(toDot(g.spec()), toDot(*yaml));
  auto dfpc = Dfpc::create(g.spec());
  ASSERT_OK(dfpc.status());
  EXPECT_NE(dfpc.value()->instance("second"), nullptr);
}

TEST(GraphDot, ShowsInstancesPortsDelaysAndConditions) {
  const std::string text =
      replaced(kChain, "  - second.result -> y\n",
               "  - second.result -> y\n  - {from: second.result, to: first.b, delay: 1}\n");
  Result<GraphSpec> spec =
      parseGraph(replaced(text, "    parameters: {offset: 1}\n",
                          "    parameters: {offset: 1}\n    active_when: first.result > 2\n"),
                 "graph.yaml");
  ASSERT_OK(spec.status());
  const std::string dot = toDot(*spec);
  EXPECT_CONTAINS(dot, "digraph \"chain\"");
  EXPECT_CONTAINS(dot, "\"first\" [shape=box, label=\"first\\nProbeRelay/Plain\"]");
  EXPECT_CONTAINS(dot, "\"in:x\" -> \"first\"");
  EXPECT_CONTAINS(dot, "\"second\" -> \"first\" [label=\"result -> b (delay 1)\", style=dashed]");
  EXPECT_CONTAINS(dot, "active when first.result > 2");
}

}  // namespace
}  // namespace cdff::dfpc
