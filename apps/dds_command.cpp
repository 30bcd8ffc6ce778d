// cdff bridge RECORDING... [--domain N] [--speed X] [--wait-for CHANNEL] [--encoding E]
// cdff node GRAPH... [--domain N] [--set ...] [--map ...] [--run-while ...] [--timing]
//                    [--encoding E]
// cdff record -o OUT.mcap [--domain N] [--duration S] [CHANNEL|PATTERN...]
// cdff api METHOD [ARGUMENT] [--domain N] [--timeout S]
//
// The CDFF on DDS (docs/dds.md): a recording played onto ROS 2-compatible topics, DFPC graphs
// run as a DDS participant, and DDS topics recorded into MCAP. Each stops cleanly on SIGINT or
// SIGTERM: the node processes and publishes what its readers had received, the recorder writes
// what it had received and closes its file. The node serves the external API (seed §7.3) on DDS
// (dds/api_service.hpp); `cdff api` is its client.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <map>
#include <memory>
#include <thread>

#include "cdff/dds/api_service.hpp"
#include "cdff/dds/streams.hpp"
#include "cdff/dfpc/api.hpp"
#include "cdff/dfpc/recording_streams.hpp"
#include "cdff/dfpc/replay.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

using Clock = std::chrono::steady_clock;

// How long a stopping node waits for its DFPCs to process what its readers held.
constexpr double kDrainTimeout_s = 60;

std::atomic<bool> stop_requested{false};
extern "C" void onStopSignal(int) {
  stop_requested.store(true);
}

// SIGINT and SIGTERM set stop_requested while it lives; the previous handlers come back after.
class StopSignals {
 public:
  StopSignals() {
    stop_requested.store(false);
    int_ = std::signal(SIGINT, onStopSignal);
    term_ = std::signal(SIGTERM, onStopSignal);
  }
  ~StopSignals() {
    std::signal(SIGINT, int_);
    std::signal(SIGTERM, term_);
  }

 private:
  void (*int_)(int);
  void (*term_)(int);
};

int ddsFail(const Status& status) {
  fmt::print(stderr, "error: {}\n", status.message());
  return 1;
}

double ddsSecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// ---- cdff bridge ----------------------------------------------------------------------------

struct BridgeArguments {
  std::vector<std::string> recordings;
  int domain = 0;
  double speed = 1.0;
  std::vector<std::string> wait_for;
  double wait_timeout_s = 30;
  bool quiet = false;
  std::string encoding = "ros2";
};

// Every channel's writer before the first message, so that readers can match first; a pose
// channel's writer carries its child frame, read from the channel's first pose.
Status prepareWriters(const BridgeArguments& args, const dfpc::McapInputStream& input,
                      dds::Publisher& publisher) {
  std::map<std::string, std::string> child_frames;
  io::Replay scan;
  CDFF_RETURN_IF_ERROR(scan.open(args.recordings));
  std::size_t poses = 0;
  for (const dfpc::ChannelInfo& c : input.channels())
    poses += c.type == TypeId::of<PoseWithCovariance>() ? 1 : 0;
  while (child_frames.size() < poses && scan.next()) {
    const io::ReplayMessage& m = scan.message();
    if (m.type() != TypeId::of<PoseWithCovariance>() || child_frames.count(m.channel())) continue;
    Result<std::shared_ptr<const PoseWithCovariance>> pose = m.decode<PoseWithCovariance>();
    if (!pose) return pose.status();
    child_frames[m.channel()] = (*pose)->pose.child_frame;
  }
  for (const dfpc::ChannelInfo& c : input.channels())
    CDFF_RETURN_IF_ERROR(publisher.prepare(c.channel, c.type, child_frames[c.channel]));
  return Status::ok();
}

Status waitForReaders(const BridgeArguments& args, const dds::Publisher& publisher) {
  const auto start = Clock::now();
  for (const std::string& channel : args.wait_for) {
    while (publisher.matchedReaders(channel) == 0) {
      if (stop_requested.load()) return Status::ok();
      if (ddsSecondsSince(start) > args.wait_timeout_s)
        return Status(StatusCode::kTimeout,
                      fmt::format("--wait-for {}: no reader after {} s; expected a subscriber "
                                  "(is `cdff node` running on domain {}?)",
                                  channel, args.wait_timeout_s, args.domain));
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  return Status::ok();
}

// Plays the input: at the recording's pace times `speed`, or as fast as the readers keep up.
Result<std::uint64_t> play(const BridgeArguments& args, dfpc::McapInputStream& input,
                           dds::Publisher& publisher) {
  const auto start = Clock::now();
  std::optional<Timestamp> first;
  std::uint64_t messages = 0;
  while (!stop_requested.load()) {
    Result<std::optional<dfpc::Message>> next = input.next();
    if (!next) return next.status();
    if (!*next) break;
    const dfpc::Message& m = **next;
    if (!first) first = m.stamp;
    if (args.speed > 0) {
      const double due_s = toSeconds(m.stamp - *first) / args.speed;
      std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(due_s)));
    }
    CDFF_RETURN_IF_ERROR(publisher.publish(m));
    ++messages;
  }
  return messages;
}

int runBridge(const BridgeArguments& args) {
  if (args.speed < 0 || !std::isfinite(args.speed))
    return ddsFail(
        invalidParameter("--speed {}: expected a number >= 0 (0: as fast as the readers "
                         "keep up)",
                         args.speed));
  Result<dds::Encoding> encoding = dds::parseEncoding(args.encoding);
  if (!encoding) return ddsFail(encoding.status().withContext("--encoding"));
  StopSignals signals;
  dfpc::McapInputStream input;
  if (Status s = input.open(args.recordings); !s) return ddsFail(s);
  Result<std::unique_ptr<dds::Participant>> participant = dds::Participant::create(args.domain);
  if (!participant) return ddsFail(participant.status());
  dds::Publisher publisher(**participant, {}, *encoding);
  if (Status s = prepareWriters(args, input, publisher); !s) return ddsFail(s);
  if (Status s = waitForReaders(args, publisher); !s) return ddsFail(s);
  const auto start = Clock::now();
  Result<std::uint64_t> played = play(args, input, publisher);
  if (!played) return ddsFail(played.status());
  // Every sample reaches its readers before the bridge leaves (a reader that stopped
  // acknowledging is an error after the timeout).
  if (Status s = publisher.waitForAcknowledgements(30); !s) return ddsFail(s);
  if (!args.quiet)
    fmt::print("{}{} messages on {} channels published on DDS domain {} in {:.2f} s\n",
               stop_requested.load() ? "interrupted: " : "", *played, input.channels().size(),
               args.domain, ddsSecondsSince(start));
  for (const auto& [channel, why] : input.skippedChannels())
    fmt::print("  not published: {} ({})\n", channel, why);
  return stop_requested.load() ? 130 : 0;
}

// ---- cdff node ------------------------------------------------------------------------------

struct NodeArguments {
  std::vector<std::string> graphs;
  int domain = 0;
  std::vector<std::string> maps;
  std::vector<std::string> run_while;
  std::vector<std::string> settings;
  bool timing = false;
  int history = 100;
  std::string encoding = "ros2";
};

Result<dfpc::ReplayOptions> nodeOptions(const NodeArguments& args) {
  dfpc::ReplayOptions options;
  options.graph_files = args.graphs;
  options.parameter_settings = args.settings;
  options.record_timing = args.timing;
  options.passthrough_prefixes.clear();  // the inputs are on DDS already
  options.cancel = nullptr;              // the input ends on a stop signal, after a drain
  for (const std::string& text : args.maps) {
    Result<dfpc::ChannelRemap> remap = dfpc::parseRemap(text);
    if (!remap) return remap.status().withContext("--map");
    options.remaps.push_back(std::move(remap).value());
  }
  for (const std::string& text : args.run_while) {
    Result<dfpc::ActivationRule> rule = dfpc::parseActivationRule(text);
    if (!rule) return rule.status().withContext("--run-while");
    options.run_while.push_back(std::move(rule).value());
  }
  return options;
}

void printNodeSummary(const api::Cdff& cdff, const std::vector<dfpc::GraphSpec>& graphs,
                      const dds::DdsSink& sink, const dds::DdsInputStream& input,
                      std::uint64_t requests) {
  fmt::print("{} messages received ({} rejected), {} products, {} events, {} API requests\n",
             input.received(), input.rejected(), sink.products(), sink.events(), requests);
  for (const dfpc::GraphSpec& g : graphs) {
    Result<dfpc::DfpcStatus> d = cdff.getDFPCStatus(g.name);
    if (!d) continue;
    fmt::print("  {}: {}{}, {} messages, {} products, {} faults{}\n", d->name, toString(d->state),
               d->track_state ? fmt::format(" (track {})", toString(*d->track_state)) : "",
               d->messages, d->products, d->faults,
               d->last_fault.empty() ? "" : fmt::format(", last fault: {}", d->last_fault));
  }
}

// Serves the external API until a stop signal, then lets the input drain (what the readers
// hold), stops the DFPCs and waits until the readers acknowledged the products.
int serveNode(api::Cdff& cdff, dds::Participant& participant, dds::DdsSink& sink,
              const dds::DdsInputStream& input, const std::vector<dfpc::GraphSpec>& graphs) {
  if (Status s = cdff.setCDFFState(api::StateRequest::kInitialize); !s) return ddsFail(s);
  Result<std::unique_ptr<dds::ApiServer>> server = dds::ApiServer::create(participant, cdff);
  if (!server) return ddsFail(server.status());
  fmt::print("external API on {} / {}\n", dds::kApiRequestTopic, dds::kApiReplyTopic);
  std::fflush(stdout);
  while (!stop_requested.load())
    if (Status s = (*server)->serve(0.05); !s) return ddsFail(s);
  // Idle or stopped (by the API), the CDFF does not consume its input: nothing to drain.
  if (cdff.getCDFFState() == api::CdffState::kRunning)
    if (Status s = cdff.flush(kDrainTimeout_s); !s) return ddsFail(s);
  const api::CdffState state = cdff.getCDFFState();
  if (state == api::CdffState::kRunning || state == api::CdffState::kIdle)
    if (Status s = cdff.setCDFFState(api::StateRequest::kStop); !s) return ddsFail(s);
  if (Status s = sink.flush(); !s) return ddsFail(s);
  printNodeSummary(cdff, graphs, sink, input, (*server)->served());
  return 0;
}

// The node's input: what its readers receive; a rejected sample and a publisher that left are
// events (input_rejected, input_lost) that say which channel and why.
std::shared_ptr<dds::DdsInputStream> nodeInput(dds::Subscriber& subscriber, dds::DdsSink& sink) {
  return std::make_shared<dds::DdsInputStream>(
      subscriber, &stop_requested,
      [&sink](const dds::Rejection& r) {
        fmt::print(stderr, "rejected: {}\n", r.status.message());
        dfpc::Event event{r.stamp, dfpc::EventType::kInputRejected, "cdff node", "",
                          r.status.message()};
        if (Status s = sink.writeEvent(event); !s)
          fmt::print(stderr, "error: publishing the rejection: {}\n", s.message());
      },
      [&sink](const dds::LostPublisher& lost, Timestamp stamp) {
        const std::string why = fmt::format(
            "channel '{}': {} publisher(s) left, {} remain; {}", lost.channel, lost.left,
            lost.remaining,
            lost.remaining > 0 ? "the others go on" : "nothing more comes until one joins");
        fmt::print(stderr, "input lost: {}\n", why);
        dfpc::Event event{stamp, dfpc::EventType::kInputLost, "cdff node", "", why};
        if (Status s = sink.writeEvent(event); !s)
          fmt::print(stderr, "error: publishing the input loss: {}\n", s.message());
      });
}

int runNode(const NodeArguments& args) {
  Result<dfpc::ReplayOptions> given = nodeOptions(args);
  if (!given) return ddsFail(given.status());
  // A run set's graphs, maps, settings and rules, as `cdff run` takes them.
  Result<dfpc::ReplayOptions> options = dfpc::expandRunSets(*given);
  if (!options) return ddsFail(options.status());
  Result<std::vector<dfpc::ChannelInfo>> inputs = dfpc::externalInputs(*options);
  if (!inputs) return ddsFail(inputs.status());
  Result<std::vector<dfpc::GraphSpec>> graphs = dfpc::loadGraphs(*options);
  if (!graphs) return ddsFail(graphs.status());
  Result<dds::Encoding> encoding = dds::parseEncoding(args.encoding);
  if (!encoding) return ddsFail(encoding.status().withContext("--encoding"));
  StopSignals signals;
  Result<std::unique_ptr<dds::Participant>> participant = dds::Participant::create(args.domain);
  if (!participant) return ddsFail(participant.status());
  dds::Subscriber subscriber(**participant, *encoding);
  for (const dfpc::ChannelInfo& in : *inputs)
    if (Status s = subscriber.subscribe(in.channel, in.type); !s) return ddsFail(s);
  // Products stay available to readers that join late (a recorder started after the node).
  dds::WriterQos qos;
  qos.durability = dds::Durability::kTransientLocal;
  qos.depth = args.history;
  dds::Publisher publisher(**participant, qos, *encoding);
  dds::DdsSink sink(publisher, args.timing);
  std::shared_ptr<dds::DdsInputStream> input = nodeInput(subscriber, sink);
  api::Config config;
  config.graphs = *graphs;
  config.input = input;
  config.sink = &sink;
  config.record_timing = args.timing;
  config.run_while = options->run_while;
  Result<std::unique_ptr<api::Cdff>> cdff = api::Cdff::create(std::move(config));
  if (!cdff) return ddsFail(cdff.status());
  fmt::print("cdff node on DDS domain {} ({}): reading", args.domain, args.encoding);
  for (const dfpc::ChannelInfo& in : *inputs) fmt::print(" {} ({})", in.channel, in.type.name());
  fmt::print("\n");
  const int rc = serveNode(**cdff, **participant, sink, *input, *graphs);
  // The input thread reads DDS until a stop: it must end before the CDFF is destroyed.
  stop_requested.store(true);
  return rc;
}

// ---- cdff api -------------------------------------------------------------------------------

struct ApiArguments {
  std::string method;
  std::string argument;
  int domain = 0;
  double timeout_s = 10;
};

int runApi(const ApiArguments& args) {
  Result<std::unique_ptr<dds::Participant>> participant = dds::Participant::create(args.domain);
  if (!participant) return ddsFail(participant.status());
  Result<std::unique_ptr<dds::ApiClient>> client = dds::ApiClient::create(**participant);
  if (!client) return ddsFail(client.status());
  Result<dds::ApiReply> reply = (*client)->call(args.method, args.argument, args.timeout_s);
  if (!reply) return ddsFail(reply.status());
  if (!reply->ok) {
    fmt::print(stderr, "error: {}\n", reply->error);
    return 1;
  }
  fmt::print("{}\n", reply->result.dump(2));
  return 0;
}

// ---- cdff record ----------------------------------------------------------------------------

struct RecordArguments {
  std::string output;
  std::vector<std::string> patterns;
  int domain = 0;
  double duration_s = 0;
  double progress_s = 0;
  std::string compression = "lz4";
  bool quiet = false;
};

/// What `cdff record` has written so far, per channel (the --progress line).
struct RecordCounts {
  std::uint64_t written = 0;
  std::map<std::string, std::uint64_t> per_channel;
};

void printProgress(const RecordCounts& counts) {
  std::string line = fmt::format("recorded {} messages", counts.written);
  for (const auto& [channel, n] : counts.per_channel) line += fmt::format(", {} {}", channel, n);
  fmt::print("{}\n", line);
  std::fflush(stdout);
}

Status recordMessages(dds::Subscriber& subscriber, io::Recorder& recorder, double timeout_s,
                      bool quiet, RecordCounts& counts) {
  std::vector<dfpc::Message> messages;
  std::vector<dds::Rejection> rejections;
  CDFF_RETURN_IF_ERROR(subscriber.poll(timeout_s, messages, rejections));
  if (!quiet)
    for (const std::string& channel : subscriber.takeNewChannels())
      fmt::print("recording {}\n", channel);
  for (const dds::Rejection& r : rejections) {
    fmt::print(stderr, "rejected: {}\n", r.status.message());
    CDFF_RETURN_IF_ERROR(recorder.writeEvent(r.stamp, "warning", "cdff record",
                                             fmt::format("rejected: {}", r.status.message())));
  }
  for (const dfpc::Message& m : messages) {
    CDFF_RETURN_IF_ERROR(recorder.write(m.channel, m.value, m.stamp));
    ++counts.written;
    ++counts.per_channel[m.channel];
  }
  return Status::ok();
}

int runRecord(const RecordArguments& args) {
  const auto compression = io::compressionFromString(args.compression);
  if (!compression)
    return ddsFail(
        invalidParameter("--compression '{}' is not one of none, lz4, zstd", args.compression));
  StopSignals signals;
  Result<std::unique_ptr<dds::Participant>> participant = dds::Participant::create(args.domain);
  if (!participant) return ddsFail(participant.status());
  io::Recorder recorder;
  io::McapWriterOptions writer;
  writer.compression = *compression;
  if (Status s = recorder.open(args.output, writer); !s) return ddsFail(s);
  dds::Subscriber subscriber(**participant);
  Status status = subscriber.subscribeDiscovered(args.patterns);
  RecordCounts counts;
  const auto start = Clock::now();
  auto last_progress = start;
  while (status.isOk() && !stop_requested.load() &&
         (args.duration_s <= 0 || ddsSecondsSince(start) < args.duration_s)) {
    status = recordMessages(subscriber, recorder, 0.05, args.quiet, counts);
    if (args.progress_s > 0 && ddsSecondsSince(last_progress) >= args.progress_s) {
      printProgress(counts);
      last_progress = Clock::now();
    }
  }
  // What the readers hold was acknowledged: it is written before the file is closed.
  if (status.isOk()) status = recordMessages(subscriber, recorder, 0, args.quiet, counts);
  if (Status s = recorder.close(); !s) return ddsFail(s);
  if (!status) return ddsFail(status);
  if (!args.quiet)
    fmt::print("{} messages on {} channels -> {}\n", counts.written, subscriber.channels().size(),
               args.output);
  return 0;
}

}  // namespace

void addDdsCommands(CLI::App& root, int& exit_code) {
  auto bridge = std::make_shared<BridgeArguments>();
  CLI::App* b = root.add_subcommand("bridge", "Play MCAP recordings onto DDS (ROS 2 topics)");
  b->add_option("RECORDING", bridge->recordings, "MCAP files (merged by time)")->required();
  b->add_option("--domain", bridge->domain, "DDS domain id")->capture_default_str();
  b->add_option("--speed", bridge->speed,
                "Stream seconds per wall second; 0: as fast as the readers keep up")
      ->capture_default_str();
  b->add_option("--wait-for", bridge->wait_for,
                "Wait until this channel has a reader before playing (repeatable)");
  b->add_option("--wait-timeout", bridge->wait_timeout_s, "Seconds --wait-for waits at most")
      ->capture_default_str();
  b->add_option("--encoding", bridge->encoding,
                "ros2, or asn1-uper: the types with an ESROCOS ASN.1 type as uPER Records")
      ->capture_default_str();
  b->add_flag("-q,--quiet", bridge->quiet, "No summary");
  b->callback([bridge, &exit_code] { exit_code = runBridge(*bridge); });

  auto node = std::make_shared<NodeArguments>();
  CLI::App* n = root.add_subcommand(
      "node", "Run DFPC graphs as a DDS participant: inputs from DDS, products and events to DDS");
  n->add_option("GRAPH", node->graphs, "DFPC graph files (YAML), run together")->required();
  n->add_option("--domain", node->domain, "DDS domain id")->capture_default_str();
  n->add_option("--map", node->maps, "Feed a DFPC input from another channel: DFPC.INPUT=/channel");
  n->add_option("--run-while", node->run_while,
                "Run a DFPC only while another's track state is one of some states");
  n->add_option("--set", node->settings, "Set an instance's parameter: [DFPC/]NODE.PARAM=VALUE");
  n->add_flag("--timing", node->timing, "Publish a timing record per DFN call");
  n->add_option("--history", node->history, "Products kept per channel for readers that join late")
      ->capture_default_str();
  n->add_option("--encoding", node->encoding,
                "ros2, or asn1-uper: the types with an ESROCOS ASN.1 type as uPER Records")
      ->capture_default_str();
  n->callback([node, &exit_code] { exit_code = runNode(*node); });

  auto call = std::make_shared<ApiArguments>();
  CLI::App* a = root.add_subcommand(
      "api",
      "Call the external API (seed 7.3) of a `cdff node` over DDS; prints the answer (JSON)");
  a->add_option("METHOD", call->method,
                fmt::format("One of {}", fmt::join(dds::apiMethods(), ", ")))
      ->required();
  a->add_option("ARGUMENT", call->argument,
                "A DFPC (getDFPCStatus, initDFPC, stopDFPC), a state (setCDFFState: initialize, "
                "idle, reset, stop) or a frame (getTargetRelative*: default the product's)");
  a->add_option("--domain", call->domain, "DDS domain id")->capture_default_str();
  a->add_option("--timeout", call->timeout_s, "Seconds to wait for the node's reply")
      ->capture_default_str();
  a->callback([call, &exit_code] { exit_code = runApi(*call); });

  auto record = std::make_shared<RecordArguments>();
  CLI::App* r = root.add_subcommand("record", "Record DDS topics (ROS 2 and CDFF types) to MCAP");
  r->add_option("CHANNEL", record->patterns,
                "Channels to record: prefixes or patterns with * ? [] (default: all)");
  r->add_option("-o,--output", record->output, "Output MCAP file")->required();
  r->add_option("--domain", record->domain, "DDS domain id")->capture_default_str();
  r->add_option("--duration", record->duration_s, "Stop after this many seconds (0: on a signal)");
  r->add_option("--compression", record->compression, "none, lz4 or zstd")->capture_default_str();
  r->add_option("--progress", record->progress_s,
                "Every this many seconds, print the messages written so far per channel (0: never)")
      ->check(CLI::NonNegativeNumber);
  r->add_flag("-q,--quiet", record->quiet, "No log of the channels");
  r->callback([record, &exit_code] { exit_code = runRecord(*record); });
}

}  // namespace cdff::app
