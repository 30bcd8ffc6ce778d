#pragma once
// A DFPC that runs: the graph of a GraphSpec, instantiated, with its control flow.
//
// The Orchestrator owns DFPCs and feeds them; a Dfpc does the work of one step:
//  - deliver() hands a message to one of the DFPC's inputs; the instances it triggers run in
//    topological order, each at most once per step, and their new outputs flow along the
//    connections (those with a delay reach their target at the start of the next step);
//  - advanceTo() moves stream time: periodic triggers fire, synchronised inputs that can no
//    longer get a better partner resolve, no-product watchdogs check their outputs;
//  - faults are detected after every call (error status, over budget, divergence) and by the
//    watchdogs, and the recoveries the graph configures are applied; every fault, recovery,
//    activation change and lifecycle change is an Event for the observer.
// Not thread-safe: one thread drives a Dfpc (the Orchestrator serialises access).

#include <array>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "cdff/dfn/node.hpp"
#include "cdff/dfpc/clock.hpp"
#include "cdff/dfpc/condition.hpp"
#include "cdff/dfpc/graph.hpp"
#include "cdff/dfpc/stream.hpp"

namespace cdff::dfpc {

enum class DfpcState { kInitialised, kRunning, kStopped };
const char* toString(DfpcState state);

struct InstanceStatus {
  std::string name, dfn, dfi;
  bool active = true;        // false while asleep (active_when does not hold)
  bool on_fallback = false;  // switched to its fallback DFI by a recovery
  std::uint64_t calls = 0;   // process() calls since the instance was (re)created
  std::uint64_t errors = 0;
  std::uint64_t faults = 0;   // all kinds, since the DFPC was initialised
  std::uint64_t skipped = 0;  // triggers ignored while asleep
  std::uint64_t sync_dropped = 0;
  double mean_wall_s = 0, max_wall_s = 0;
  std::string last_error;
};

struct DfpcStatus {
  std::string name;
  DfpcState state = DfpcState::kInitialised;
  std::optional<TrackState> track_state;  // none when the graph declares no track state
  Timestamp stream_time = 0;              // the latest stream time the DFPC has seen
  std::optional<Timestamp> last_product;  // stream time of its latest product
  std::uint64_t messages = 0;             // messages delivered while running
  std::uint64_t ignored_messages = 0;     // messages that arrived while not running
  std::uint64_t products = 0;
  std::uint64_t faults = 0, recoveries = 0;
  std::string last_fault;  // "" when none
  std::vector<InstanceStatus> instances;
};

class Dfpc;

/// Receives what a running DFPC produces (the Orchestrator implements it).
class DfpcObserver {
 public:
  virtual ~DfpcObserver() = default;
  /// A new value on DFPC output `output` (index into spec().outputs).
  virtual void onProduct(const Dfpc& dfpc, std::size_t output, Timestamp stamp,
                         const Value& value) = 0;
  virtual void onEvent(const Event& event) = 0;
  /// One DFN call; only when timing is enabled.
  virtual void onTiming(const TimingRecord& timing) = 0;
};

class Dfpc {
 public:
  /// Checks the graph (checkGraph) and creates and configures every instance; an error lists
  /// every problem found, one per line, each with its location. The DFPC starts initialised.
  static Result<std::unique_ptr<Dfpc>> create(GraphSpec spec);
  ~Dfpc();
  Dfpc(const Dfpc&) = delete;
  Dfpc& operator=(const Dfpc&) = delete;

  const std::string& name() const { return spec_.name; }
  const GraphSpec& spec() const { return spec_; }
  DfpcState state() const { return state_; }

  void setObserver(DfpcObserver* observer) { observer_ = observer; }
  /// The clock that times calls against their budgets; nullptr (default): the wall time that
  /// each DFN's diagnostics measure.
  void setExecutionClock(Clock* clock) { execution_clock_ = clock; }
  void setTimingEnabled(bool enabled) { timing_enabled_ = enabled; }

  // Life cycle. Events are stamped with the latest stream time seen.
  /// Fresh instances (internal states cleared), queues and track state cleared; any state ->
  /// initialised, except running (stop first).
  Status init();
  /// initialised or stopped -> running; `now`, when given, is the stream time of the start (its
  /// event's stamp: a stopped DFPC's own time stood still).
  Status start(std::optional<Timestamp> now = std::nullopt);
  /// running -> stopped: messages are then ignored (and counted); instances keep their state.
  Status stop();
  /// As init(), keeping the DFPC running if it was.
  Status reset();

  /// Index of a DFPC input by name.
  std::optional<std::size_t> inputIndex(const std::string& input) const;
  /// One message for DFPC input `input`; runs the step. An error only when the message does not
  /// fit the input (its type); DFN faults are events, not errors.
  Status deliver(std::size_t input, const Message& message);
  /// Moves stream time to t (periodic triggers, synchronisation, watchdogs).
  void advanceTo(Timestamp t);
  /// End of the stream: resolves what synchronised inputs still hold.
  void finish();

  DfpcStatus status() const;
  TrackState trackState() const { return track_state_; }
  /// An instance by name (nullptr if none); it changes when a recovery re-creates it.
  dfn::Node* instance(const std::string& name) const;

 private:
  struct Edge {
    std::size_t node;
    std::size_t input;
    bool delayed;
  };
  struct OutputSlot {
    std::vector<Edge> edges;
    std::vector<std::size_t> dfpc_outputs;
    bool feeds_track_state = false;
  };
  struct InputSlot {
    bool trigger = false;
    int sync = -1;  // index into Instance::queues, -1 when not synchronised
  };
  struct SyncEntry {
    Timestamp stamp;
    Value value;
  };
  struct BoundCondition {
    Condition condition;
    std::vector<std::pair<int, int>> refs;  // (instance, output) per ref; (-1, -1): track_state
  };
  struct Instance {
    const InstanceSpec* spec = nullptr;
    std::unique_ptr<dfn::Node> node;
    std::string dfi;
    bool on_fallback = false;
    std::vector<InputSlot> inputs;
    std::vector<OutputSlot> outputs;
    std::vector<const void*> before;  // output values before a call
    std::optional<BoundCondition> active_when, diverged_when, tick_when;
    bool active = true;
    bool woken = false;
    Timestamp period = 0;
    Timestamp next_tick = 0;
    int time_input = -1;
    std::vector<std::size_t> sync_inputs;  // node input index per queue; [0] is the pivot
    std::vector<std::deque<SyncEntry>> queues;
    Timestamp tolerance = 0;
    std::size_t queue_limit = 10;
    bool sync_loaded = false;  // a match is on the ports, waiting to run
    bool pending = false;
    Timestamp pending_stamp = 0;
    std::array<int, 4> consecutive{};             // consecutive faults per FaultKind
    std::array<std::deque<Timestamp>, 4> recent;  // per FaultKind, for a recovery's within_s
    std::uint64_t warnings_seen = 0;
    std::uint64_t faults = 0, skipped = 0, sync_dropped = 0;
  };
  struct DelayedValue {
    Edge edge;
    Value value;
    Timestamp stamp;
  };
  struct OutputState {
    TypeId type;
    Timestamp watch_since = 0;
  };

  explicit Dfpc(GraphSpec spec);
  Status build();
  Result<std::vector<std::size_t>> executionOrder() const;
  Status createInstances(const std::vector<std::size_t>& order);
  /// Wires connections into instance slots; returns, per instance input, whether a connection
  /// without delay feeds it (such inputs trigger by default).
  std::vector<std::vector<bool>> connectPorts();
  void configureTriggers(const std::vector<std::vector<bool>>& fed_without_delay);
  Status bindConditions();
  Status createNode(Instance& inst, const std::string& dfi, const YAML::Node& parameters,
                    const std::string& source, std::unique_ptr<dfn::Node>& out) const;
  Result<BoundCondition> bindCondition(const std::string& text, const SourceLocation& at) const;
  bool evaluate(const BoundCondition& c) const;
  void clearRuntime();

  void beginStep(Timestamp t);
  void writeInput(const Edge& e, const Value& value, Timestamp stamp);
  void markPending(std::size_t n, Timestamp stamp);
  void runPending();
  void runNode(std::size_t n);
  /// Evaluates an instance's active_when (reporting a change); false when it sleeps.
  bool updateActivation(Instance& inst);
  /// The run's timing record and the DFN's new warnings.
  void reportRun(Instance& inst, Timestamp stamp, double wall_s, StatusCode code);
  /// Passes the outputs the run set to their connections, the DFPC outputs and the track state.
  void passOutputs(Instance& inst, Timestamp stamp);
  void pushSync(std::size_t n, int queue, const Value& value, Timestamp stamp);
  void trySync(std::size_t n, Timestamp now, bool final);
  void dropSync(std::size_t n, int queue, Timestamp stamp, const char* why);

  void fault(std::optional<std::size_t> n, FaultKind kind, const std::string& message,
             const RecoverySpec* recovery);
  void recover(const RecoverySpec& recovery, std::optional<std::size_t> faulty);
  bool recreate(std::size_t n, bool fallback, std::string& why);
  void setTrackState(TrackState value);
  void emit(EventType type, const std::string& instance, std::string message);

  GraphSpec spec_;
  DfpcState state_ = DfpcState::kInitialised;
  DfpcObserver* observer_ = nullptr;
  Clock* execution_clock_ = nullptr;
  bool timing_enabled_ = true;

  std::vector<Instance> instances_;  // topological order
  std::unordered_map<std::string, std::size_t> index_;
  std::vector<std::vector<Edge>> input_edges_;  // per DFPC input
  std::vector<TypeId> input_types_;
  std::vector<OutputState> outputs_;
  std::optional<std::pair<std::size_t, std::size_t>> track_state_source_;

  std::size_t first_pending_ = 0;
  std::vector<DelayedValue> delayed_, delayed_next_;
  bool has_periodic_ = false, has_sync_ = false, has_watchdog_ = false;
  bool started_ = false;  // stream time has started (first advanceTo since init)
  Timestamp step_stamp_ = 0;
  Timestamp stream_time_ = 0;
  TrackState track_state_ = TrackState::kUninitialised;
  std::optional<Timestamp> last_product_;
  /// Per input: the latest message of a latched input that came while not running.
  std::vector<std::optional<Message>> latched_;
  std::uint64_t messages_ = 0, ignored_ = 0, products_ = 0, faults_ = 0, recoveries_ = 0;
  std::string last_fault_;
};

}  // namespace cdff::dfpc
