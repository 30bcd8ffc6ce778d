#pragma once
// What flows into and out of the Orchestrator, independent of any file format.
//
// Input: an InputStream yields timestamped, type-erased Messages in timestamp order (a recording,
// several merged, or a live queue fed by sensor threads). Output: a Sink receives products and
// copied-through input messages (both Messages), Events (faults, recoveries, state changes) and
// per-call TimingRecords. The recording library implements both interfaces for MCAP files;
// MemoryStream, LiveStream and MemorySink here serve tests and live use.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"
#include "cdff/types/type_registry.hpp"
#include "cdff/types/value.hpp"

namespace cdff::dfpc {

struct Message {
  std::string
      channel;  // e.g. /chaser/camera_left/image, /truth/target_pose, /cdff/<dfpc>/<product>
  Timestamp stamp = 0;  // stream time of the data
  Value value;

  TypeId type() const { return value.type(); }

  template <RegisteredType T>
  static Message of(std::string channel, Timestamp stamp, std::shared_ptr<const T> value) {
    return {std::move(channel), stamp, Value::of<T>(std::move(value))};
  }
  template <RegisteredType T>
  static Message of(std::string channel, Timestamp stamp, T value) {
    return of<T>(std::move(channel), stamp, std::make_shared<const T>(std::move(value)));
  }
  /// The value as a T, or nullptr when it is of another type.
  template <RegisteredType T>
  const T* as() const {
    return value.get<T>();
  }
};

struct ChannelInfo {
  std::string channel;
  TypeId type;
  std::uint64_t message_count = 0;  // 0 when unknown
};

class InputStream {
 public:
  virtual ~InputStream() = default;
  /// The next message (non-decreasing stamps), std::nullopt at the end, or an error (e.g. a
  /// truncated recording: the error says where).
  virtual Result<std::optional<Message>> next() = 0;
  /// The channels the stream will deliver, when known in advance (recordings); empty otherwise.
  virtual std::vector<ChannelInfo> channels() const { return {}; }
  /// First and last stamps, when known in advance (for progress).
  virtual std::optional<std::pair<Timestamp, Timestamp>> timeRange() const { return std::nullopt; }
};

/// Messages held in memory, delivered in timestamp order (a stable sort keeps the order of equal
/// stamps).
class MemoryStream final : public InputStream {
 public:
  MemoryStream() = default;
  explicit MemoryStream(std::vector<Message> messages);
  void add(Message message);  // before the first next()

  Result<std::optional<Message>> next() override;
  std::vector<ChannelInfo> channels() const override;
  std::optional<std::pair<Timestamp, Timestamp>> timeRange() const override;

 private:
  void sortIfNeeded();
  std::vector<Message> messages_;
  std::size_t position_ = 0;
  bool sorted_ = true;
};

/// Several streams merged by timestamp; equal stamps keep the order of the streams as given.
class MergedStream final : public InputStream {
 public:
  explicit MergedStream(std::vector<std::unique_ptr<InputStream>> inputs);

  Result<std::optional<Message>> next() override;
  std::vector<ChannelInfo> channels() const override;
  std::optional<std::pair<Timestamp, Timestamp>> timeRange() const override;

 private:
  std::vector<std::unique_ptr<InputStream>> inputs_;
  std::vector<std::optional<Message>> heads_;
  bool primed_ = false;
};

/// A live input: producer threads push(), the Orchestrator's thread blocks in next() until a
/// message arrives or close() is called. Bounded: when full, the oldest message is dropped and
/// counted (a live system must not stall its sensors; a recording is never read this way).
class LiveStream final : public InputStream {
 public:
  explicit LiveStream(std::size_t capacity = 1024);

  /// Queues a message; an error after close().
  Status push(Message message);
  /// Ends the stream: next() returns std::nullopt once the queue is empty.
  void close();
  Result<std::optional<Message>> next() override;

  std::uint64_t dropped() const;
  std::size_t queued() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable arrived_;
  std::deque<Message> queue_;
  std::size_t capacity_;
  std::uint64_t dropped_ = 0;
  bool closed_ = false;
};

// ---------------------------------------------------------------------------------------------
// Output

enum class EventKind { kLifecycle, kFault, kRecovery, kActivation, kWarning };

enum class EventType {
  // lifecycle
  kInitialised,        // a DFPC's instances were (re)created and configured
  kStarted,            // a DFPC started consuming its inputs
  kStopped,            // a DFPC stopped consuming its inputs
  kReset,              // a DFPC was re-initialised by request
  kTrackStateChanged,  // the DFPC's track state took a new value (message: "OLD -> NEW")
  // faults (detected by the Orchestrator, reported by a DFN)
  kDfnError,    // process() returned an error
  kOverBudget,  // a call took longer than the instance's budget
  kDivergence,  // the instance's divergence condition held after a call
  kNoProduct,   // a DFPC output produced nothing for longer than its timeout (stream time)
  // recoveries
  kReinitialise,    // an instance was re-created and re-configured (internal state cleared)
  kWake,            // a sleeping instance was woken
  kSwitchDfi,       // an instance was replaced by its fallback DFI
  kSetTrackState,   // a recovery set the track state
  kRecoveryFailed,  // a recovery action could not be applied
  // activation
  kActivated,    // a conditional instance became active (its condition holds)
  kDeactivated,  // a conditional instance was put to sleep
  // warnings
  kSyncDropped,    // a synchronised input dropped a message (queue full, or no partner in time)
  kDfnWarning,     // a DFN recorded a warning during a call
  kInputRejected,  // a message did not fit the DFPC input it was routed to
  kInputLost,      // a live input's publisher left (`cdff node`: nothing more comes from it)
};

const char* toString(EventKind kind);
const char* toString(EventType type);
EventKind kindOf(EventType type);

struct Event {
  Timestamp stamp = 0;  // stream time at which it happened
  EventType type = EventType::kInitialised;
  std::string dfpc;
  std::string instance;  // the DFN instance concerned, "" for the DFPC as a whole
  std::string message;   // what happened, with values

  EventKind kind() const { return kindOf(type); }
};

/// One DFN call. The string views are valid during the Sink call only; copy them to keep them.
struct TimingRecord {
  Timestamp stamp = 0;  // stream time of the step that made the call
  std::string_view dfpc;
  std::string_view instance;
  std::string_view dfn;
  std::string_view dfi;
  double wall_s = 0;  // on the execution clock (the steady clock unless a test injects another)
  double cpu_s = 0;   // thread CPU time (the DFN's diagnostics)
  StatusCode status = StatusCode::kOk;
};

/// Where a run's results go. Calls come from the Orchestrator's thread, one at a time. An error
/// stops the run (a result that cannot be written is not silently lost).
class Sink {
 public:
  virtual ~Sink() = default;
  /// A DFPC product (channel /cdff/<dfpc>/<output>) or an input message copied through.
  virtual Status writeMessage(const Message& message) = 0;
  virtual Status writeEvent(const Event& event) = 0;
  virtual Status writeTiming(const TimingRecord& timing) = 0;
  virtual Status flush() { return Status::ok(); }
};

/// The JSON encodings that recordings use for events and timing records (docs/dfpc.md).
std::string toJson(const Event& event);
std::string toJson(const TimingRecord& timing);

/// Keeps everything in memory; thread-safe (tests read it while a run goes on).
class MemorySink final : public Sink {
 public:
  struct Timing {
    Timestamp stamp = 0;
    std::string dfpc, instance, dfn, dfi;
    double wall_s = 0, cpu_s = 0;
    StatusCode status = StatusCode::kOk;
  };

  Status writeMessage(const Message& message) override;
  Status writeEvent(const Event& event) override;
  Status writeTiming(const TimingRecord& timing) override;

  std::vector<Message> messages() const;
  std::vector<Message> messages(const std::string& channel) const;
  std::vector<Event> events() const;
  std::vector<Event> events(EventType type) const;
  std::vector<Timing> timings() const;

 private:
  mutable std::mutex mutex_;
  std::vector<Message> messages_;
  std::vector<Event> events_;
  std::vector<Timing> timings_;
};

}  // namespace cdff::dfpc
