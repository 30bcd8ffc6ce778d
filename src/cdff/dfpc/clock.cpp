#include "cdff/dfpc/clock.hpp"

#include <chrono>

namespace cdff::dfpc {

namespace {
std::chrono::steady_clock::time_point toTimePoint(Timestamp t) {
  return std::chrono::steady_clock::time_point(std::chrono::microseconds(t));
}
}  // namespace

Timestamp SteadyClock::now() const {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::uint64_t SteadyClock::interrupts() const {
  std::lock_guard lock(mutex_);
  return interrupts_;
}

bool SteadyClock::sleepUntil(Timestamp t, std::uint64_t since) {
  std::unique_lock lock(mutex_);
  while (now() < t) {
    if (interrupts_ != since) return false;
    if (t == kForever)
      wake_.wait(lock);
    else
      wake_.wait_until(lock, toTimePoint(t));
  }
  return true;
}

void SteadyClock::interrupt() {
  {
    std::lock_guard lock(mutex_);
    ++interrupts_;
  }
  wake_.notify_all();
}

SimulatedClock::SimulatedClock(Timestamp start, Mode mode) : now_(start), mode_(mode) {}

Timestamp SimulatedClock::now() const {
  std::lock_guard lock(mutex_);
  return now_;
}

std::uint64_t SimulatedClock::interrupts() const {
  std::lock_guard lock(mutex_);
  return interrupts_;
}

bool SimulatedClock::sleepUntil(Timestamp t, std::uint64_t since) {
  std::unique_lock lock(mutex_);
  if (mode_ == Mode::kAutoAdvance && t != kForever) {
    if (t > now_) now_ = t;
    return true;
  }
  if (now_ >= t) return true;
  if (interrupts_ != since) return false;
  auto entry = sleepers_.insert({t, since});
  settled_.notify_all();
  wake_.wait(lock, [&] { return now_ >= t || interrupts_ != since; });
  sleepers_.erase(entry);
  return now_ >= t;
}

void SimulatedClock::interrupt() {
  {
    std::lock_guard lock(mutex_);
    ++interrupts_;
  }
  wake_.notify_all();
  settled_.notify_all();
}

bool SimulatedClock::participantsSettled() const {
  // Every participant sleeps, none of them is due, and none has been interrupted (it would be
  // about to wake and work).
  int waiting_for_later = 0;
  for (const auto& [deadline, since] : sleepers_)
    if (deadline > now_ && since == interrupts_) ++waiting_for_later;
  return waiting_for_later >= participants_;
}

void SimulatedClock::advanceTo(Timestamp t) {
  std::unique_lock lock(mutex_);
  if (t > now_) now_ = t;
  wake_.notify_all();
  settled_.wait(lock, [&] { return participantsSettled(); });
}

void SimulatedClock::advanceBy(Timestamp dt) {
  Timestamp target;
  {
    std::lock_guard lock(mutex_);
    target = now_ + dt;
  }
  advanceTo(target);
}

void SimulatedClock::addParticipant() {
  std::lock_guard lock(mutex_);
  ++participants_;
}

void SimulatedClock::removeParticipant() {
  {
    std::lock_guard lock(mutex_);
    --participants_;
  }
  settled_.notify_all();
}

}  // namespace cdff::dfpc
