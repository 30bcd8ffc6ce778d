#pragma once
// The description of a DFPC: its DFN instances, their connections, its own inputs and outputs,
// and its control (triggers, synchronisation, conditional activation, faults and recoveries).
//
// A GraphSpec is plain data. It is written in YAML (dfpcs/*.yaml, loadGraphFile; the format is
// in docs/dfpc.md) or in C++ with GraphBuilder; both give the same GraphSpec, and Dfpc::create()
// checks it and makes it run. Every element remembers where it was written (file:line:column, or
// the C++ call site), so that every error points at the line to fix.

#include <map>
#include <memory>
#include <optional>
#include <source_location>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "cdff/schema/override.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/track_state.hpp"

namespace cdff::dfpc {

/// Letters, digits and '_', not starting with a digit: instance, input and output names.
bool isIdentifier(const std::string& s);

/// `instance.port`, or a DFPC input or output when `instance` is empty.
struct PortRef {
  std::string instance;
  std::string port;

  static PortRef parse(const std::string& text);  // "a.b" -> {a, b}; "b" -> {"", b}
  std::string toString() const { return instance.empty() ? port : instance + "." + port; }
  bool isDfpcPort() const { return instance.empty(); }
};

enum class SyncPolicy { kNone, kExact, kNearest };
const char* toString(SyncPolicy policy);

struct TriggerSpec {
  /// Input ports whose arrival runs the instance. When not given: every input fed by a connection
  /// without delay.
  std::vector<std::string> on;
  bool on_given = false;
  /// Also run every period_s of stream time (0: not periodic), writing the tick's time into the
  /// Timestamp input `time_input` when one is named, and only while `tick_when` holds (when set).
  double period_s = 0;
  std::string time_input;
  std::string tick_when;
  /// Synchronisation of the `on` ports: run when each has a message with the same stamp (exact)
  /// or stamps within tolerance_s of the first `on` port's (nearest); queue bounds each port's
  /// waiting messages.
  SyncPolicy sync = SyncPolicy::kNone;
  double tolerance_s = 0;
  int queue = 10;
};

enum class FaultKind { kError, kOverBudget, kDivergence, kNoProduct };
const char* toString(FaultKind kind);

enum class RecoveryActionKind { kReinitialise, kWake, kSwitchDfi, kSetTrackState };
const char* toString(RecoveryActionKind kind);

struct RecoveryAction {
  RecoveryActionKind kind = RecoveryActionKind::kReinitialise;
  /// The instance acted on ("" = the faulty instance), or the track state value to set.
  std::string argument;
  SourceLocation at;
};

struct RecoverySpec {
  /// Act on the after-th fault of this kind: the after-th in a row (a clean call of the
  /// instance resets the count) or, with `within_s`, the after-th within that much stream time
  /// (clean calls do not reset it: an instance whose clean calls come between its faults, such
  /// as a filter's prediction ticks between rejected measurements, can still recover).
  int after = 1;
  double within_s = 0;  // 0: consecutive faults
  std::vector<RecoveryAction> actions;
  SourceLocation at;
};

struct FallbackSpec {
  std::string dfi;
  YAML::Node parameters;  // null: defaults
  std::string parameters_source;
  SourceLocation at;
};

struct InstanceSpec {
  std::string name;
  std::string dfn;
  std::string dfi;
  YAML::Node parameters;          // a map, or null for defaults
  std::string parameters_source;  // where the parameters were written (for error messages)
  TriggerSpec trigger;
  std::string active_when;    // condition; empty: always active
  std::string diverged_when;  // condition evaluated after each call; true is a divergence fault
  double budget_s = 0;        // time budget per call; 0: none
  std::optional<FallbackSpec> fallback;
  std::map<FaultKind, RecoverySpec> on_fault;
  /// Where each field was written: "" (the instance), "dfn", "dfi", "parameters", "trigger",
  /// "on", "time_input", "tick_when", "active_when", "diverged_when", "budget_ms", "fallback".
  std::map<std::string, SourceLocation> where;

  const SourceLocation& at(const std::string& field = "") const;
};

struct ConnectionSpec {
  PortRef from;
  PortRef to;
  int delay = 0;  // 1: the value reaches `to` at the start of the next step
  SourceLocation at;
};

struct DfpcInputSpec {
  std::string name;
  std::string type;       // a port type name, e.g. "PoseWithCovariance"
  std::string channel;    // the stream channel that feeds it
  bool optional = false;  // a run may lack the channel
  /// A configuration that comes once (a sensor's mounting, a calibration): the latest message
  /// that arrives while the DFPC is not running is kept and delivered when it starts, so that a
  /// DFPC started late by a rule has it.
  bool latched = false;
  SourceLocation at;
};

/// A performance goal a DFPC states for a pose output (docs/dfpc.md, "Goals"): the p95 of an
/// error over a run's valid estimates below a bound, or the tracked fraction at least one,
/// applying to runs whose true range stays in a band. Campaigns check them per run, beside the
/// seed's requirements (docs/campaigns.md).
struct GoalSpec {
  /// position_error_m, position_error_pct_range, angle_error_deg (p95, below) or
  /// tracked_fraction (at least).
  std::string quantity;
  double threshold = 0;
  double min_range_m = 0, max_range_m = 1e9;  // the band of true range it applies in
  SourceLocation at;
  bool atLeast() const { return quantity == "tracked_fraction"; }
};

struct DfpcOutputSpec {
  std::string name;
  std::string type;
  std::string channel;      // default /cdff/<dfpc>/<name>
  std::string role;         // "", "target_state", "target_pose", "target_model" (external API)
  std::size_t history = 0;  // samples the Data Product Manager keeps; 0: its default
  double timeout_s = 0;     // no product for this long (stream time) is a fault; 0: no watchdog
  RecoverySpec on_timeout;
  std::vector<GoalSpec> goals;
  SourceLocation at;
};

struct TrackStateSpec {
  PortRef from;  // a TrackState output; empty: only recoveries set the track state
  TrackState initial = TrackState::kUninitialised;
  SourceLocation at;
};

struct GraphSpec {
  std::string name;
  std::string doc;
  std::string source_file;  // "" when built in C++
  std::vector<DfpcInputSpec> inputs;
  std::vector<DfpcOutputSpec> outputs;
  std::vector<InstanceSpec> instances;  // in declaration order
  std::vector<ConnectionSpec> connections;
  std::optional<TrackStateSpec> track_state;
  SourceLocation at;
  std::vector<Status> build_errors;  // what GraphBuilder could not accept (e.g. malformed YAML)

  const InstanceSpec* findInstance(const std::string& name) const;
  const DfpcInputSpec* findInput(const std::string& name) const;
  const DfpcOutputSpec* findOutput(const std::string& name) const;
  /// The channel of an output (its own, or /cdff/<dfpc>/<output>).
  std::string outputChannel(const DfpcOutputSpec& output) const;
};

/// Parses a DFPC graph file. Syntax and structure errors (unknown keys, wrong value types,
/// malformed connections or recoveries) name the file, line and column; the graph's meaning
/// (DFNs, types, cycles...) is checked by checkGraph().
Result<GraphSpec> loadGraphFile(const std::string& path);
Result<GraphSpec> parseGraph(const std::string& yaml_text, const std::string& source_name);

/// A parameter of an instance set from the command line (`cdff run --set`), so that a graph is
/// adapted without copying it: "[DFPC/]NODE.PARAM=VALUE", the value YAML (a nested parameter's
/// key dotted: NODE.PARAM.SUB=VALUE). Without DFPC/ it applies to the one graph with that node.
struct ParameterSetting {
  std::string text;  // as given
  std::string dfpc;  // "" : the graph that has the node
  std::string node;
  schema::Override parameter;  // the key below the instance's parameters
};
Result<ParameterSetting> parseParameterSetting(const std::string& text);

/// loadGraphFile with the settings that address this graph (its name, or any graph with the
/// node when unqualified) applied to its instances' parameters; `applied[i]` is set for each
/// setting applied. An error in a set value names the setting.
Result<GraphSpec> loadGraphFile(const std::string& path,
                                const std::vector<ParameterSetting>& settings,
                                std::vector<bool>& applied);

/// The one graph of `path` with every "[DFPC/]NODE.PARAM=VALUE" setting applied (as `cdff run
/// --set`); a malformed setting, or one that addresses no node of this graph, is an error naming
/// it and the file.
Result<GraphSpec> loadGraphFile(const std::string& path,
                                const std::vector<std::string>& setting_texts);

/// Every problem of a graph, each message starting with its location: unknown DFN or DFI, unknown
/// port, type mismatch, unconnected required input or output, a cycle without a delay, malformed
/// or ill-typed conditions, recoveries naming unknown instances, a switch_dfi without fallback...
/// Empty when the graph is sound. Parameters are checked when the instances are configured
/// (Dfpc::create).
std::vector<Status> checkGraph(const GraphSpec& graph);

/// Graphviz DOT of the graph: instances, DFPC inputs and outputs, connections (delayed ones
/// dashed), conditions and periodic triggers.
std::string toDot(const GraphSpec& graph);

/// Builds a GraphSpec in C++; errors then point at the C++ line that made the element.
///   GraphBuilder g("pose_filtering");
///   g.input("pose", "PoseWithCovariance", "/chaser/pose");
///   g.node("ekf", "EstimationFilter", "ExtendedKalman").parameters("position_sigma: 0.05");
///   g.connect("pose", "ekf.pose_measurement");
///   g.output("state", "RigidBodyState").connect("ekf.state", "state");
///   Result<std::unique_ptr<Dfpc>> dfpc = Dfpc::create(g.spec());
class GraphBuilder {
 public:
  class Node {
   public:
    /// Parameters as inline YAML (a map).
    Node& parameters(const std::string& yaml);
    Node& trigger(TriggerSpec trigger);
    Node& on(std::vector<std::string> ports);
    Node& every(double period_s, std::string time_input = "", std::string tick_when = "");
    Node& sync(SyncPolicy policy, double tolerance_s = 0, int queue = 10);
    Node& activeWhen(std::string condition);
    Node& divergedWhen(std::string condition);
    Node& budget(double seconds);
    Node& fallback(std::string dfi, const std::string& parameters_yaml = "");
    Node& onFault(FaultKind kind, std::vector<RecoveryAction> actions, int after = 1,
                  double within_s = 0);

   private:
    friend class GraphBuilder;
    Node(GraphBuilder& builder, std::size_t index) : builder_(builder), index_(index) {}
    InstanceSpec& spec();
    GraphBuilder& builder_;
    std::size_t index_;
  };

  explicit GraphBuilder(std::string name,
                        std::source_location where = std::source_location::current());

  GraphBuilder& input(std::string name, std::string type, std::string channel,
                      std::source_location where = std::source_location::current());
  GraphBuilder& output(std::string name, std::string type, std::string channel = "",
                       std::string role = "",
                       std::source_location where = std::source_location::current());
  GraphBuilder& outputWatchdog(const std::string& output, double timeout_s,
                               std::vector<RecoveryAction> actions);
  Node node(std::string name, std::string dfn, std::string dfi,
            std::source_location where = std::source_location::current());
  GraphBuilder& connect(const std::string& from, const std::string& to, int delay = 0,
                        std::source_location where = std::source_location::current());
  GraphBuilder& trackState(const std::string& from, TrackState initial = TrackState::kUninitialised,
                           std::source_location where = std::source_location::current());

  const GraphSpec& spec() const { return spec_; }

 private:
  GraphSpec spec_;
};

}  // namespace cdff::dfpc
