// cdff log export --asn1-uper OUT_DIR FILE... [-c CHANNEL]: the messages of a recording as the
// seed's ESROCOS-style ASN.1 types in uPER (docs/asn1.md), one file per message:
//   OUT_DIR/<channel>/<index>.<ASN.1 type>.uper      (index: 000000, 000001... per channel)
//   OUT_DIR/index.csv: channel,index,log_time_ns,asn1_type,bytes,file (one row per file)
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include <fmt/format.h>

#include "cdff/asn1/uper.hpp"
#include "cdff/io/replay.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

namespace fs = std::filesystem;

struct ExportArguments {
  std::vector<std::string> inputs;
  std::string output;
  std::vector<std::string> channels;
};

Status writeFile(const fs::path& path, std::span<const std::uint8_t> bytes) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  if (ec) return ioError("cannot create '{}': {}", path.parent_path().string(), ec.message());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) return ioError("cannot write '{}'", path.string());
  return Status::ok();
}

// A channel "/a/b" is the folder OUT_DIR/a/b; ".." and empty parts are refused (a recording is
// untrusted: its channel names must not write outside OUT_DIR).
Result<fs::path> channelFolder(const std::string& channel) {
  fs::path folder;
  for (const fs::path& part : fs::path(channel).relative_path()) {
    if (part.empty() || part == "." || part == "..")
      return invalidInput("channel '{}' has a part '{}'; expected a path without '.' or '..'",
                          channel, part.string());
    folder /= part;
  }
  if (folder.empty()) return invalidInput("channel '{}' names no folder", channel);
  return folder;
}

struct ExportState {
  std::map<std::string, std::uint64_t> counts;  // messages written per channel
  std::map<std::string, std::string> skipped;   // channel -> its type, when it has no ASN.1 type
  std::uint64_t bytes = 0;
  std::vector<std::uint8_t> buffer;
};

Status exportMessage(const ExportArguments& args, const io::ReplayMessage& m, ExportState& state,
                     std::ofstream& index) {
  const std::string where = fmt::format("channel '{}' at {} ns", m.channel(), m.logTimeNs());
  if (!asn1::hasAsn1Type(m.type())) {
    if (!args.channels.empty())
      return invalidInput(
          "{}: {} has no ASN.1 type; expected one of Timestamp, Transform, "
          "PoseWithCovariance, RigidBodyState, Bearing, CameraModel, Image, "
          "PointCloud",
          where, m.type() ? m.type().name() : "message of another schema");
    state.skipped.emplace(m.channel(), m.type() ? m.type().name() : m.schemaName());
    return Status::ok();
  }
  Result<Value> value = m.decode();
  if (!value) return value.status().withContext(where);
  Result<asn1::Asn1Type> type = asn1::asn1TypeOf(*value);
  if (!type) return type.status().withContext(where);
  CDFF_RETURN_IF_ERROR(asn1::encode(*value, state.buffer).withContext(where));
  Result<fs::path> folder = channelFolder(m.channel());
  if (!folder) return folder.status();
  std::uint64_t& n = state.counts[m.channel()];
  const fs::path file = *folder / fmt::format("{:06d}.{}.uper", n, asn1::asn1Name(*type));
  CDFF_RETURN_IF_ERROR(writeFile(fs::path(args.output) / file, state.buffer));
  index << fmt::format("{},{},{},{},{},{}\n", m.channel(), n, m.logTimeNs(), asn1::asn1Name(*type),
                       state.buffer.size(), file.string());
  ++n;
  state.bytes += state.buffer.size();
  return Status::ok();
}

int runExport(const ExportArguments& args) {
  const auto fail = [](const Status& s) {
    fmt::print(stderr, "error: {}\n", s.message());
    return 1;
  };
  io::ReplayOptions options;
  options.channels = args.channels;
  io::Replay replay;
  if (Status s = replay.open(args.inputs, options); !s) return fail(s);
  std::error_code ec;
  fs::create_directories(args.output, ec);
  if (ec) return fail(ioError("cannot create '{}': {}", args.output, ec.message()));
  std::ofstream index(fs::path(args.output) / "index.csv", std::ios::trunc);
  index << "channel,index,log_time_ns,asn1_type,bytes,file\n";
  ExportState state;
  Status status;
  while (status && replay.next()) status = exportMessage(args, replay.message(), state, index);
  if (status && !replay.status()) status = replay.status();
  index.close();
  if (status && !index) status = ioError("cannot write '{}/index.csv'", args.output);
  if (!status) return fail(status);
  std::uint64_t messages = 0;
  for (const auto& [channel, n] : state.counts) messages += n;
  fmt::print("{} messages on {} channels -> {} ({} bytes of uPER)\n", messages, state.counts.size(),
             args.output, state.bytes);
  for (const auto& [channel, type] : state.skipped)
    fmt::print("  not exported: {} ({} has no ASN.1 type)\n", channel, type);
  return 0;
}

}  // namespace

void addLogExportCommand(CLI::App& log, int& exit_code) {
  auto args = std::make_shared<ExportArguments>();
  CLI::App* cmd = log.add_subcommand(
      "export",
      "Write the messages as the seed's ASN.1 types in uPER, one file per message, and an "
      "index.csv (docs/asn1.md)");
  cmd->add_option("--asn1-uper", args->output, "Output folder")->required();
  cmd->add_option("FILE", args->inputs, "Input MCAP file(s), merged by time")->required();
  cmd->add_option("--channel,-c", args->channels,
                  "Only this channel (repeatable); a channel whose type has no ASN.1 type is then "
                  "an error. Default: every channel with one");
  cmd->callback([args, &exit_code] { exit_code = runExport(*args); });
}

}  // namespace cdff::app
