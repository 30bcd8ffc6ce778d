// The MCAP reader's summary: the footer, the summary section it points at, and the index records
// in it (schemas, channels, chunk, attachment and metadata indexes, statistics).
#include <algorithm>
#include <cstring>

#include "cdff/io/crc32.hpp"
#include "cdff/io/mcap_reader_impl.hpp"

namespace cdff::io {

using namespace format;

namespace {

// The records of a summary section, before they replace the reader's.
struct SummaryRecords {
  std::map<std::uint16_t, Schema> schemas;
  std::map<std::uint16_t, Channel> channels;
  std::vector<ChunkInfo> chunks;
  std::vector<AttachmentInfo> attachments;
  std::vector<MetadataInfo> metadata;
  bool have_stats = false;
  Statistics stats;
};

// A Chunk Index record at byte offset `at`, whose chunk must lie in the data section
// [header_end, data_limit). Failures are left in the cursor.
void readChunkIndex(Cursor& c, std::uint64_t at, std::uint64_t header_end, std::uint64_t data_limit,
                    std::vector<ChunkInfo>& out) {
  ChunkInfo ci;
  std::uint32_t map_len = 0;
  std::string compression;
  std::uint64_t index_length = 0;
  if (!c.read(ci.message_start_time, "Chunk Index start") ||
      !c.read(ci.message_end_time, "Chunk Index end") || !c.read(ci.offset, "Chunk Index offset") ||
      !c.read(ci.length, "Chunk Index length") ||
      !c.read(map_len, "Chunk Index message index offsets"))
    return;
  if (map_len % 10 != 0 || map_len > c.remaining()) {
    c.fail(
        fmt::format("Chunk Index message index map of {} bytes at byte offset {} is "
                    "malformed",
                    map_len, c.offset()));
    return;
  }
  for (std::uint32_t i = 0; i < map_len / 10; ++i) {
    std::uint16_t id = 0;
    std::uint64_t off = 0;
    c.read(id, "Chunk Index channel");
    c.read(off, "Chunk Index offset");
    ci.channels.push_back(id);
  }
  if (!c.read(index_length, "Chunk Index message index length") ||
      !c.string(compression, "Chunk Index compression") ||
      !c.read(ci.compressed_size, "Chunk Index compressed size") ||
      !c.read(ci.uncompressed_size, "Chunk Index uncompressed size"))
    return;
  const auto comp = compressionFromString(compression);
  if (!comp || compression == "none") {
    c.fail(
        fmt::format("Chunk Index at byte offset {}: unsupported compression '{}'; "
                    "expected '', 'lz4' or 'zstd'",
                    at, compression));
    return;
  }
  ci.compression = *comp;
  if (ci.offset < header_end || ci.length < kRecordPrefix || ci.offset > data_limit ||
      ci.length > data_limit - ci.offset) {
    c.fail(
        fmt::format("Chunk Index at byte offset {} points at [{}, +{}), outside the "
                    "data section [{}, {})",
                    at, ci.offset, ci.length, header_end, data_limit));
    return;
  }
  std::sort(ci.channels.begin(), ci.channels.end());
  out.push_back(std::move(ci));
}

// A Statistics record. Failures are left in the cursor.
void readStatistics(Cursor& c, SummaryRecords& out) {
  Statistics& s = out.stats;
  std::uint32_t map_len = 0;
  if (!c.read(s.message_count, "Statistics message count") ||
      !c.read(s.schema_count, "Statistics schema count") ||
      !c.read(s.channel_count, "Statistics channel count") ||
      !c.read(s.attachment_count, "Statistics attachment count") ||
      !c.read(s.metadata_count, "Statistics metadata count") ||
      !c.read(s.chunk_count, "Statistics chunk count") ||
      !c.read(s.message_start_time, "Statistics start time") ||
      !c.read(s.message_end_time, "Statistics end time") ||
      !c.read(map_len, "Statistics channel message counts"))
    return;
  if (map_len % 10 != 0 || map_len > c.remaining()) {
    c.fail(fmt::format("Statistics channel count map of {} bytes is malformed", map_len));
    return;
  }
  for (std::uint32_t i = 0; i < map_len / 10; ++i) {
    std::uint16_t id = 0;
    std::uint64_t count = 0;
    c.read(id, "Statistics channel");
    c.read(count, "Statistics count");
    s.channel_message_counts[id] = count;
  }
  out.have_stats = true;
}

// Reads one summary record (opcode `op` at byte offset `at`; its content in the cursor). False,
// with `why`, for a record that may not be in a summary; failures to parse are left in the
// cursor. Unknown records are skipped, as the specification asks.
bool readSummaryRecord(std::uint8_t op, Cursor& c, std::uint64_t at, std::uint64_t header_end,
                       std::uint64_t data_limit, SummaryRecords& out, std::string& why) {
  switch (op) {
    case kSchema: {
      Schema s;
      if (!parseSchema(c, s)) break;
      if (s.id != 0) out.schemas[s.id] = std::move(s);
      break;
    }
    case kChannel: {
      Channel ch;
      if (!parseChannel(c, ch)) break;
      out.channels[ch.id] = std::move(ch);
      break;
    }
    case kChunkIndex:
      readChunkIndex(c, at, header_end, data_limit, out.chunks);
      break;
    case kAttachmentIndex: {
      AttachmentInfo a;
      if (c.read(a.offset, "Attachment Index offset") &&
          c.read(a.length, "Attachment Index length") &&
          c.read(a.log_time, "Attachment Index log time") &&
          c.read(a.create_time, "Attachment Index create time") &&
          c.read(a.data_size, "Attachment Index data size") &&
          c.string(a.name, "Attachment Index name") &&
          c.string(a.media_type, "Attachment Index media type"))
        out.attachments.push_back(std::move(a));
      break;
    }
    case kMetadataIndex: {
      MetadataInfo m;
      if (c.read(m.offset, "Metadata Index offset") && c.read(m.length, "Metadata Index length") &&
          c.string(m.name, "Metadata Index name"))
        out.metadata.push_back(std::move(m));
      break;
    }
    case kStatistics:
      readStatistics(c, out);
      break;
    case kSummaryOffset:
    case kDataEnd:
      break;
    case kHeader:
    case kFooter:
    case kMessage:
    case kChunk:
    case kMessageIndex:
    case kAttachment:
    case kMetadata:
      why = fmt::format("a {} record is not allowed in the summary section", opcodeName(op));
      return false;
    default:
      break;
  }
  return true;
}

}  // namespace

McapReader::Impl::Summary McapReader::Impl::readSummarySection(SummarySection& section,
                                                               std::string& why,
                                                               std::uint64_t& why_offset) const {
  const std::uint64_t size = source->size;
  constexpr std::uint64_t kTail = kRecordPrefix + kFooterContent + 8;
  why_offset = size;
  if (size < header_end + kTail) {
    return Summary::kNoFooter;
  }
  const std::uint64_t footer_at = size - kTail;
  std::uint8_t* tail = section.tail;
  if (!source->read(footer_at, kTail, tail).isOk()) {
    return Summary::kNoFooter;
  }
  std::uint64_t length = 0, summary_start = 0, summary_offset_start = 0;
  std::uint32_t summary_crc = 0;
  std::memcpy(&length, tail + 1, 8);
  std::memcpy(&summary_start, tail + 9, 8);
  std::memcpy(&summary_offset_start, tail + 17, 8);
  std::memcpy(&summary_crc, tail + 25, 4);
  if (std::memcmp(tail + kRecordPrefix + kFooterContent, kMagic, 8) != 0 || tail[0] != kFooter ||
      length != kFooterContent) {
    return Summary::kNoFooter;
  }
  if (summary_start == 0) {
    return Summary::kNotIndexed;  // a valid file without summary: scan it
  }
  why_offset = footer_at;
  if (summary_start < header_end || summary_start > footer_at ||
      (summary_offset_start != 0 &&
       (summary_offset_start < summary_start || summary_offset_start > footer_at))) {
    why = fmt::format(
        "the footer's summary offsets ({}, {}) are outside the file's summary "
        "area [{}, {}]",
        summary_start, summary_offset_start, header_end, footer_at);
    return Summary::kDamaged;
  }
  section.start = summary_start;
  section.footer_at = footer_at;
  ByteVector& summary = section.bytes;
  if (!readAt(summary_start, static_cast<std::size_t>(footer_at - summary_start), summary).isOk()) {
    why = "cannot read the summary section";
    return Summary::kDamaged;
  }
  if (summary_crc != 0 && options.verify_crcs) {
    std::uint32_t crc = crc32Update(0, summary.data(), summary.size());
    crc = crc32Update(crc, tail, kRecordPrefix + 16);
    if (crc != summary_crc) {
      why_offset = summary_start;
      why = fmt::format(
          "summary CRC mismatch: the summary section [{}, {}) has CRC 0x{:08X}, "
          "the footer says 0x{:08X}",
          summary_start, footer_at, crc, summary_crc);
      return Summary::kDamaged;
    }
  }
  return Summary::kRead;
}

McapReader::Impl::Summary McapReader::Impl::readSummary(std::string& why,
                                                        std::uint64_t& why_offset) {
  SummarySection section;
  if (const Summary found = readSummarySection(section, why, why_offset); found != Summary::kRead)
    return found;
  const ByteVector& summary = section.bytes;
  const std::uint64_t summary_start = section.start;
  SummaryRecords records;
  std::size_t pos = 0;
  const std::uint64_t data_limit = summary_start;
  while (pos < summary.size()) {
    const std::uint64_t at = summary_start + pos;
    why_offset = at;
    if (summary.size() - pos < kRecordPrefix) {
      why = fmt::format("summary section: {} trailing bytes, too few for a record",
                        summary.size() - pos);
      return Summary::kDamaged;
    }
    const std::uint8_t op = summary[pos];
    std::uint64_t len = 0;
    std::memcpy(&len, summary.data() + pos + 1, 8);
    if (len > summary.size() - pos - kRecordPrefix) {
      why = fmt::format("summary {} record claims {} bytes; only {} remain in the summary",
                        opcodeName(op), len, summary.size() - pos - kRecordPrefix);
      return Summary::kDamaged;
    }
    Cursor c(summary.data() + pos + kRecordPrefix, static_cast<std::size_t>(len),
             at + kRecordPrefix);
    if (!readSummaryRecord(op, c, at, header_end, data_limit, records, why))
      return Summary::kDamaged;
    if (!c.ok()) {
      why = "summary section: " + c.error();
      return Summary::kDamaged;
    }
    pos += kRecordPrefix + static_cast<std::size_t>(len);
  }
  for (const ChunkInfo& ci : records.chunks)
    for (std::uint16_t id : ci.channels)
      if (!records.channels.count(id)) {
        why_offset = ci.offset;
        why = fmt::format(
            "the chunk index of the chunk at byte offset {} names channel {}, "
            "which the summary does not define",
            ci.offset, id);
        return Summary::kDamaged;
      }
  if (!records.have_stats || (records.stats.message_count > 0 && records.chunks.empty())) {
    return Summary::kNotIndexed;  // partly indexed (no statistics or chunk index): scan
  }
  // The Data End record just before the summary carries the data-section CRC (for verify()).
  std::uint8_t end_record[kRecordPrefix + kDataEndContent];
  if (summary_start >= header_end + sizeof(end_record) &&
      source->read(summary_start - sizeof(end_record), sizeof(end_record), end_record).isOk() &&
      end_record[0] == kDataEnd) {
    data_end = summary_start - sizeof(end_record);
    std::memcpy(&data_section_crc, end_record + kRecordPrefix, 4);
  }
  std::sort(records.chunks.begin(), records.chunks.end(),
            [](const ChunkInfo& a, const ChunkInfo& b) { return a.offset < b.offset; });
  schemas = std::move(records.schemas);
  channels = std::move(records.channels);
  chunks = std::move(records.chunks);
  attachments = std::move(records.attachments);
  metadata = std::move(records.metadata);
  stats = std::move(records.stats);
  return Summary::kRead;
}

}  // namespace cdff::io
