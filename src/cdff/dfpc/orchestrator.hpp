#pragma once
// The Orchestrator (seed §4.1, §7.2.2.2): owns the DFPCs of a run, drives their life cycle,
// feeds them their input streams in timestamp order, publishes their products to the Data
// Product Manager and the Sink, routes products to the DFPCs that consume them, and records
// every event (faults and recoveries included) and every DFN call's timing in the Sink.
//
// Stream time is global: every message moves every running DFPC to its stamp (so that periodic
// triggers and no-product watchdogs fire even for a DFPC whose own inputs have gone silent).
// Thread-safe: one mutex serialises processing, life-cycle changes and status queries, so the
// external API can query and control DFPCs while another thread feeds them.

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "cdff/dfpc/clock.hpp"
#include "cdff/dfpc/condition.hpp"
#include "cdff/dfpc/data_product_manager.hpp"
#include "cdff/dfpc/dfpc.hpp"
#include "cdff/dfpc/stream.hpp"

namespace cdff::dfpc {

/// Whether `channel` is one of a passthrough entry's: `pattern` is a prefix, or a shell pattern
/// (fnmatch(3), '*' matching '/' too) when it holds * ? or [.
bool matchesChannelPattern(const std::string& channel, const std::string& pattern);

struct OrchestratorOptions {
  Sink* sink = nullptr;  // where products, events and timings go (none: they are not recorded)
  std::shared_ptr<DataProductManager> products;  // shared with other users; created when null
  Clock* execution_clock = nullptr;  // times DFN calls against budgets (null: DFN diagnostics)
  bool record_timing = true;         // one TimingRecord per DFN call to the sink
  /// Input channels copied to the sink unchanged: by prefix (e.g. "/truth/" for ground truth),
  /// or by a shell pattern where the entry has * ? or [ (fnmatch(3); * also matches '/').
  std::vector<std::string> passthrough_prefixes;
};

struct RunProgress {
  std::uint64_t messages = 0;
  Timestamp stamp = 0;
  std::optional<std::pair<Timestamp, Timestamp>> range;  // when the input knows it
  /// In [0, 1], or a negative value when the range is unknown.
  double fraction() const;
};

struct RunOptions {
  /// Pace the replay so that stream time advances like the clock (times `speed`).
  bool realtime = false;
  double speed = 1.0;
  Clock* clock = nullptr;                            // pacing clock; the steady clock when null
  std::function<void(const RunProgress&)> progress;  // after each message
  const std::atomic<bool>* cancel = nullptr;         // stops the run when set
  /// The end of the input (or a cancel) stops the running DFPCs, so that the recording ends
  /// with their "stopped" events; false leaves them running for more input.
  bool stop_at_end = true;
};

struct RunSummary {
  std::uint64_t messages = 0;        // read from the input
  std::uint64_t routed = 0;          // delivered to at least one DFPC input
  std::uint64_t passed_through = 0;  // copied to the sink
  std::uint64_t products = 0, events = 0, faults = 0, recoveries = 0;
  std::optional<Timestamp> first, last;  // stamps of the first and last message
  bool cancelled = false;
};

/// Runs one DFPC only while a condition holds: the seed's Figure 5 (detection running while a
/// tracker is UNINITIALISED or LOST, stopped while it tracks) and Table 1's hand-overs by range
/// and track state. Two forms:
///  - "DFPC=TRACKER:STATE[,STATE...]": while TRACKER's track state is one of the states;
///  - "DFPC: CONDITION": while CONDITION holds, written in the conditions' language
///    (condition.hpp) over the loaded DFPCs: `X.track_state` (X's track state), `X.range` (the
///    distance to the target that X estimates: the position's norm of its latest target_state or
///    target_pose product, or its Bearing product's range; unset when X has none, or none
///    younger than the output's timeout) and `X.OUTPUT` (the latest value of X's product), e.g.
///    "visual_tracking: lidar_tracking.track_state == TRACKING and lidar_tracking.range < 5".
struct ActivationRule {
  std::string dfpc;                // the DFPC started and stopped
  std::string tracker;             // the first form: the DFPC whose track state decides
  std::vector<TrackState> states;  // the first form: `dfpc` runs while the tracker is in one
  std::string condition;           // the second form's CONDITION (empty for the first form)
};

/// Parses either form (see ActivationRule); the condition's syntax is checked here, its names
/// when the rule is added to an Orchestrator.
Result<ActivationRule> parseActivationRule(const std::string& text);

class Orchestrator final : private DfpcObserver {
 public:
  explicit Orchestrator(OrchestratorOptions options = {});
  ~Orchestrator() override;
  Orchestrator(const Orchestrator&) = delete;
  Orchestrator& operator=(const Orchestrator&) = delete;

  /// Takes a DFPC (initialised, not started). Names must be unique.
  Status add(std::unique_ptr<Dfpc> dfpc);
  /// Loads, checks and adds the graph of a YAML file.
  Status addGraphFile(const std::string& path);

  std::vector<std::string> dfpcNames() const;
  bool contains(const std::string& dfpc) const;

  // Life cycle of one DFPC (see Dfpc) or of all of them.
  Status init(const std::string& dfpc);
  Status start(const std::string& dfpc);
  Status stop(const std::string& dfpc);
  Status reset(const std::string& dfpc);
  Status initAll();
  Status startAll();
  Status stopAll();  // stops the running ones
  Status resetAll();

  /// Adds a rule: before every message, `rule.dfpc` is started when the rule holds and stopped
  /// otherwise, with an `activated` or `deactivated` event (the DFPC as a whole) that gives the
  /// values the rule read. A DFPC that a caller stopped is not restarted by its rule. One rule
  /// per DFPC; every DFPC it names loaded; a followed track state declared by its graph; a
  /// condition's refs naming a DFPC's track_state, range or output, compared as its type allows.
  Status runWhile(ActivationRule rule);

  /// Every DFPC input (not optional) has its channel among `available`, or among the loaded
  /// DFPCs' outputs, with its type.
  Status checkChannels(const std::vector<ChannelInfo>& available) const;

  /// One message: moves stream time, copies it through when its channel is a passthrough, and
  /// delivers it (and the products it leads to, to their consumers). An error when a message
  /// does not fit the input it is routed to, or when the sink failed.
  Status process(const Message& message);
  /// End of the input: lets synchronised inputs resolve what they still hold.
  Status finish();
  /// Runs `input` to its end through process() and finish(), stops the DFPCs (unless
  /// `options.stop_at_end` is false), then flushes the sink.
  Result<RunSummary> run(InputStream& input, const RunOptions& options = {});

  Result<DfpcStatus> status(const std::string& dfpc) const;
  std::vector<DfpcStatus> statuses() const;

  DataProductManager& products() { return *products_; }
  const std::shared_ptr<DataProductManager>& sharedProducts() const { return products_; }
  /// The DPM name of a DFPC output: "<dfpc>/<output>".
  static std::string productName(const std::string& dfpc, const std::string& output);
  /// The DPM names of the outputs with a role ("target_state"...), in DFPC order; `dfpc`
  /// restricts the search to one DFPC.
  std::vector<std::string> productsWithRole(const std::string& role,
                                            const std::string& dfpc = "") const;
  /// The inputs of `dfpc` as its graph declares them (empty when there is no such DFPC).
  std::vector<DfpcInputSpec> inputsOf(const std::string& dfpc) const;
  /// The first output of `dfpc` whose type is one of `types` (by name), as a DPM name.
  std::optional<std::string> productOfType(const std::string& dfpc,
                                           const std::vector<std::string>& types) const;

 private:
  struct Route {
    Dfpc* dfpc;
    std::size_t input;
  };
  struct OutputBinding {
    std::string product;        // DPM name
    Message message;            // channel set once; stamp and value per product
    std::vector<Route> routes;  // DFPC inputs that consume this channel
  };
  struct Entry {
    std::unique_ptr<Dfpc> dfpc;
    std::vector<OutputBinding> outputs;
  };

  void onProduct(const Dfpc& dfpc, std::size_t output, Timestamp stamp,
                 const Value& value) override;
  void onEvent(const Event& event) override;
  void onTiming(const TimingRecord& timing) override;

  Entry* find(const std::string& dfpc);
  const Entry* find(const std::string& dfpc) const;
  Status unknown(const std::string& dfpc) const;
  void rebuildRoutes();
  Status deliverLocked(const Message& message, bool external);
  Status applyActivationRules(Timestamp stamp);
  void recordSinkError(const Status& status);

  OrchestratorOptions options_;
  std::shared_ptr<DataProductManager> products_;
  mutable std::mutex mutex_;
  std::vector<Entry> entries_;
  std::unordered_map<std::string, std::vector<Route>> routes_;  // channel -> DFPC inputs
  std::vector<Message> internal_;  // products waiting to be routed within this step
  /// What a condition's ref reads: a DFPC's track state, its range, or one of its products.
  struct RuleRef {
    enum class Kind { kTrackState, kRange, kProduct } kind = Kind::kProduct;
    const Entry* entry = nullptr;
    std::size_t output = 0;  // kRange: the output it is computed from; kProduct: the product
    TypeId type;             // the value's
    double range = 0;        // kRange: the value of the last evaluation
    TrackState track_state = TrackState::kUninitialised;  // kTrackState: the same
    Value held;  // kProduct: the value of the last evaluation
  };
  struct RuleState {
    ActivationRule rule;
    Dfpc* dfpc;                          // rule.dfpc, resolved once (DFPCs are never removed)
    const Dfpc* tracker;                 // rule.tracker (the first form)
    std::optional<Condition> condition;  // the second form, bound
    std::vector<RuleRef> refs;           // condition->refs()[i] reads refs[i]
    bool stopped_by_rule = false;        // a DFPC stopped by a caller stays stopped
  };
  Result<RuleRef> bindRuleRef(const Condition::Ref& ref, TypeId& type) const;
  Status bindCondition(RuleState& rule) const;
  /// Whether the rule holds at `stamp`, and the values it read, for the event's message.
  bool ruleHolds(RuleState& rule, Timestamp stamp, std::string& why) const;
  const void* ruleValue(RuleRef& ref, Timestamp stamp) const;
  std::vector<RuleState> activation_rules_;
  Status sink_status_;
  RunSummary counters_;
};

}  // namespace cdff::dfpc
