#pragma once
// The Orchestrator's input and output over DDS: what `cdff node` runs DFPC graphs with, as
// `cdff run` does with MCAP files (dfpc/recording_streams.hpp).
//
//   DdsInputStream input(subscriber, &stop);     // stop: set by SIGINT/SIGTERM
//   DdsSink sink(publisher);
//   Result<ReplayResult> result = replay(input, sink, options);
//
// The input ends when `stop` is set: it then takes what its readers still hold (every sample
// that was acknowledged), delivers it, and ends, so that the DFPCs finish and publish what it
// leads to.

#include <atomic>
#include <deque>
#include <functional>
#include <mutex>

#include "cdff/dds/publisher.hpp"
#include "cdff/dds/subscriber.hpp"
#include "cdff/dfpc/stream.hpp"

namespace cdff::dds {

class DdsInputStream final : public dfpc::InputStream {
 public:
  /// `on_rejected` is called, in the thread that calls next(), for every sample that does not
  /// convert; `on_lost` when a channel's publishers left, with the stamp of the latest message
  /// delivered (the stream time then).
  DdsInputStream(Subscriber& subscriber, const std::atomic<bool>* stop,
                 std::function<void(const Rejection&)> on_rejected = {},
                 std::function<void(const LostPublisher&, Timestamp)> on_lost = {});

  /// Blocks until a message arrives or `stop` is set (then std::nullopt once drained).
  Result<std::optional<dfpc::Message>> next() override;
  /// The channels subscribed, with their types.
  std::vector<dfpc::ChannelInfo> channels() const override;

  std::uint64_t received() const { return received_; }
  std::uint64_t rejected() const { return rejected_; }

 private:
  Status fill(double timeout_s);

  Subscriber& subscriber_;
  const std::atomic<bool>* stop_;
  std::function<void(const Rejection&)> on_rejected_;
  std::function<void(const LostPublisher&, Timestamp)> on_lost_;
  Timestamp last_stamp_ = 0;
  std::deque<dfpc::Message> queue_;
  bool drained_ = false;
  std::uint64_t received_ = 0, rejected_ = 0;
};

/// Publishes a run's products on their channels, its events as JSON records on /cdff/events
/// (the same records as in an MCAP run, docs/recording.md) and, when asked, one timing record
/// per DFN call on /cdff/<dfpc>/timing. Thread-safe: the input thread (products, rejections)
/// and the external API's thread (life-cycle events) write through it.
class DdsSink final : public dfpc::Sink {
 public:
  explicit DdsSink(Publisher& publisher, bool publish_timing = false,
                   std::string event_channel = "/cdff/events");

  Status writeMessage(const dfpc::Message& message) override;
  Status writeEvent(const dfpc::Event& event) override;
  Status writeTiming(const dfpc::TimingRecord& timing) override;
  /// Waits until every reader acknowledged what was published (up to 10 s).
  Status flush() override;

  std::uint64_t products() const;
  std::uint64_t events() const;

 private:
  mutable std::mutex mutex_;
  std::uint64_t products_ = 0, events_ = 0;
  Publisher& publisher_;
  bool publish_timing_;
  std::string event_channel_;
};

}  // namespace cdff::dds
