// cdff log info | cat | cut | export: inspect, print, cut and export MCAP recordings
// (docs/recording.md; export: log_export_command.cpp, docs/asn1.md).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "cdff/io/inspect.hpp"
#include "cdff/io/mcap.hpp"
#include "cdff/io/replay.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

using nlohmann::json;

/// A channel's CDFF type name, "" when it is none of ours (e.g. a ROS 2 message).
std::string_view typeLabel(TypeId type) {
  return type ? type.name() : std::string_view();
}

void printError(const Status& s) {
  fmt::print(stderr, "error: {}\n", s.message());
}

std::string humanBytes(std::uint64_t n) {
  if (n < 1024) return fmt::format("{} B", n);
  if (n < (1u << 20)) return fmt::format("{:.1f} KiB", n / 1024.0);
  if (n < (1u << 30)) return fmt::format("{:.1f} MiB", n / 1048576.0);
  return fmt::format("{:.2f} GiB", n / 1073741824.0);
}

std::string seconds(std::uint64_t ns) {
  return fmt::format("{}.{:09d}", ns / 1'000'000'000, ns % 1'000'000'000);
}

std::string dumpLine(const json& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

// --start / --end: seconds from the first message of the inputs, or since the epoch with
// --absolute.
struct TimeWindow {
  std::optional<double> start, end;
  bool absolute = false;

  void addOptions(CLI::App* cmd) {
    cmd->add_option("--start", start,
                    "Keep messages from this time on: seconds after the first message (or since "
                    "the epoch of the recording with --absolute)");
    cmd->add_option("--end", end, "Keep messages up to this time (inclusive), same reference");
    cmd->add_flag("--absolute", absolute, "--start and --end are times since the epoch");
  }

  // Resolves to microseconds, given the first message time (us) of the inputs.
  Status apply(Timestamp first_us, io::ReplayOptions& options) const {
    const auto convert = [&](double s) -> Timestamp {
      const Timestamp us = static_cast<Timestamp>(std::llround(s * 1e6));
      return absolute ? us : first_us + us;
    };
    if (start && !std::isfinite(*start))
      return invalidInput("--start {} is not a finite number of seconds", *start);
    if (end && !std::isfinite(*end))
      return invalidInput("--end {} is not a finite number of seconds", *end);
    if (start) options.start = convert(*start);
    if (end) options.end = convert(*end);
    if (start && end && *end < *start)
      return invalidInput("--end {} s is before --start {} s", *end, *start);
    return Status::ok();
  }
};

// Opens a replay of `paths`, resolving the time window against the inputs' first message.
Status openReplay(const std::vector<std::string>& paths, const std::vector<std::string>& channels,
                  const TimeWindow& window, io::Replay& replay) {
  io::ReplayOptions options;
  options.channels = channels;
  if (window.start || window.end) {
    io::Replay probe;
    CDFF_RETURN_IF_ERROR(probe.open(paths));
    CDFF_RETURN_IF_ERROR(window.apply(probe.startTime(), options));
  }
  return replay.open(paths, options);
}

// ---- info ----------------------------------------------------------------------------------

struct ChannelStats {
  std::uint64_t count = 0;
  std::uint64_t first = 0, last = 0;
};

int info(const std::string& path, bool quick, bool as_json) {
  io::McapReader r;
  if (Status s = r.open(path); !s.isOk()) {
    printError(s);
    return 1;
  }
  std::vector<io::Damage> damages = r.recovery().damages;
  std::map<std::uint16_t, ChannelStats> stats;
  const bool exact = !quick;
  if (exact) {
    auto it = r.messages();
    while (it.next()) {
      const io::MessageView& m = it.message();
      ChannelStats& c = stats[m.channel->id];
      if (c.count++ == 0) c.first = m.log_time;
      c.first = std::min(c.first, m.log_time);
      c.last = std::max(c.last, m.log_time);
    }
    damages.insert(damages.end(), it.damages().begin(), it.damages().end());
    const auto crc = r.verify(false);
    damages.insert(damages.end(), crc.begin(), crc.end());
  } else {
    for (const auto& [id, count] : r.statistics().channel_message_counts) stats[id].count = count;
  }

  std::map<std::string, std::pair<std::size_t, std::pair<std::uint64_t, std::uint64_t>>>
      by_compression;
  for (const io::ChunkInfo& c : r.chunks()) {
    if (c.unchunked) continue;
    auto& [n, sizes] = by_compression[io::toString(c.compression)];
    ++n;
    sizes.first += c.compressed_size;
    sizes.second += c.uncompressed_size;
  }
  const io::Statistics& st = r.statistics();
  std::uint64_t messages = 0, t0 = 0, t1 = 0;
  bool any = false;
  for (const auto& [id, c] : stats) {
    messages += c.count;
    if (exact && c.count) {
      t0 = any ? std::min(t0, c.first) : c.first;
      t1 = any ? std::max(t1, c.last) : c.last;
      any = true;
    }
  }
  if (!exact) {
    messages = st.message_count;
    t0 = st.message_start_time;
    t1 = st.message_end_time;
  }
  const double duration = (t1 - t0) * 1e-9;

  if (as_json) {
    json j = {{"file", path},
              {"size", r.fileSize()},
              {"library", r.library()},
              {"profile", r.profile()},
              {"indexed", r.recovery().indexed},
              {"verified", exact},
              {"messages", messages},
              {"start_ns", t0},
              {"end_ns", t1},
              {"duration_s", duration},
              {"chunks", r.chunks().size()},
              {"channels", json::array()},
              {"attachments", json::array()},
              {"metadata", json::array()},
              {"damage", json::array()}};
    for (const auto& [name, v] : by_compression)
      j["compression"][name] = {{"chunks", v.first},
                                {"compressed_bytes", v.second.first},
                                {"uncompressed_bytes", v.second.second}};
    for (const auto& [id, ch] : r.channels()) {
      const io::Schema* schema = r.schemaOf(ch);
      const ChannelStats& c = stats[id];
      json e = {{"id", id},
                {"topic", ch.topic},
                {"cdff_type", std::string(typeLabel(io::typeOfChannel(ch, schema)))},
                {"schema", schema ? schema->name : ""},
                {"schema_encoding", schema ? schema->encoding : ""},
                {"message_encoding", ch.message_encoding},
                {"messages", c.count}};
      if (exact && c.count > 1 && c.last > c.first)
        e["rate_hz"] = (c.count - 1) / ((c.last - c.first) * 1e-9);
      j["channels"].push_back(e);
    }
    for (const auto& a : r.attachments())
      j["attachments"].push_back(
          {{"name", a.name}, {"media_type", a.media_type}, {"bytes", a.data_size}});
    for (const auto& m : r.metadata()) j["metadata"].push_back(m.name);
    for (const auto& d : damages) j["damage"].push_back({{"offset", d.offset}, {"what", d.what}});
    fmt::print("{}\n", j.dump(1, ' ', false, json::error_handler_t::replace));
  } else {
    fmt::print("file:        {} ({})\n", path, humanBytes(r.fileSize()));
    fmt::print("library:     {}{}\n", r.library().empty() ? "(none)" : r.library(),
               r.profile().empty() ? "" : fmt::format(", profile {}", r.profile()));
    fmt::print("index:       {}\n", r.recovery().indexed
                                        ? "summary and chunk index read"
                                        : "no usable summary: the data section was scanned");
    if (by_compression.empty()) fmt::print("compression: (no chunks)\n");
    for (const auto& [name, v] : by_compression)
      fmt::print("compression: {} ({} chunks, {} stored for {}, ratio {:.2f})\n", name, v.first,
                 humanBytes(v.second.first), humanBytes(v.second.second),
                 v.second.first ? static_cast<double>(v.second.second) / v.second.first : 0.0);
    fmt::print("messages:    {}{}\n", messages, exact ? "" : " (from the statistics record)");
    if (messages)
      fmt::print("time:        {} .. {} s (duration {:.3f} s)\n", seconds(t0), seconds(t1),
                 duration);
    std::size_t topic_w = 5, type_w = 4, schema_w = 6;
    for (const auto& [id, ch] : r.channels()) {
      const io::Schema* schema = r.schemaOf(ch);
      topic_w = std::max(topic_w, ch.topic.size());
      type_w = std::max(type_w, typeLabel(io::typeOfChannel(ch, schema)).size());
      schema_w = std::max(schema_w, schema ? schema->name.size() : 0);
    }
    fmt::print("channels:    {}\n", r.channels().size());
    fmt::print("  {:>3}  {:<{}}  {:<{}}  {:<{}}  {:<10} {:>9} {:>10}\n", "id", "topic", topic_w,
               "type", type_w, "schema", schema_w, "encoding", "messages", "rate");
    for (const auto& [id, ch] : r.channels()) {
      const io::Schema* schema = r.schemaOf(ch);
      const ChannelStats& c = stats[id];
      std::string rate = "-";
      if (exact && c.count > 1 && c.last > c.first)
        rate = fmt::format("{:.2f} Hz", (c.count - 1) / ((c.last - c.first) * 1e-9));
      const std::string_view type = typeLabel(io::typeOfChannel(ch, schema));
      fmt::print("  {:>3}  {:<{}}  {:<{}}  {:<{}}  {:<10} {:>9} {:>10}\n", id, ch.topic, topic_w,
                 type.empty() ? "-" : type, type_w, schema ? schema->name : "-", schema_w,
                 ch.message_encoding, c.count, rate);
    }
    if (!r.attachments().empty()) {
      fmt::print("attachments: {}\n", r.attachments().size());
      for (const auto& a : r.attachments())
        fmt::print("  {} ({}, {})\n", a.name, a.media_type, humanBytes(a.data_size));
    }
    if (!r.metadata().empty()) {
      std::vector<std::string> names;
      for (const auto& m : r.metadata()) names.push_back(m.name);
      fmt::print("metadata:    {}\n", fmt::join(names, ", "));
    }
    if (!exact)
      fmt::print("check:       skipped (--quick); chunks were not read\n");
    else if (damages.empty())
      fmt::print("check:       every chunk read, CRCs match\n");
  }
  if (!damages.empty()) {
    if (!as_json) {
      fmt::print(
          "damage:      {} place(s); every intact chunk is readable (cdff log cut makes a "
          "sound copy)\n",
          damages.size());
      for (const auto& d : damages) fmt::print("  {}\n", d.toString());
    }
    fmt::print(stderr, "error: '{}' is damaged: {}\n", path, damages.front().toString());
    return 1;
  }
  return 0;
}

// ---- cat -----------------------------------------------------------------------------------

int cat(const std::vector<std::string>& paths, const std::vector<std::string>& channels,
        const TimeWindow& window, std::size_t limit, std::size_t max_array) {
  io::Replay replay;
  if (Status s = openReplay(paths, channels, window, replay); !s.isOk()) {
    printError(s);
    return 1;
  }
  io::InspectOptions options;
  options.max_array = max_array;
  options.head = std::min<std::size_t>(max_array, 6);
  std::map<std::pair<std::size_t, std::uint16_t>, Result<io::MessageInspector>> inspectors;
  std::size_t printed = 0;
  bool bad_message = false;
  while ((limit == 0 || printed < limit) && replay.next()) {
    const io::ReplayMessage& m = replay.message();
    const io::MessageView& v = m.view();
    const auto key = std::make_pair(m.fileIndex(), v.channel->id);
    auto it = inspectors.find(key);
    if (it == inspectors.end())
      it = inspectors.emplace(key, io::MessageInspector::create(*v.channel, v.schema, options))
               .first;
    // Fields in a fixed order, the data last (nlohmann::json would sort the keys).
    std::string line = fmt::format(
        R"({{"channel":{},"log_time":{},"log_time_ns":{},"publish_time_ns":{},"sequence":{},)"
        R"("schema":{},"type":{})",
        dumpLine(m.channel()), seconds(v.log_time), v.log_time, v.publish_time, v.sequence,
        dumpLine(std::string(m.schemaName())), dumpLine(std::string(typeLabel(m.type()))));
    if (paths.size() > 1) line += fmt::format(R"(,"file":{})", dumpLine(paths[m.fileIndex()]));
    Result<json> data = it->second ? it->second->toJson(v.data) : Result<json>(it->second.status());
    if (data) {
      line += fmt::format(R"(,"data":{}}})", dumpLine(*data));
    } else {
      line += fmt::format(R"(,"error":{}}})", dumpLine(data.status().message()));
      bad_message = true;
    }
    fmt::print("{}\n", line);
    ++printed;
  }
  std::fflush(stdout);
  if (!replay.status().isOk()) {
    printError(replay.status());
    return 1;
  }
  if (bad_message) {
    fmt::print(stderr, "error: some messages could not be decoded (see their \"error\" field)\n");
    return 1;
  }
  return 0;
}

// ---- cut -----------------------------------------------------------------------------------

int cut(const std::vector<std::string>& paths, const std::string& output,
        const std::vector<std::string>& channels, const TimeWindow& window,
        const std::string& compression, std::size_t chunk_size) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const std::string& p : paths)
    if (fs::equivalent(p, output, ec)) {
      fmt::print(stderr, "error: the output '{}' is also an input; write to another file\n",
                 output);
      return 1;
    }
  const auto comp = io::compressionFromString(compression);
  if (!comp) {
    fmt::print(stderr, "error: --compression '{}' is not one of none, lz4, zstd\n", compression);
    return 2;
  }
  io::Replay replay;
  if (Status s = openReplay(paths, channels, window, replay); !s.isOk()) {
    printError(s);
    return 1;
  }
  io::McapWriter writer;
  io::McapWriterOptions options;
  options.compression = *comp;
  options.chunk_size = chunk_size;
  options.library = "cdff log cut";
  if (Status s = writer.open(output, options); !s.isOk()) {
    printError(s);
    return 1;
  }
  std::map<std::string, std::uint16_t> out_channels;
  std::map<std::pair<std::size_t, std::uint16_t>, std::uint16_t> mapping;
  std::uint64_t written = 0, first = 0, last = 0;
  Status status;
  while (status.isOk() && replay.next()) {
    const io::ReplayMessage& m = replay.message();
    const io::MessageView& v = m.view();
    const auto key = std::make_pair(m.fileIndex(), v.channel->id);
    auto it = mapping.find(key);
    if (it == mapping.end()) {
      auto known = out_channels.find(v.channel->topic);
      if (known == out_channels.end()) {
        std::uint16_t schema_id = 0;
        if (v.schema) {
          auto id = writer.addSchema(v.schema->name, v.schema->encoding, v.schema->data);
          if (!id) {
            status = id.status();
            break;
          }
          schema_id = *id;
        }
        auto id = writer.addChannel(v.channel->topic, v.channel->message_encoding, schema_id,
                                    v.channel->metadata);
        if (!id) {
          status = id.status();
          break;
        }
        known = out_channels.emplace(v.channel->topic, *id).first;
      }
      it = mapping.emplace(key, known->second).first;
    }
    status = writer.write(it->second, v.log_time, v.publish_time, v.data, v.sequence);
    if (written++ == 0) first = v.log_time;
    last = v.log_time;
  }
  // Attachments within the window and every metadata record come along.
  for (std::size_t f = 0; status.isOk() && f < replay.fileCount(); ++f) {
    const io::McapReader& r = replay.reader(f);
    for (const io::AttachmentInfo& a : r.attachments()) {
      const Timestamp t = io::fromMcapTime(a.log_time);
      if (window.start || window.end) {
        if (t < replay.startTime() || t > replay.endTime()) continue;
      }
      auto data = r.readAttachment(a);
      if (!data) {
        fmt::print(stderr, "warning: attachment '{}' skipped: {}\n", a.name,
                   data.status().message());
        continue;
      }
      status = writer.writeAttachment(a.name, a.media_type, a.log_time, *data, a.create_time);
    }
    for (const io::MetadataInfo& m : r.metadata()) {
      auto values = r.readMetadata(m);
      if (values) status = writer.writeMetadata(m.name, *values);
    }
  }
  const Status closed = writer.close();
  if (status.isOk()) status = closed;
  if (!status.isOk()) {
    printError(status);
    return 1;
  }
  fmt::print("wrote {} messages on {} channels ({} .. {} s) to {} ({})\n", written,
             out_channels.size(), written ? seconds(first) : "-", written ? seconds(last) : "-",
             output, humanBytes(writer.bytesWritten()));
  if (!replay.status().isOk()) {
    fmt::print(stderr, "error: the input is damaged: {}; the {} intact messages were written\n",
               replay.status().message(), written);
    return 1;
  }
  return 0;
}

}  // namespace

void addLogCommands(CLI::App& root, int& exit_code) {
  CLI::App* log = root.add_subcommand("log", "Inspect, print, cut and export MCAP recordings");
  log->require_subcommand(1);

  CLI::App* info_cmd = log->add_subcommand(
      "info", "Channels, schemas, message counts, rates, time range, compression and damage");
  auto info_file = std::make_shared<std::string>();
  auto quick = std::make_shared<bool>(false);
  auto info_json = std::make_shared<bool>(false);
  info_cmd->add_option("FILE", *info_file, "MCAP file")->required();
  info_cmd->add_flag("--quick", *quick,
                     "Read only the summary (O(chunks)); by default every chunk is read and "
                     "checked, which also gives exact rates");
  info_cmd->add_flag("--json", *info_json, "Print one JSON object instead of text");
  info_cmd->callback([=, &exit_code] { exit_code = info(*info_file, *quick, *info_json); });

  CLI::App* cat_cmd = log->add_subcommand(
      "cat", "Print messages as JSON lines, in log-time order (several files are merged)");
  auto cat_files = std::make_shared<std::vector<std::string>>();
  auto cat_channels = std::make_shared<std::vector<std::string>>();
  auto cat_window = std::make_shared<TimeWindow>();
  auto limit = std::make_shared<std::size_t>(0);
  auto max_array = std::make_shared<std::size_t>(16);
  cat_cmd->add_option("FILE", *cat_files, "MCAP file(s)")->required();
  cat_cmd->add_option("--channel,-c", *cat_channels, "Only this channel (repeatable); default all");
  cat_window->addOptions(cat_cmd);
  cat_cmd->add_option("--limit,-n", *limit, "Stop after this many messages (0: all)");
  cat_cmd
      ->add_option("--max-array", *max_array,
                   "Arrays and byte fields longer than this are summarised as their length "
                   "and first values")
      ->check(CLI::PositiveNumber);
  cat_cmd->callback([=, &exit_code] {
    exit_code = cat(*cat_files, *cat_channels, *cat_window, *limit, *max_array);
  });

  CLI::App* cut_cmd = log->add_subcommand(
      "cut",
      "Copy a time range and a subset of channels into a new, indexed MCAP file (several "
      "inputs are merged; a damaged input is copied up to its damage)");
  auto cut_files = std::make_shared<std::vector<std::string>>();
  auto output = std::make_shared<std::string>();
  auto cut_channels = std::make_shared<std::vector<std::string>>();
  auto cut_window = std::make_shared<TimeWindow>();
  auto compression = std::make_shared<std::string>("lz4");
  auto chunk_size = std::make_shared<std::size_t>(4u << 20);
  cut_cmd->add_option("FILE", *cut_files, "Input MCAP file(s)")->required();
  cut_cmd->add_option("--output,-o", *output, "Output MCAP file")->required();
  cut_cmd->add_option("--channel,-c", *cut_channels, "Only this channel (repeatable); default all");
  cut_window->addOptions(cut_cmd);
  cut_cmd->add_option("--compression", *compression, "none, lz4 or zstd")
      ->check(CLI::IsMember({"none", "lz4", "zstd"}));
  cut_cmd->add_option("--chunk-size", *chunk_size, "Uncompressed bytes per chunk")
      ->check(CLI::PositiveNumber);
  cut_cmd->callback([=, &exit_code] {
    exit_code = cut(*cut_files, *output, *cut_channels, *cut_window, *compression, *chunk_size);
  });

  addLogExportCommand(*log, exit_code);
}

}  // namespace cdff::app
