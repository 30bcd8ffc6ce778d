#pragma once
// The frames waiting to be sent to one browser. The producer (a replay, a live run) never waits
// on it: when the browser reads slower than frames come, the oldest waiting binary frame (an
// image or a point cloud: large, and replaced by the next one) is dropped, or the oldest frame
// when only text frames (poses, errors, states, events: small, each its own) wait. Only this
// browser's copy is decimated; the recording and the other browsers are not affected.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>

namespace cdff::serve {

struct Frame {
  bool binary = false;  // a WebSocket binary frame (an image) or a text frame (JSON)
  std::string data;
};

class FrameQueue {
 public:
  explicit FrameQueue(std::size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}

  /// Appends a frame, dropping the oldest binary frame (the oldest frame when none is binary)
  /// when `capacity` frames already wait.
  void push(Frame frame) {
    std::lock_guard lock(mutex_);
    if (frames_.size() >= capacity_) {
      auto binary =
          std::find_if(frames_.begin(), frames_.end(), [](const Frame& f) { return f.binary; });
      frames_.erase(binary == frames_.end() ? frames_.begin() : binary);
      ++dropped_;
    }
    frames_.push_back(std::move(frame));
  }
  std::optional<Frame> pop() {
    std::lock_guard lock(mutex_);
    if (frames_.empty()) return std::nullopt;
    Frame f = std::move(frames_.front());
    frames_.pop_front();
    return f;
  }
  std::size_t size() const {
    std::lock_guard lock(mutex_);
    return frames_.size();
  }
  /// Frames dropped so far because the browser was behind.
  std::uint64_t dropped() const {
    std::lock_guard lock(mutex_);
    return dropped_;
  }

 private:
  mutable std::mutex mutex_;
  std::size_t capacity_;
  std::deque<Frame> frames_;
  std::uint64_t dropped_ = 0;
};

}  // namespace cdff::serve
