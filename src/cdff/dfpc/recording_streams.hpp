#pragma once
// The Orchestrator's input and output over MCAP recordings (src/cdff/io): what `cdff run` reads
// and writes.
//
//   McapInputStream input;
//   CDFF_RETURN_IF_ERROR(input.open({"sim.mcap"}));
//   McapSink sink;
//   CDFF_RETURN_IF_ERROR(sink.open("out.mcap"));
//   Result<ReplayResult> result = replay(input, sink, options);
//   CDFF_RETURN_IF_ERROR(sink.close());   // also after a failed run: what was written is kept
//
// Recorded layout (docs/recording.md): products and copied-through inputs on their own channels
// with their CDFF schema; events as JSON records on /cdff/events; one JSON timing record per DFN
// call on /cdff/<dfpc>/timing.

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "cdff/dfpc/replay.hpp"
#include "cdff/dfpc/stream.hpp"
#include "cdff/io/recorder.hpp"
#include "cdff/io/replay.hpp"

namespace cdff::dfpc {

/// Messages of one or several MCAP files in log-time order. A channel whose type is not a port
/// type (e.g. a ROS 2 message, or a recording-only type such as a compressed image) is not
/// delivered; skippedChannels() names them. Damage in a file (a truncated recording) is
/// reported by next() as an error after every message before it was delivered.
class McapInputStream final : public InputStream {
 public:
  McapInputStream();
  ~McapInputStream() override;

  Status open(const std::vector<std::string>& paths, const io::ReplayOptions& options = {});

  Result<std::optional<Message>> next() override;
  std::vector<ChannelInfo> channels() const override;
  std::optional<std::pair<Timestamp, Timestamp>> timeRange() const override;

  /// Channels present in the files but not delivered, with the reason.
  const std::map<std::string, std::string>& skippedChannels() const { return skipped_; }

 private:
  io::Replay replay_;
  std::vector<ChannelInfo> channels_;
  std::map<std::string, TypeId, std::less<>> types_;
  std::map<std::string, std::string> skipped_;
  bool done_ = false;
};

struct McapSinkOptions {
  io::McapWriterOptions writer;
  /// Events go to this channel (docs/recording.md).
  std::string event_channel = "/cdff/events";
};

/// Records a run's products, events and timings into one MCAP file.
class McapSink final : public Sink {
 public:
  Status open(const std::string& path, const McapSinkOptions& options = {});
  /// Writes the summary and the footer; idempotent.
  Status close();

  Status writeMessage(const Message& message) override;
  Status writeEvent(const Event& event) override;
  Status writeTiming(const TimingRecord& timing) override;
  Status flush() override;

  std::uint64_t messagesWritten() const { return messages_written_; }
  std::uint64_t eventsWritten() const { return events_written_; }

 private:
  io::Recorder recorder_;
  McapSinkOptions options_;
  std::map<std::string, std::string, std::less<>> timing_channels_;  // dfpc -> channel
  std::uint64_t messages_written_ = 0;
  std::uint64_t events_written_ = 0;
};

/// The event level recorded for each kind of event: "error" for faults that a DFN reported and
/// failed recoveries, "warning" for other faults and warnings, "info" otherwise.
const char* eventLevel(EventType type);

/// An event as recordings hold it on /cdff/events: level, source, kind, type, dfpc, instance,
/// message (docs/recording.md).
nlohmann::json eventRecord(const Event& event);
/// A DFPC's status (getDFPCStatus) as every external interface gives it: the DDS service, the
/// web UI and Python read the same keys (times in int64 microseconds, `*_us`; null where the
/// DFPC has no track state or no product yet; docs/external-api.md).
nlohmann::json statusRecord(const DfpcStatus& status);
/// A DFN call's timing record, as recorded on timingChannel(dfpc).
nlohmann::json timingRecord(const TimingRecord& timing);
/// "/cdff/<dfpc>/timing".
std::string timingChannel(std::string_view dfpc);

/// replay() from MCAP files (merged by time) into an MCAP file, as a script or a campaign run
/// wants it: the output is closed after a failed run too, so that what was produced is kept.
/// (`cdff run` adds a time window, compression, Ctrl-C and a progress bar around the same calls.)
Result<ReplayResult> replayFiles(const std::vector<std::string>& inputs, const std::string& output,
                                 const ReplayOptions& options);

}  // namespace cdff::dfpc
