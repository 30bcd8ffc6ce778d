// The MCAP reader's recovery: when the summary is missing or damaged, the data section is read
// record by record, rebuilding the index (schemas, channels, chunks, runs of unchunked messages,
// attachments, metadata, statistics) up to the first damage.
#include <algorithm>
#include <cstring>

#include "cdff/io/mcap_reader_impl.hpp"

namespace cdff::io {

using namespace format;
using detail::Decompressor;
using detail::parseRecords;

class McapReader::Impl::Scanner {
 public:
  explicit Scanner(Impl& reader) : r_(reader), pos_(reader.header_end) {}

  void run() {
    const std::uint64_t size = r_.source->size;
    while (pos_ < size) {
      if (!readRecord()) break;
    }
    closeRun();
    if (!finished_ && r_.recovery.damages.empty())
      r_.addDamage(pos_,
                   "the data section ends without a Data End record, summary or footer: the file "
                   "was truncated or its writer did not finish (killed?); every chunk before "
                   "this offset is intact");
    s_.schema_count = static_cast<std::uint16_t>(r_.schemas.size());
    s_.channel_count = static_cast<std::uint32_t>(r_.channels.size());
    r_.stats = std::move(s_);
    r_.recovery.intact_bytes =
        r_.recovery.damages.empty() ? size : r_.recovery.damages.front().offset;
  }

 private:
  // Reads the record at pos_ and moves past it; false where the scan stops (damage, or the end
  // of the data section).
  bool readRecord() {
    const std::uint64_t size = r_.source->size;
    const std::uint64_t pos = pos_;
    if (size - pos < kRecordPrefix) {
      r_.addDamage(
          pos, fmt::format("truncated: the file ends {} bytes into a record header", size - pos));
      return false;
    }
    std::uint8_t prefix[kRecordPrefix];
    if (!r_.source->read(pos, kRecordPrefix, prefix).isOk()) {
      r_.addDamage(pos, "unreadable record header");
      return false;
    }
    const std::uint8_t op = prefix[0];
    std::uint64_t len = 0;
    std::memcpy(&len, prefix + 1, 8);
    if (op == 0 || (op > kDataEnd && op < 0x80)) {
      r_.addDamage(pos,
                   fmt::format("invalid record opcode 0x{:02X} (corrupt data, or garbage after "
                               "the last record)",
                               op));
      return false;
    }
    if (len > size - pos - kRecordPrefix) {
      r_.addDamage(pos, fmt::format("truncated: {} record claims {} bytes but the file has only {} "
                                    "more",
                                    opcodeName(op), len, size - pos - kRecordPrefix));
      return false;
    }
    const std::uint64_t next = pos + kRecordPrefix + len;
    const bool top_level_data = op == kSchema || op == kChannel || op == kMessage;
    if (!top_level_data) closeRun();
    if (top_level_data || op == kAttachment || op == kMetadata || op == kFooter) {
      const std::size_t want = static_cast<std::size_t>(
          op == kAttachment ? std::min<std::uint64_t>(len, 1u << 20) : len);
      if (len > r_.options.max_chunk_bytes) {
        r_.addDamage(pos, fmt::format("{} record of {} bytes exceeds the reader's limit",
                                      opcodeName(op), len));
        return false;
      }
      if (!r_.readAt(pos + kRecordPrefix, want, buf_).isOk()) {
        r_.addDamage(pos, "unreadable record");
        return false;
      }
    }
    if (!readContent(op, len, next)) return false;
    pos_ = next;
    return true;
  }

  // The content of the record of opcode `op` at pos_ (its first bytes in buf_ for the records
  // that need them), `len` bytes long, ending at `next`. False where the scan stops.
  bool readContent(std::uint8_t op, std::uint64_t len, std::uint64_t next) {
    const std::uint64_t pos = pos_;
    Cursor c(buf_.data(), buf_.size(), pos + kRecordPrefix);
    switch (op) {
      case kSchema: {
        Schema schema;
        if (!parseSchema(c, schema)) {
          r_.addDamage(pos, c.error());
          break;
        }
        addSchema(pos, std::move(schema));
        break;
      }
      case kChannel: {
        Channel channel;
        if (!parseChannel(c, channel)) {
          r_.addDamage(pos, c.error());
          break;
        }
        addChannel(pos, std::move(channel));
        break;
      }
      case kMessage:
        readMessage(len, next);
        break;
      case kChunk:
        readChunk(len);
        break;
      case kAttachment:
        readAttachment(c, len);
        break;
      case kMetadata: {
        MetadataInfo m;
        m.offset = pos;
        m.length = kRecordPrefix + len;
        if (!c.string(m.name, "Metadata name")) {
          r_.addDamage(pos, c.error());
          break;
        }
        r_.metadata.push_back(std::move(m));
        ++s_.metadata_count;
        break;
      }
      case kHeader:
        r_.addDamage(pos, "a second Header record");
        return false;
      case kDataEnd:
      case kFooter:
        finished_ = true;
        return false;
      default:
        break;  // message indexes (rebuilt from the chunks), summary records, unknown records
    }
    return true;
  }

  // A message outside chunks: it joins the current run of unchunked records.
  void readMessage(std::uint64_t len, std::uint64_t next) {
    const std::uint64_t pos = pos_;
    if (len < kMessageFixed) {
      r_.addDamage(pos, fmt::format("Message record of {} bytes; expected at least 22", len));
      return;
    }
    std::uint16_t channel = 0;
    std::uint64_t t = 0;
    std::memcpy(&channel, buf_.data(), 2);
    std::memcpy(&t, buf_.data() + 6, 8);
    if (!r_.channels.count(channel)) {
      r_.addDamage(pos, fmt::format("Message on channel id {}, which no earlier Channel record "
                                    "defines",
                                    channel));
      return;
    }
    noteMessage(channel, t);
    if (!in_run_) {
      run_ = ChunkInfo{};
      run_.unchunked = true;
      run_.offset = pos;
      run_.message_start_time = run_.message_end_time = t;
      in_run_ = true;
    }
    run_.length = next - run_.offset;
    run_.compressed_size = run_.uncompressed_size = run_.length;
    run_.message_start_time = std::min(run_.message_start_time, t);
    run_.message_end_time = std::max(run_.message_end_time, t);
    run_channels_.push_back(channel);
  }

  // A chunk: its header fields for the index, then its records (loaded and checked).
  void readChunk(std::uint64_t len) {
    const std::uint64_t pos = pos_;
    ChunkInfo ci;
    ci.offset = pos;
    ci.length = kRecordPrefix + len;
    // The header fields, for the index: they are before the records.
    std::uint8_t h[8 + 8 + 8 + 4 + 4];
    if (len < sizeof(h) || !r_.source->read(pos + kRecordPrefix, sizeof(h), h).isOk()) {
      r_.addDamage(pos, fmt::format("Chunk record of {} bytes is too short", len));
      return;
    }
    std::memcpy(&ci.message_start_time, h, 8);
    std::memcpy(&ci.message_end_time, h + 8, 8);
    std::memcpy(&ci.uncompressed_size, h + 16, 8);
    std::uint32_t name_len = 0;
    std::memcpy(&name_len, h + 28, 4);
    std::string compression;
    if (name_len <= 16 && len >= sizeof(h) + name_len + 8) {
      compression.resize(name_len);
      if (!r_.source
               ->read(pos + kRecordPrefix + sizeof(h), name_len,
                      reinterpret_cast<std::uint8_t*>(compression.data()))
               .isOk())
        compression = "?";
    } else {
      compression = "?";
    }
    const auto comp = compressionFromString(compression);
    ci.compression = comp && compression != "none" ? *comp : Compression::kNone;
    ci.compressed_size = len - std::min<std::uint64_t>(len, sizeof(h) + name_len + 8);
    std::shared_ptr<ByteVector> storage;
    Bytes records;
    std::string error = r_.loadChunk(ci, d_, storage, records);
    if (!error.empty()) {
      r_.addDamage(pos, "chunk skipped: " + error);
      return;
    }
    ci.channels = readChunkRecords(records);
    ++s_.chunk_count;
    if (!ci.channels.empty()) r_.chunks.push_back(std::move(ci));
  }

  // The records of the chunk at pos_: its definitions and messages are noted; returns the
  // channels its messages are on.
  std::vector<std::uint16_t> readChunkRecords(Bytes records) {
    const std::uint64_t pos = pos_;
    std::vector<std::uint16_t> chunk_channels;
    std::string inner_error;
    const std::string error = parseRecords(
        records,
        [&](std::size_t at, std::uint16_t channel, std::uint32_t, std::uint64_t t, std::uint64_t,
            Bytes) {
          if (!r_.channels.count(channel)) {
            if (inner_error.empty())
              inner_error = fmt::format(
                  "message at records offset {} is on channel id {}, "
                  "which no Channel record defines",
                  at, channel);
            return;
          }
          noteMessage(channel, t);
          chunk_channels.push_back(channel);
        },
        [&](std::size_t, Schema schema) { addSchema(pos, std::move(schema)); },
        [&](std::size_t, Channel channel) { addChannel(pos, std::move(channel)); });
    if (!error.empty()) r_.addDamage(pos, "chunk partly read: " + error);
    if (!inner_error.empty()) r_.addDamage(pos, "chunk: " + inner_error);
    std::sort(chunk_channels.begin(), chunk_channels.end());
    chunk_channels.erase(std::unique(chunk_channels.begin(), chunk_channels.end()),
                         chunk_channels.end());
    return chunk_channels;
  }

  void readAttachment(Cursor& c, std::uint64_t len) {
    const std::uint64_t pos = pos_;
    AttachmentInfo a;
    a.offset = pos;
    a.length = kRecordPrefix + len;
    std::uint64_t data_size = 0;
    if (!c.read(a.log_time, "Attachment log time") ||
        !c.read(a.create_time, "Attachment create time") || !c.string(a.name, "Attachment name") ||
        !c.string(a.media_type, "Attachment media type") ||
        !c.read(data_size, "Attachment data size")) {
      r_.addDamage(pos, c.error());
      return;
    }
    a.data_size = data_size;
    r_.attachments.push_back(std::move(a));
    ++s_.attachment_count;
  }

  void noteMessage(std::uint16_t channel, std::uint64_t t) {
    ++s_.message_count;
    ++s_.channel_message_counts[channel];
    if (!have_messages_) {
      s_.message_start_time = s_.message_end_time = t;
      have_messages_ = true;
    } else {
      s_.message_start_time = std::min(s_.message_start_time, t);
      s_.message_end_time = std::max(s_.message_end_time, t);
    }
  }

  void addSchema(std::uint64_t at, Schema schema) {
    if (schema.id == 0) return;
    auto [it, inserted] = r_.schemas.try_emplace(schema.id, schema);
    if (!inserted && (it->second.name != schema.name || it->second.data != schema.data))
      r_.addDamage(at, fmt::format("Schema id {} is redefined differently ('{}' then '{}')",
                                   schema.id, it->second.name, schema.name));
  }

  void addChannel(std::uint64_t at, Channel channel) {
    auto [it, inserted] = r_.channels.try_emplace(channel.id, channel);
    if (!inserted &&
        (it->second.topic != channel.topic || it->second.schema_id != channel.schema_id ||
         it->second.message_encoding != channel.message_encoding))
      r_.addDamage(at, fmt::format("Channel id {} is redefined differently ('{}' then '{}')",
                                   channel.id, it->second.topic, channel.topic));
  }

  // Ends the current run of records outside chunks, indexed like a chunk.
  void closeRun() {
    if (!in_run_) return;
    std::sort(run_channels_.begin(), run_channels_.end());
    run_channels_.erase(std::unique(run_channels_.begin(), run_channels_.end()),
                        run_channels_.end());
    run_.channels = run_channels_;
    if (!run_.channels.empty()) r_.chunks.push_back(run_);
    in_run_ = false;
    run_channels_.clear();
  }

  Impl& r_;
  std::uint64_t pos_;
  bool finished_ = false;  // reached Data End or the footer
  Decompressor d_;
  Statistics s_;
  bool have_messages_ = false;
  ChunkInfo run_;  // the current run of records outside chunks
  bool in_run_ = false;
  std::vector<std::uint16_t> run_channels_;
  ByteVector buf_;
};

void McapReader::Impl::scan() {
  Scanner(*this).run();
}

}  // namespace cdff::io
