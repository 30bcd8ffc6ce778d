#pragma once
// Clocks: where the Orchestrator and the external API read "now" and wait.
//
// Two times matter to a DFPC run. *Stream time* is the timestamps of the data (a recording's or a
// live sensor's); periodic triggers, synchronisation and the no-product watchdog use it and never
// read a clock. *Clock time* is read from a Clock: it paces a real-time replay, drives the
// external API's subscriptions and measures DFN calls against their time budgets. Every use of
// clock time goes through this interface, so that tests run on a SimulatedClock and are exact.

#include <condition_variable>
#include <cstdint>
#include <limits>
#include <mutex>
#include <set>
#include <utility>

#include "cdff/types/time.hpp"

namespace cdff::dfpc {

/// A far-future time: sleeping until it means "until interrupted".
constexpr Timestamp kForever = std::numeric_limits<Timestamp>::max();

class Clock {
 public:
  virtual ~Clock() = default;
  /// Microseconds since the clock's epoch.
  virtual Timestamp now() const = 0;
  /// How many times interrupt() has been called.
  virtual std::uint64_t interrupts() const = 0;
  /// Blocks until now() >= t, or until interrupts() differs from `since` (returns at once if it
  /// already does: read interrupts() before deciding to sleep, and no interrupt is missed).
  /// Returns true when t was reached.
  virtual bool sleepUntil(Timestamp t, std::uint64_t since) = 0;
  bool sleepUntil(Timestamp t) { return sleepUntil(t, interrupts()); }
  /// Wakes every thread sleeping in sleepUntil() early (it returns false and re-checks its work).
  virtual void interrupt() = 0;
};

/// The monotonic system clock (std::chrono::steady_clock).
class SteadyClock final : public Clock {
 public:
  Timestamp now() const override;
  std::uint64_t interrupts() const override;
  using Clock::sleepUntil;
  bool sleepUntil(Timestamp t, std::uint64_t since) override;
  void interrupt() override;

 private:
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::uint64_t interrupts_ = 0;
};

/// A clock that only moves when told to.
///
/// In manual mode (the default) another thread moves it with advanceTo(); sleepers wake when their
/// time comes. Threads that sleep on the clock register as participants; advanceTo() returns only
/// once every participant has done the work that was due and is asleep again waiting for a later
/// time, so a test that advances the clock sees every effect of that time before it goes on.
///
/// In auto-advance mode sleepUntil(t) itself moves the clock to t and returns at once: a real-time
/// replay then runs as fast as possible while its pacing can still be checked. Sleeping until
/// kForever still blocks until interrupt().
class SimulatedClock final : public Clock {
 public:
  enum class Mode { kManual, kAutoAdvance };
  explicit SimulatedClock(Timestamp start = 0, Mode mode = Mode::kManual);

  Timestamp now() const override;
  std::uint64_t interrupts() const override;
  using Clock::sleepUntil;
  bool sleepUntil(Timestamp t, std::uint64_t since) override;
  void interrupt() override;

  /// Moves the clock forward to t (never backwards) and waits for the participants (see above).
  void advanceTo(Timestamp t);
  void advanceBy(Timestamp dt);

  /// A thread that sleeps on this clock calls addParticipant() before it first sleeps (or its
  /// creator does, before starting it) and removeParticipant() when it ends.
  void addParticipant();
  void removeParticipant();

 private:
  bool participantsSettled() const;

  mutable std::mutex mutex_;
  std::condition_variable wake_;     // sleepers wait on it
  std::condition_variable settled_;  // advanceTo() waits on it
  Timestamp now_;
  Mode mode_;
  int participants_ = 0;
  // Each sleeping thread: its deadline and the interrupt count it sleeps on (an interrupted
  // sleeper is about to wake even before it has left the set).
  std::multiset<std::pair<Timestamp, std::uint64_t>> sleepers_;
  std::uint64_t interrupts_ = 0;
};

}  // namespace cdff::dfpc
