#pragma once
// MCAP recording files (https://mcap.dev/spec, major version 0): a streaming writer and an indexed,
// damage-tolerant reader, written against the published specification.
//
// Files are chunked (optionally lz4- or zstd-compressed), every chunk is followed by its message
// indexes, and close() writes the summary (schemas, channels, statistics, chunk / attachment /
// metadata indexes), the summary offsets and the footer, so that any MCAP reader can seek.
// Times in this layer are MCAP times: uint64 nanoseconds. The typed layer (recorder.hpp,
// replay.hpp) converts from and to cdff::Timestamp (microseconds).

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "cdff/types/status.hpp"

namespace cdff::io {

using Bytes = std::span<const std::uint8_t>;

enum class Compression : std::uint8_t { kNone, kLz4, kZstd };

/// The MCAP name of a compression: "", "lz4" or "zstd".
const char* mcapName(Compression compression);
/// "none", "lz4" or "zstd" (for people).
const char* toString(Compression compression);
/// Parses "none" (or ""), "lz4", "zstd".
std::optional<Compression> compressionFromString(std::string_view name);

struct Schema {
  std::uint16_t id = 0;
  std::string name;      // e.g. "foxglove.RawImage"
  std::string encoding;  // "protobuf", "jsonschema", ... ("" = no schema)
  std::vector<std::uint8_t> data;
};

struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;  // 0: no schema
  std::string topic;
  std::string message_encoding;  // "protobuf", "json", ...
  std::map<std::string, std::string> metadata;
};

struct Statistics {
  std::uint64_t message_count = 0;
  std::uint16_t schema_count = 0;
  std::uint32_t channel_count = 0;
  std::uint32_t attachment_count = 0;
  std::uint32_t metadata_count = 0;
  std::uint32_t chunk_count = 0;
  std::uint64_t message_start_time = 0;  // ns; 0 when there are no messages
  std::uint64_t message_end_time = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

// ---------------------------------------------------------------------------------------------
// Writer

struct McapWriterOptions {
  Compression compression = Compression::kLz4;
  /// 0: the compressor's default (lz4: fast mode; zstd: level 1). Higher is smaller and slower.
  int compression_level = 0;
  /// A chunk is closed and written once its records reach this many (uncompressed) bytes. A
  /// message larger than this gets a chunk of its own. Memory use is about twice this, plus the
  /// largest message.
  std::size_t chunk_size = 4u << 20;
  /// A chunk is also closed once it spans this much log time (ns; 0: no limit), which bounds how
  /// much of a slow stream a killed writer can lose.
  std::uint64_t chunk_duration_ns = 1'000'000'000;
  bool chunk_crc = true;         // CRC of every chunk's uncompressed records
  bool data_section_crc = true;  // CRC of the whole data section, in the Data End record
  /// fsync() after every chunk: finished chunks survive a power loss, not only a killed process
  /// (written chunks always survive the death of the writing process).
  bool sync_each_chunk = false;
  std::string profile;  // MCAP profile ("" for CDFF recordings)
  std::string library = "cdff";
};

/// Writes one MCAP file, streaming: memory stays bounded by the chunk size whatever the length of
/// the recording. Not thread-safe (Recorder adds a lock). Every call returns a Status; after an
/// I/O error the writer refuses further writes and close() reports the error again.
class McapWriter {
 public:
  McapWriter();
  ~McapWriter();  // closes the file (writing its summary) if still open
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  Status open(const std::string& path, const McapWriterOptions& options = {});
  bool isOpen() const;
  const std::string& path() const;

  /// Registers a schema; returns its id (>= 1). Identical schemas get the same id.
  Result<std::uint16_t> addSchema(const std::string& name, const std::string& encoding, Bytes data);
  /// Registers a channel on a schema (0: none); returns its id. A topic may be registered once.
  Result<std::uint16_t> addChannel(const std::string& topic, const std::string& message_encoding,
                                   std::uint16_t schema_id,
                                   const std::map<std::string, std::string>& metadata = {});

  /// Appends one message. `parts` are concatenated into the message data (a protobuf head and
  /// the pixels it describes, say) so large payloads are copied once, into the chunk.
  /// `sequence` defaults to a per-channel counter starting at 0.
  Status write(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
               std::span<const Bytes> parts, std::optional<std::uint32_t> sequence = {});
  Status write(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
               Bytes data, std::optional<std::uint32_t> sequence = {}) {
    return write(channel_id, log_time, publish_time, std::span<const Bytes>(&data, 1), sequence);
  }

  /// An attachment (a calibration file, a target model, a configuration), outside the chunks.
  Status writeAttachment(const std::string& name, const std::string& media_type,
                         std::uint64_t log_time, Bytes data, std::uint64_t create_time = 0);
  /// A named set of key-value pairs (run id, git revision, scenario, ...).
  Status writeMetadata(const std::string& name, const std::map<std::string, std::string>& values);

  /// Closes the current chunk and hands it to the operating system.
  Status flush();
  /// Writes the last chunk, the summary and the footer, and closes the file.
  Status close();

  const Statistics& statistics() const;
  /// Bytes written to the file so far.
  std::uint64_t bytesWritten() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// ---------------------------------------------------------------------------------------------
// Reader

/// A chunk (or, in files that do not use chunks, a run of top-level records) and what its index
/// says about it.
struct ChunkInfo {
  std::uint64_t offset = 0;  // of the Chunk record (or of the first record of the run)
  std::uint64_t length = 0;  // of the whole record (or run), opcode and length prefix included
  std::uint64_t message_start_time = 0;
  std::uint64_t message_end_time = 0;
  Compression compression = Compression::kNone;
  std::uint64_t compressed_size = 0;
  std::uint64_t uncompressed_size = 0;
  std::vector<std::uint16_t> channels;  // channels with messages in it; empty: unknown
  bool unchunked = false;               // a run of records outside any chunk
};

struct AttachmentInfo {
  std::uint64_t offset = 0;
  std::uint64_t length = 0;
  std::uint64_t log_time = 0;
  std::uint64_t create_time = 0;
  std::uint64_t data_size = 0;
  std::string name;
  std::string media_type;
};

struct MetadataInfo {
  std::uint64_t offset = 0;
  std::uint64_t length = 0;
  std::string name;
};

/// A place where a file is damaged: what was found, at which byte offset of the file.
struct Damage {
  std::uint64_t offset = 0;
  std::string what;
  std::string toString() const;
};

/// How a file was opened, and what could not be read.
struct RecoveryReport {
  /// True when the summary and footer were read and trusted; false when the reader had to scan
  /// the data section (file without summary, truncated file, killed writer, corrupt summary).
  bool indexed = false;
  std::vector<Damage> damages;  // empty for a sound file
  /// Bytes from the start of the file that scanned cleanly (== file size for a sound file).
  std::uint64_t intact_bytes = 0;
  bool damaged() const { return !damages.empty(); }
};

struct McapReaderOptions {
  /// Chunks whose records would decompress to more than this are refused as corrupt (guards
  /// against absurd sizes in damaged or hostile files).
  std::uint64_t max_chunk_bytes = 1ull << 32;
  bool verify_crcs = true;
};

/// One message. `data` stays valid as long as `owner` (the decompressed chunk) is held; the
/// MessageView itself may be copied freely.
struct MessageView {
  const Channel* channel = nullptr;
  const Schema* schema = nullptr;  // null when the channel has no schema
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;
  std::uint64_t publish_time = 0;
  Bytes data;
  std::shared_ptr<const void> owner;
};

struct ReadOptions {
  std::optional<std::uint64_t> start_time;  // ns, inclusive
  std::optional<std::uint64_t> end_time;    // ns, inclusive
  std::vector<std::uint16_t> channels;      // empty: every channel
};

class McapReader;

/// Messages of one file in log-time order (ties: file order). Chunks are read lazily, only those
/// the index says overlap the requested time range and channels. A chunk that turns out to be
/// damaged is skipped and reported in damages(); iteration goes on with the next one.
class MessageIterator {
 public:
  MessageIterator(MessageIterator&&) noexcept;
  MessageIterator& operator=(MessageIterator&&) noexcept;
  ~MessageIterator();

  /// Advances to the next message; false at the end.
  bool next();
  const MessageView& message() const;
  /// Ok, or the first damage met so far (kCorruptData, with its byte offset).
  Status status() const;
  const std::vector<Damage>& damages() const;
  /// Chunks decompressed so far (the cost of a seek).
  std::size_t chunksLoaded() const;

 private:
  friend class McapReader;
  struct Impl;
  explicit MessageIterator(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Reads an MCAP file. open() reads the footer and the summary, O(chunks) whatever the number of
/// messages; when they are missing or damaged it scans the data section instead, keeps every
/// intact chunk and reports in recovery() where the damage starts. open() fails only when nothing
/// can be read (not MCAP, empty, unreadable).
class McapReader {
 public:
  McapReader();
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  Status open(const std::string& path, const McapReaderOptions& options = {});
  /// Reads a file held in memory (tests, fuzzing); `name` stands for the path in messages.
  Status openBuffer(std::vector<std::uint8_t> bytes, const std::string& name = "<memory>",
                    const McapReaderOptions& options = {});

  const std::string& path() const;
  std::uint64_t fileSize() const;
  const std::string& profile() const;
  const std::string& library() const;

  const std::map<std::uint16_t, Schema>& schemas() const;
  const std::map<std::uint16_t, Channel>& channels() const;
  /// The channel on `topic`, or null.
  const Channel* channel(std::string_view topic) const;
  const Schema* schemaOf(const Channel& channel) const;
  /// From the Statistics record, or counted by the scan when there is none.
  const Statistics& statistics() const;
  const std::vector<ChunkInfo>& chunks() const;
  const std::vector<AttachmentInfo>& attachments() const;
  const std::vector<MetadataInfo>& metadata() const;
  const RecoveryReport& recovery() const;

  MessageIterator messages(const ReadOptions& options = {}) const;

  /// Reads the whole file: decompresses every chunk, checks its CRC and its records (unless
  /// `chunks` is false: a message iteration already does that), and checks the data-section CRC
  /// when the file has one. O(file size). Returns what is damaged (empty for a sound file);
  /// open() alone only reads the summary.
  std::vector<Damage> verify(bool chunks = true) const;

  Result<std::vector<std::uint8_t>> readAttachment(const AttachmentInfo& attachment) const;
  Result<std::map<std::string, std::string>> readMetadata(const MetadataInfo& metadata) const;

 private:
  friend class MessageIterator;
  struct Impl;
  std::shared_ptr<Impl> impl_;  // shared with the iterators
};

}  // namespace cdff::io
