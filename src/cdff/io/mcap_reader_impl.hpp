#pragma once
// Internal to cdff_io: the MCAP reader's state (McapReader::Impl) and what its parts share
// (mcap_reader.cpp: opening and the public interface; mcap_reader_summary.cpp: the summary;
// mcap_reader_scan.cpp: recovery by scanning the data section; mcap_reader_chunk.cpp: chunk
// loading; mcap_reader_iterator.cpp: log-time ordered iteration).
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <lz4frame.h>
#include <zstd.h>

#include "cdff/io/mcap.hpp"
#include "cdff/io/mcap_format.hpp"

namespace cdff::io {

namespace detail {

using namespace format;  // the record format, throughout the reader's parts

// ---- byte sources ----------------------------------------------------------------------------

class Source {
 public:
  virtual ~Source() = default;
  virtual Status read(std::uint64_t offset, std::size_t n, std::uint8_t* out) const = 0;
  std::uint64_t size = 0;
};

// ---- chunk decompression ---------------------------------------------------------------------

struct Decompressor {
  ZSTD_DCtx* zstd = nullptr;
  LZ4F_dctx* lz4 = nullptr;
  ~Decompressor() {
    if (zstd) ZSTD_freeDCtx(zstd);
    if (lz4) LZ4F_freeDecompressionContext(lz4);
  }

  // Decompresses `in` into exactly `out.size()` bytes; returns an empty string or what failed.
  std::string run(Compression compression, Bytes in, ByteVector& out) {
    if (compression == Compression::kZstd) {
      if (!zstd) zstd = ZSTD_createDCtx();
      const std::size_t n = ZSTD_decompressDCtx(zstd, out.data(), out.size(), in.data(), in.size());
      if (ZSTD_isError(n))
        return fmt::format("zstd decompression failed: {}", ZSTD_getErrorName(n));
      if (n != out.size())
        return fmt::format("zstd data decompresses to {} bytes; the chunk says {}", n, out.size());
      return {};
    }
    if (!lz4 && LZ4F_isError(LZ4F_createDecompressionContext(&lz4, LZ4F_VERSION)))
      return "cannot create an lz4 decompression context";
    LZ4F_resetDecompressionContext(lz4);
    const std::uint8_t* src = in.data();
    std::size_t src_left = in.size();
    std::uint8_t* dst = out.data();
    std::size_t dst_left = out.size();
    for (;;) {
      std::size_t in_n = src_left, out_n = dst_left;
      const std::size_t r = LZ4F_decompress(lz4, dst, &out_n, src, &in_n, nullptr);
      if (LZ4F_isError(r)) return fmt::format("lz4 decompression failed: {}", LZ4F_getErrorName(r));
      src += in_n;
      src_left -= in_n;
      dst += out_n;
      dst_left -= out_n;
      if (r == 0) break;  // frame complete
      if (in_n == 0 && out_n == 0) {
        if (dst_left == 0)
          return fmt::format("lz4 data decompresses to more than the {} bytes the chunk says",
                             out.size());
        return "lz4 data ends before its frame is complete";
      }
    }
    if (dst_left != 0)
      return fmt::format("lz4 data decompresses to {} bytes; the chunk says {}",
                         out.size() - dst_left, out.size());
    return {};
  }
};

// Parses the records of a chunk; calls on_message(offset, fixed fields, data) for each message,
// on_schema / on_channel for definitions. Returns an empty string or what went wrong (the
// records before the failure have been delivered).
template <typename OnMessage, typename OnSchema, typename OnChannel>
std::string parseRecords(Bytes records, OnMessage&& on_message, OnSchema&& on_schema,
                         OnChannel&& on_channel) {
  std::size_t pos = 0;
  while (pos < records.size()) {
    if (records.size() - pos < kRecordPrefix)
      return fmt::format("{} stray bytes at records offset {}", records.size() - pos, pos);
    const std::uint8_t op = records[pos];
    std::uint64_t len = 0;
    std::memcpy(&len, records.data() + pos + 1, 8);
    if (len > records.size() - pos - kRecordPrefix)
      return fmt::format("{} record at records offset {} claims {} bytes; {} remain",
                         opcodeName(op), pos, len, records.size() - pos - kRecordPrefix);
    const std::uint8_t* body = records.data() + pos + kRecordPrefix;
    Cursor c(body, static_cast<std::size_t>(len), pos + kRecordPrefix);
    switch (op) {
      case kMessage: {
        if (len < kMessageFixed)
          return fmt::format("Message record at records offset {} is {} bytes; expected >= 22", pos,
                             len);
        std::uint16_t channel = 0;
        std::uint32_t sequence = 0;
        std::uint64_t log_time = 0, publish_time = 0;
        std::memcpy(&channel, body, 2);
        std::memcpy(&sequence, body + 2, 4);
        std::memcpy(&log_time, body + 6, 8);
        std::memcpy(&publish_time, body + 14, 8);
        on_message(pos, channel, sequence, log_time, publish_time,
                   Bytes(body + kMessageFixed, static_cast<std::size_t>(len) - kMessageFixed));
        break;
      }
      case kSchema: {
        Schema s;
        if (!parseSchema(c, s)) return c.error() + " (records offset)";
        on_schema(pos, std::move(s));
        break;
      }
      case kChannel: {
        Channel ch;
        if (!parseChannel(c, ch)) return c.error() + " (records offset)";
        on_channel(pos, std::move(ch));
        break;
      }
      case kHeader:
      case kFooter:
      case kChunk:
      case kMessageIndex:
      case kChunkIndex:
      case kAttachment:
      case kAttachmentIndex:
      case kStatistics:
      case kMetadata:
      case kMetadataIndex:
      case kSummaryOffset:
      case kDataEnd:
        return fmt::format("a {} record (records offset {}) is not allowed inside a chunk",
                           opcodeName(op), pos);
      default:
        break;
    }
    pos += kRecordPrefix + static_cast<std::size_t>(len);
  }
  return {};
}

}  // namespace detail

// ---- the reader ------------------------------------------------------------------------------

struct McapReader::Impl {
  std::string path;
  std::unique_ptr<detail::Source> source;
  McapReaderOptions options;
  std::string profile, library;
  std::uint64_t header_end = 0;
  std::map<std::uint16_t, Schema> schemas;
  std::map<std::uint16_t, Channel> channels;
  Statistics stats;
  std::vector<ChunkInfo> chunks;
  std::vector<AttachmentInfo> attachments;
  std::vector<MetadataInfo> metadata;
  RecoveryReport recovery;

  Status fileError(std::string what) const {
    return format::corrupt(fmt::format("'{}': {}", path, what));
  }

  Status readAt(std::uint64_t offset, std::size_t n, format::ByteVector& out) const {
    out.resize(n);
    return source->read(offset, n, out.data());
  }

  Status open();
  Status readHeader();
  enum class Summary { kRead, kNoFooter, kNotIndexed, kDamaged };
  // kRead, or why the summary cannot be used (kDamaged: `why` at `why_offset`).
  Summary readSummary(std::string& why, std::uint64_t& why_offset);
  // The summary section's bytes, which start at byte offset `start`, and the file's last 37 bytes
  // (footer and magic), whose first 25 the summary CRC covers too.
  struct SummarySection {
    std::uint64_t start = 0, footer_at = 0;
    std::uint8_t tail[format::kRecordPrefix + format::kFooterContent + 8];
    format::ByteVector bytes;
  };
  // Reads the footer and the summary section it points at, checking its CRC: kRead, or why
  // there is no usable summary, as readSummary().
  Summary readSummarySection(SummarySection& section, std::string& why,
                             std::uint64_t& why_offset) const;
  std::uint64_t data_end = 0;  // offset of the Data End record (indexed files)
  std::uint32_t data_section_crc = 0;
  // Rebuilds the index from the data section (see mcap_reader_scan.cpp).
  class Scanner;
  void scan();
  void addDamage(std::uint64_t offset, std::string what) {
    recovery.damages.push_back({offset, std::move(what)});
  }

  /// Reads and decompresses a chunk (or an unchunked run); `records` points into `storage`.
  std::string loadChunk(const ChunkInfo& chunk, detail::Decompressor& d,
                        std::shared_ptr<format::ByteVector>& storage, Bytes& records) const;
};

}  // namespace cdff::io
