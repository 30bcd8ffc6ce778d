#include "cdff/dds/streams.hpp"

#include "cdff/dfpc/recording_streams.hpp"

namespace cdff::dds {

namespace {
constexpr double kPollInterval_s = 0.05;  // how often a blocked next() looks at `stop`
constexpr double kAcknowledgementTimeout_s = 10.0;
}  // namespace

DdsInputStream::DdsInputStream(Subscriber& subscriber, const std::atomic<bool>* stop,
                               std::function<void(const Rejection&)> on_rejected,
                               std::function<void(const LostPublisher&, Timestamp)> on_lost)
    : subscriber_(subscriber),
      stop_(stop),
      on_rejected_(std::move(on_rejected)),
      on_lost_(std::move(on_lost)) {}

Status DdsInputStream::fill(double timeout_s) {
  std::vector<dfpc::Message> messages;
  std::vector<Rejection> rejections;
  CDFF_RETURN_IF_ERROR(subscriber_.poll(timeout_s, messages, rejections));
  for (const Rejection& r : rejections) {
    ++rejected_;
    if (on_rejected_) on_rejected_(r);
  }
  received_ += messages.size();
  for (dfpc::Message& m : messages) queue_.push_back(std::move(m));
  // A departure after the messages it sent: reported at the stamp of the last of them.
  if (!queue_.empty()) last_stamp_ = queue_.back().stamp;
  if (on_lost_)
    for (const LostPublisher& lost : subscriber_.takeLostPublishers()) on_lost_(lost, last_stamp_);
  return Status::ok();
}

Result<std::optional<dfpc::Message>> DdsInputStream::next() {
  while (queue_.empty() && !drained_) {
    if (stop_ != nullptr && stop_->load()) {
      // What the readers hold was acknowledged to its publishers: deliver it before ending.
      CDFF_RETURN_IF_ERROR(fill(0));
      drained_ = true;
      break;
    }
    CDFF_RETURN_IF_ERROR(fill(kPollInterval_s));
  }
  if (queue_.empty()) return std::optional<dfpc::Message>();
  dfpc::Message m = std::move(queue_.front());
  queue_.pop_front();
  return std::optional<dfpc::Message>(std::move(m));
}

std::vector<dfpc::ChannelInfo> DdsInputStream::channels() const {
  return subscriber_.channels();
}

// ---------------------------------------------------------------------------------------------

DdsSink::DdsSink(Publisher& publisher, bool publish_timing, std::string event_channel)
    : publisher_(publisher),
      publish_timing_(publish_timing),
      event_channel_(std::move(event_channel)) {}

Status DdsSink::writeMessage(const dfpc::Message& message) {
  std::lock_guard lock(mutex_);
  ++products_;
  return publisher_.publish(message);
}

Status DdsSink::writeEvent(const dfpc::Event& event) {
  std::lock_guard lock(mutex_);
  ++events_;
  return publisher_.publish(
      dfpc::Message::of<nlohmann::json>(event_channel_, event.stamp, dfpc::eventRecord(event)));
}

Status DdsSink::writeTiming(const dfpc::TimingRecord& timing) {
  if (!publish_timing_) return Status::ok();
  std::lock_guard lock(mutex_);
  return publisher_.publish(dfpc::Message::of<nlohmann::json>(
      dfpc::timingChannel(timing.dfpc), timing.stamp, dfpc::timingRecord(timing)));
}

Status DdsSink::flush() {
  std::lock_guard lock(mutex_);
  return publisher_.waitForAcknowledgements(kAcknowledgementTimeout_s);
}

std::uint64_t DdsSink::products() const {
  std::lock_guard lock(mutex_);
  return products_;
}

std::uint64_t DdsSink::events() const {
  std::lock_guard lock(mutex_);
  return events_;
}

}  // namespace cdff::dds
