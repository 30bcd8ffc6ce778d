// MCAP reader: summary first (O(chunks)), a scan of the data section when the summary is missing
// or damaged, and a lazy k-way merge of chunks for log-time ordered iteration.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>

#include <lz4frame.h>
#include <zstd.h>

#include "cdff/io/crc32.hpp"
#include "cdff/io/mcap.hpp"
#include "cdff/io/mcap_format.hpp"

namespace cdff::io {

using namespace format;

namespace format {

const char* opcodeName(std::uint8_t opcode) {
  switch (opcode) {
    case kHeader:
      return "Header";
    case kFooter:
      return "Footer";
    case kSchema:
      return "Schema";
    case kChannel:
      return "Channel";
    case kMessage:
      return "Message";
    case kChunk:
      return "Chunk";
    case kMessageIndex:
      return "Message Index";
    case kChunkIndex:
      return "Chunk Index";
    case kAttachment:
      return "Attachment";
    case kAttachmentIndex:
      return "Attachment Index";
    case kStatistics:
      return "Statistics";
    case kMetadata:
      return "Metadata";
    case kMetadataIndex:
      return "Metadata Index";
    case kSummaryOffset:
      return "Summary Offset";
    case kDataEnd:
      return "Data End";
    default:
      return "unknown";
  }
}

bool Cursor::stringMap(std::map<std::string, std::string>& map, const char* field) {
  std::uint32_t n = 0;
  if (!read(n, field)) return false;
  if (n > remaining()) return skip(n, field);  // fails with the message
  const std::size_t end = pos_ + n;
  while (ok_ && pos_ < end) {
    std::string key, value;
    if (!string(key, field) || !string(value, field)) return false;
    if (pos_ > end)
      return fail(fmt::format("{} overruns its length at byte offset {}", field, offset()));
    map[std::move(key)] = std::move(value);
  }
  return ok_;
}

bool parseSchema(Cursor& c, Schema& s) {
  Bytes data;
  if (!c.read(s.id, "Schema id") || !c.string(s.name, "Schema name") ||
      !c.string(s.encoding, "Schema encoding") || !c.bytes32(data, "Schema data"))
    return false;
  s.data.assign(data.begin(), data.end());
  return true;
}

bool parseChannel(Cursor& c, Channel& ch) {
  return c.read(ch.id, "Channel id") && c.read(ch.schema_id, "Channel schema id") &&
         c.string(ch.topic, "Channel topic") &&
         c.string(ch.message_encoding, "Channel message encoding") &&
         c.stringMap(ch.metadata, "Channel metadata");
}

}  // namespace format

std::string Damage::toString() const {
  return fmt::format("byte offset {}: {}", offset, what);
}

namespace {

// ---- byte sources ----------------------------------------------------------------------------

class Source {
 public:
  virtual ~Source() = default;
  virtual Status read(std::uint64_t offset, std::size_t n, std::uint8_t* out) const = 0;
  std::uint64_t size = 0;
};

class FileSource final : public Source {
 public:
  FileSource(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  ~FileSource() override { ::close(fd_); }
  Status read(std::uint64_t offset, std::size_t n, std::uint8_t* out) const override {
    std::size_t done = 0;
    while (done < n) {
      const ssize_t r = ::pread(fd_, out + done, n - done, static_cast<off_t>(offset + done));
      if (r < 0) {
        if (errno == EINTR) continue;
        return ioError("reading '{}' at byte offset {}: {}", path_, offset + done,
                       std::strerror(errno));
      }
      if (r == 0)
        return corrupt(
            fmt::format("'{}' ends at byte offset {} while {} bytes were expected "
                        "there (the file shrank while being read?)",
                        path_, offset + done, n - done));
      done += static_cast<std::size_t>(r);
    }
    return Status::ok();
  }

 private:
  int fd_;
  std::string path_;
};

class MemorySource final : public Source {
 public:
  explicit MemorySource(std::vector<std::uint8_t> bytes) : bytes_(std::move(bytes)) {
    size = bytes_.size();
  }
  Status read(std::uint64_t offset, std::size_t n, std::uint8_t* out) const override {
    if (offset > bytes_.size() || n > bytes_.size() - offset)
      return corrupt(fmt::format("read of {} bytes at byte offset {} beyond the end ({})", n,
                                 offset, bytes_.size()));
    if (n) std::memcpy(out, bytes_.data() + offset, n);
    return Status::ok();
  }

 private:
  std::vector<std::uint8_t> bytes_;
};

// What the first bytes of a non-MCAP file look like, to say so in the error.
std::string describeSignature(const std::uint8_t* b, std::size_t n) {
  auto starts = [&](std::string_view sig) {
    return n >= sig.size() && std::memcmp(b, sig.data(), sig.size()) == 0;
  };
  if (starts("\x89PNG")) return " (it looks like a PNG image)";
  if (starts("\xFF\xD8\xFF")) return " (it looks like a JPEG image)";
  if (starts("#ROSBAG")) return " (it looks like a ROS 1 bag)";
  if (starts("SQLite format")) return " (it looks like an SQLite database, e.g. a ROS 2 .db3 bag)";
  if (starts("\x1F\x8B")) return " (it looks like a gzip file)";
  if (starts("PK\x03\x04")) return " (it looks like a zip archive)";
  if (starts("\x89MCAP")) return " (an MCAP file of another major version)";
  if (n > 0 && (b[0] == '{' || b[0] == '[')) return " (it looks like JSON text)";
  return "";
}

std::string hexBytes(const std::uint8_t* b, std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < n; ++i) s += fmt::format("{}{:02X}", i ? " " : "", b[i]);
  return s;
}

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

}  // namespace

// ---- the reader ------------------------------------------------------------------------------

struct McapReader::Impl {
  std::string path;
  std::unique_ptr<Source> source;
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

  Status fileError(std::string what) const { return corrupt(fmt::format("'{}': {}", path, what)); }

  Status readAt(std::uint64_t offset, std::size_t n, ByteVector& out) const {
    out.resize(n);
    return source->read(offset, n, out.data());
  }

  Status open();
  Status readHeader();
  enum class Summary { kRead, kNoFooter, kNotIndexed, kDamaged };
  // kRead, or why the summary cannot be used (kDamaged: `why` at `why_offset`).
  Summary readSummary(std::string& why, std::uint64_t& why_offset);
  std::uint64_t data_end = 0;  // offset of the Data End record (indexed files)
  std::uint32_t data_section_crc = 0;
  void scan();
  void addDamage(std::uint64_t offset, std::string what) {
    recovery.damages.push_back({offset, std::move(what)});
  }

  /// Reads and decompresses a chunk (or an unchunked run); `records` points into `storage`.
  std::string loadChunk(const ChunkInfo& chunk, Decompressor& d,
                        std::shared_ptr<ByteVector>& storage, Bytes& records) const;
};

Status McapReader::Impl::readHeader() {
  const std::uint64_t size = source->size;
  if (size == 0) return fileError("the file is empty (0 bytes); expected an MCAP file");
  std::uint8_t magic[8];
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(size, 8));
  CDFF_RETURN_IF_ERROR(source->read(0, n, magic));
  if (n < 8 || std::memcmp(magic, kMagic, 8) != 0) {
    if (n < 8 && std::memcmp(magic, kMagic, n) == 0)
      return fileError(
          fmt::format("the file is {} bytes long, truncated inside the 8-byte MCAP magic", size));
    return fileError(fmt::format(
        "not an MCAP file: bytes 0-{} are {}{}; expected the MCAP magic 89 4D 43 41 50 30 0D 0A",
        n - 1, hexBytes(magic, n), describeSignature(magic, n)));
  }
  if (size < 8 + kRecordPrefix)
    return fileError(
        fmt::format("truncated at byte offset {}: the file ends before its Header record", size));
  std::uint8_t prefix[kRecordPrefix];
  CDFF_RETURN_IF_ERROR(source->read(8, kRecordPrefix, prefix));
  std::uint64_t length = 0;
  std::memcpy(&length, prefix + 1, 8);
  if (prefix[0] != kHeader)
    return fileError(fmt::format(
        "byte offset 8: expected the Header record (opcode 0x01), found opcode 0x{:02X} ({})",
        prefix[0], opcodeName(prefix[0])));
  if (length > size - 8 - kRecordPrefix)
    return fileError(
        fmt::format("byte offset 8: the Header record claims {} bytes but the file has {} after it "
                    "(truncated?)",
                    length, size - 8 - kRecordPrefix));
  if (length > (64u << 20))
    return fileError(fmt::format("byte offset 8: implausible Header record length {}", length));
  ByteVector body;
  CDFF_RETURN_IF_ERROR(readAt(8 + kRecordPrefix, static_cast<std::size_t>(length), body));
  Cursor c(body.data(), body.size(), 8 + kRecordPrefix);
  if (!c.string(profile, "Header profile") || !c.string(library, "Header library"))
    return fileError(c.error());
  header_end = 8 + kRecordPrefix + length;
  return Status::ok();
}

McapReader::Impl::Summary McapReader::Impl::readSummary(std::string& why,
                                                        std::uint64_t& why_offset) {
  const std::uint64_t size = source->size;
  constexpr std::uint64_t kTail = kRecordPrefix + kFooterContent + 8;
  why_offset = size;
  if (size < header_end + kTail) {
    return Summary::kNoFooter;
  }
  const std::uint64_t footer_at = size - kTail;
  std::uint8_t tail[kTail];
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
  ByteVector summary;
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

  std::map<std::uint16_t, Schema> new_schemas;
  std::map<std::uint16_t, Channel> new_channels;
  std::vector<ChunkInfo> new_chunks;
  std::vector<AttachmentInfo> new_attachments;
  std::vector<MetadataInfo> new_metadata;
  bool have_stats = false;
  Statistics new_stats;
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
    switch (op) {
      case kSchema: {
        Schema s;
        if (!parseSchema(c, s)) break;
        if (s.id != 0) new_schemas[s.id] = std::move(s);
        break;
      }
      case kChannel: {
        Channel ch;
        if (!parseChannel(c, ch)) break;
        new_channels[ch.id] = std::move(ch);
        break;
      }
      case kChunkIndex: {
        ChunkInfo ci;
        std::uint32_t map_len = 0;
        std::string compression;
        std::uint64_t index_length = 0;
        if (!c.read(ci.message_start_time, "Chunk Index start") ||
            !c.read(ci.message_end_time, "Chunk Index end") ||
            !c.read(ci.offset, "Chunk Index offset") || !c.read(ci.length, "Chunk Index length") ||
            !c.read(map_len, "Chunk Index message index offsets"))
          break;
        if (map_len % 10 != 0 || map_len > c.remaining()) {
          c.fail(
              fmt::format("Chunk Index message index map of {} bytes at byte offset {} is "
                          "malformed",
                          map_len, c.offset()));
          break;
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
          break;
        const auto comp = compressionFromString(compression);
        if (!comp || compression == "none") {
          c.fail(
              fmt::format("Chunk Index at byte offset {}: unsupported compression '{}'; "
                          "expected '', 'lz4' or 'zstd'",
                          at, compression));
          break;
        }
        ci.compression = *comp;
        if (ci.offset < header_end || ci.length < kRecordPrefix || ci.offset > data_limit ||
            ci.length > data_limit - ci.offset) {
          c.fail(
              fmt::format("Chunk Index at byte offset {} points at [{}, +{}), outside the "
                          "data section [{}, {})",
                          at, ci.offset, ci.length, header_end, data_limit));
          break;
        }
        std::sort(ci.channels.begin(), ci.channels.end());
        new_chunks.push_back(std::move(ci));
        break;
      }
      case kAttachmentIndex: {
        AttachmentInfo a;
        if (c.read(a.offset, "Attachment Index offset") &&
            c.read(a.length, "Attachment Index length") &&
            c.read(a.log_time, "Attachment Index log time") &&
            c.read(a.create_time, "Attachment Index create time") &&
            c.read(a.data_size, "Attachment Index data size") &&
            c.string(a.name, "Attachment Index name") &&
            c.string(a.media_type, "Attachment Index media type"))
          new_attachments.push_back(std::move(a));
        break;
      }
      case kMetadataIndex: {
        MetadataInfo m;
        if (c.read(m.offset, "Metadata Index offset") &&
            c.read(m.length, "Metadata Index length") && c.string(m.name, "Metadata Index name"))
          new_metadata.push_back(std::move(m));
        break;
      }
      case kStatistics: {
        Statistics& s = new_stats;
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
          break;
        if (map_len % 10 != 0 || map_len > c.remaining()) {
          c.fail(fmt::format("Statistics channel count map of {} bytes is malformed", map_len));
          break;
        }
        for (std::uint32_t i = 0; i < map_len / 10; ++i) {
          std::uint16_t id = 0;
          std::uint64_t count = 0;
          c.read(id, "Statistics channel");
          c.read(count, "Statistics count");
          s.channel_message_counts[id] = count;
        }
        have_stats = true;
        break;
      }
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
        return Summary::kDamaged;
      default:
        break;  // unknown records are skipped, as the specification asks
    }
    if (!c.ok()) {
      why = "summary section: " + c.error();
      return Summary::kDamaged;
    }
    pos += kRecordPrefix + static_cast<std::size_t>(len);
  }
  for (const ChunkInfo& ci : new_chunks)
    for (std::uint16_t id : ci.channels)
      if (!new_channels.count(id)) {
        why_offset = ci.offset;
        why = fmt::format(
            "the chunk index of the chunk at byte offset {} names channel {}, "
            "which the summary does not define",
            ci.offset, id);
        return Summary::kDamaged;
      }
  if (!have_stats || (new_stats.message_count > 0 && new_chunks.empty())) {
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
  std::sort(new_chunks.begin(), new_chunks.end(),
            [](const ChunkInfo& a, const ChunkInfo& b) { return a.offset < b.offset; });
  schemas = std::move(new_schemas);
  channels = std::move(new_channels);
  chunks = std::move(new_chunks);
  attachments = std::move(new_attachments);
  metadata = std::move(new_metadata);
  stats = std::move(new_stats);
  return Summary::kRead;
}

std::string McapReader::Impl::loadChunk(const ChunkInfo& chunk, Decompressor& d,
                                        std::shared_ptr<ByteVector>& storage,
                                        Bytes& records) const {
  if (chunk.length > options.max_chunk_bytes)
    return fmt::format("record of {} bytes exceeds the reader's limit of {} bytes", chunk.length,
                       options.max_chunk_bytes);
  auto raw = std::make_shared<ByteVector>();
  if (Status s = readAt(chunk.offset, static_cast<std::size_t>(chunk.length), *raw); !s.isOk())
    return s.message();
  if (chunk.unchunked) {
    records = Bytes(*raw);
    storage = std::move(raw);
    return {};
  }
  Cursor c(raw->data(), raw->size(), chunk.offset);
  std::uint8_t op = 0;
  std::uint64_t length = 0, start = 0, end = 0, uncompressed_size = 0;
  std::uint32_t crc = 0;
  std::string compression;
  Bytes body;
  if (!c.read(op, "Chunk opcode") || !c.read(length, "Chunk length")) return c.error();
  if (op != kChunk)
    return fmt::format("expected a Chunk record (opcode 0x06), found opcode 0x{:02X} ({})", op,
                       opcodeName(op));
  if (length != chunk.length - kRecordPrefix)
    return fmt::format("Chunk record length {} disagrees with its index ({})", length,
                       chunk.length - kRecordPrefix);
  if (!c.read(start, "Chunk start time") || !c.read(end, "Chunk end time") ||
      !c.read(uncompressed_size, "Chunk uncompressed size") || !c.read(crc, "Chunk CRC") ||
      !c.string(compression, "Chunk compression") || !c.bytes64(body, "Chunk records"))
    return c.error();
  const auto comp = compressionFromString(compression);
  if (!comp || compression == "none")
    return fmt::format("unsupported chunk compression '{}'; expected '', 'lz4' or 'zstd'",
                       compression);
  if (uncompressed_size > options.max_chunk_bytes)
    return fmt::format("chunk claims {} uncompressed bytes, beyond the reader's limit of {}",
                       uncompressed_size, options.max_chunk_bytes);
  // Refuse sizes the compressed bytes cannot produce before allocating for them: lz4 expands at
  // most ~255:1, zstd (RLE blocks) ~32768:1, and a zstd frame usually states its size.
  if (*comp == Compression::kLz4 && uncompressed_size > body.size() * 256 + 65536)
    return fmt::format(
        "chunk claims {} uncompressed bytes from {} lz4 bytes, more than lz4 can "
        "expand",
        uncompressed_size, body.size());
  if (*comp == Compression::kZstd) {
    const unsigned long long stated = ZSTD_getFrameContentSize(body.data(), body.size());
    if (stated == ZSTD_CONTENTSIZE_ERROR) return "the chunk records are not a zstd frame";
    if (stated != ZSTD_CONTENTSIZE_UNKNOWN && stated != uncompressed_size)
      return fmt::format("zstd frame holds {} bytes; the chunk says {}", stated, uncompressed_size);
    if (uncompressed_size > body.size() * 32768 + 65536)
      return fmt::format(
          "chunk claims {} uncompressed bytes from {} zstd bytes, more than zstd "
          "can expand",
          uncompressed_size, body.size());
  }
  const std::size_t body_offset = static_cast<std::size_t>(body.data() - raw->data());
  if (*comp == Compression::kNone) {
    if (uncompressed_size != body.size())
      return fmt::format("uncompressed chunk holds {} bytes of records but says {}", body.size(),
                         uncompressed_size);
    records = Bytes(raw->data() + body_offset, body.size());
    storage = std::move(raw);
  } else {
    auto out = std::make_shared<ByteVector>(static_cast<std::size_t>(uncompressed_size));
    if (std::string e = d.run(*comp, body, *out); !e.empty()) return e;
    records = Bytes(*out);
    storage = std::move(out);
  }
  if (crc != 0 && options.verify_crcs) {
    const std::uint32_t actual = crc32(records);
    if (actual != crc)
      return fmt::format(
          "chunk CRC mismatch: its records have CRC 0x{:08X}, the chunk says "
          "0x{:08X} (bit error?)",
          actual, crc);
  }
  return {};
}

namespace {

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

}  // namespace

void McapReader::Impl::scan() {
  const std::uint64_t size = source->size;
  std::uint64_t pos = header_end;
  bool finished = false;  // reached Data End or the footer
  Decompressor d;
  Statistics s;
  bool have_messages = false;
  ChunkInfo run;  // the current run of records outside chunks
  bool in_run = false;
  std::vector<std::uint16_t> run_channels;

  auto note_message = [&](std::uint16_t channel, std::uint64_t t) {
    ++s.message_count;
    ++s.channel_message_counts[channel];
    if (!have_messages) {
      s.message_start_time = s.message_end_time = t;
      have_messages = true;
    } else {
      s.message_start_time = std::min(s.message_start_time, t);
      s.message_end_time = std::max(s.message_end_time, t);
    }
  };
  auto add_schema = [&](std::uint64_t at, Schema schema) {
    if (schema.id == 0) return;
    auto [it, inserted] = schemas.try_emplace(schema.id, schema);
    if (!inserted && (it->second.name != schema.name || it->second.data != schema.data))
      addDamage(at, fmt::format("Schema id {} is redefined differently ('{}' then '{}')", schema.id,
                                it->second.name, schema.name));
  };
  auto add_channel = [&](std::uint64_t at, Channel channel) {
    auto [it, inserted] = channels.try_emplace(channel.id, channel);
    if (!inserted &&
        (it->second.topic != channel.topic || it->second.schema_id != channel.schema_id ||
         it->second.message_encoding != channel.message_encoding))
      addDamage(at, fmt::format("Channel id {} is redefined differently ('{}' then '{}')",
                                channel.id, it->second.topic, channel.topic));
  };
  auto close_run = [&]() {
    if (!in_run) return;
    std::sort(run_channels.begin(), run_channels.end());
    run_channels.erase(std::unique(run_channels.begin(), run_channels.end()), run_channels.end());
    run.channels = run_channels;
    if (!run.channels.empty()) chunks.push_back(run);
    in_run = false;
    run_channels.clear();
  };

  ByteVector buf;
  while (pos < size) {
    if (size - pos < kRecordPrefix) {
      addDamage(pos,
                fmt::format("truncated: the file ends {} bytes into a record header", size - pos));
      break;
    }
    std::uint8_t prefix[kRecordPrefix];
    if (!source->read(pos, kRecordPrefix, prefix).isOk()) {
      addDamage(pos, "unreadable record header");
      break;
    }
    const std::uint8_t op = prefix[0];
    std::uint64_t len = 0;
    std::memcpy(&len, prefix + 1, 8);
    if (op == 0 || (op > kDataEnd && op < 0x80)) {
      addDamage(pos, fmt::format("invalid record opcode 0x{:02X} (corrupt data, or garbage after "
                                 "the last record)",
                                 op));
      break;
    }
    if (len > size - pos - kRecordPrefix) {
      addDamage(pos, fmt::format("truncated: {} record claims {} bytes but the file has only {} "
                                 "more",
                                 opcodeName(op), len, size - pos - kRecordPrefix));
      break;
    }
    const std::uint64_t next = pos + kRecordPrefix + len;
    const bool top_level_data = op == kSchema || op == kChannel || op == kMessage;
    if (!top_level_data) close_run();

    if (top_level_data || op == kAttachment || op == kMetadata || op == kFooter) {
      const std::size_t want = static_cast<std::size_t>(
          op == kAttachment ? std::min<std::uint64_t>(len, 1u << 20) : len);
      if (len > options.max_chunk_bytes) {
        addDamage(pos, fmt::format("{} record of {} bytes exceeds the reader's limit",
                                   opcodeName(op), len));
        break;
      }
      if (!readAt(pos + kRecordPrefix, want, buf).isOk()) {
        addDamage(pos, "unreadable record");
        break;
      }
    }
    Cursor c(buf.data(), buf.size(), pos + kRecordPrefix);
    bool stop = false;
    switch (op) {
      case kSchema: {
        Schema schema;
        if (!parseSchema(c, schema)) {
          addDamage(pos, c.error());
          break;
        }
        add_schema(pos, std::move(schema));
        break;
      }
      case kChannel: {
        Channel channel;
        if (!parseChannel(c, channel)) {
          addDamage(pos, c.error());
          break;
        }
        add_channel(pos, std::move(channel));
        break;
      }
      case kMessage: {
        if (len < kMessageFixed) {
          addDamage(pos, fmt::format("Message record of {} bytes; expected at least 22", len));
          break;
        }
        std::uint16_t channel = 0;
        std::uint64_t t = 0;
        std::memcpy(&channel, buf.data(), 2);
        std::memcpy(&t, buf.data() + 6, 8);
        if (!channels.count(channel)) {
          addDamage(pos, fmt::format("Message on channel id {}, which no earlier Channel record "
                                     "defines",
                                     channel));
          break;
        }
        note_message(channel, t);
        if (!in_run) {
          run = ChunkInfo{};
          run.unchunked = true;
          run.offset = pos;
          run.message_start_time = run.message_end_time = t;
          in_run = true;
        }
        run.length = next - run.offset;
        run.compressed_size = run.uncompressed_size = run.length;
        run.message_start_time = std::min(run.message_start_time, t);
        run.message_end_time = std::max(run.message_end_time, t);
        run_channels.push_back(channel);
        break;
      }
      case kChunk: {
        ChunkInfo ci;
        ci.offset = pos;
        ci.length = kRecordPrefix + len;
        // The header fields, for the index: they are before the records.
        std::uint8_t h[8 + 8 + 8 + 4 + 4];
        if (len < sizeof(h) || !source->read(pos + kRecordPrefix, sizeof(h), h).isOk()) {
          addDamage(pos, fmt::format("Chunk record of {} bytes is too short", len));
          break;
        }
        std::memcpy(&ci.message_start_time, h, 8);
        std::memcpy(&ci.message_end_time, h + 8, 8);
        std::memcpy(&ci.uncompressed_size, h + 16, 8);
        std::uint32_t name_len = 0;
        std::memcpy(&name_len, h + 28, 4);
        std::string compression;
        if (name_len <= 16 && len >= sizeof(h) + name_len + 8) {
          compression.resize(name_len);
          if (!source
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
        std::string error = loadChunk(ci, d, storage, records);
        if (!error.empty()) {
          addDamage(pos, "chunk skipped: " + error);
          break;
        }
        std::vector<std::uint16_t> chunk_channels;
        std::string inner_error;
        error = parseRecords(
            records,
            [&](std::size_t at, std::uint16_t channel, std::uint32_t, std::uint64_t t,
                std::uint64_t, Bytes) {
              if (!channels.count(channel)) {
                if (inner_error.empty())
                  inner_error = fmt::format(
                      "message at records offset {} is on channel id {}, "
                      "which no Channel record defines",
                      at, channel);
                return;
              }
              note_message(channel, t);
              chunk_channels.push_back(channel);
            },
            [&](std::size_t, Schema schema) { add_schema(pos, std::move(schema)); },
            [&](std::size_t, Channel channel) { add_channel(pos, std::move(channel)); });
        if (!error.empty()) addDamage(pos, "chunk partly read: " + error);
        if (!inner_error.empty()) addDamage(pos, "chunk: " + inner_error);
        std::sort(chunk_channels.begin(), chunk_channels.end());
        chunk_channels.erase(std::unique(chunk_channels.begin(), chunk_channels.end()),
                             chunk_channels.end());
        ci.channels = std::move(chunk_channels);
        ++s.chunk_count;
        if (!ci.channels.empty()) chunks.push_back(std::move(ci));
        break;
      }
      case kAttachment: {
        AttachmentInfo a;
        a.offset = pos;
        a.length = kRecordPrefix + len;
        std::uint64_t data_size = 0;
        if (!c.read(a.log_time, "Attachment log time") ||
            !c.read(a.create_time, "Attachment create time") ||
            !c.string(a.name, "Attachment name") ||
            !c.string(a.media_type, "Attachment media type") ||
            !c.read(data_size, "Attachment data size")) {
          addDamage(pos, c.error());
          break;
        }
        a.data_size = data_size;
        attachments.push_back(std::move(a));
        ++s.attachment_count;
        break;
      }
      case kMetadata: {
        MetadataInfo m;
        m.offset = pos;
        m.length = kRecordPrefix + len;
        if (!c.string(m.name, "Metadata name")) {
          addDamage(pos, c.error());
          break;
        }
        metadata.push_back(std::move(m));
        ++s.metadata_count;
        break;
      }
      case kHeader:
        addDamage(pos, "a second Header record");
        stop = true;
        break;
      case kDataEnd:
      case kFooter:
        finished = true;
        stop = true;
        break;
      default:
        break;  // message indexes (rebuilt from the chunks), summary records, unknown records
    }
    if (stop) break;
    pos = next;
  }
  close_run();
  if (!finished && recovery.damages.empty())
    addDamage(pos,
              "the data section ends without a Data End record, summary or footer: the file "
              "was truncated or its writer did not finish (killed?); every chunk before "
              "this offset is intact");
  s.schema_count = static_cast<std::uint16_t>(schemas.size());
  s.channel_count = static_cast<std::uint32_t>(channels.size());
  stats = std::move(s);
  recovery.intact_bytes = recovery.damages.empty() ? size : recovery.damages.front().offset;
}

Status McapReader::Impl::open() {
  CDFF_RETURN_IF_ERROR(readHeader());
  std::string why;
  std::uint64_t why_offset = 0;
  const Summary summary = readSummary(why, why_offset);
  if (summary == Summary::kRead) {
    recovery.indexed = true;
    recovery.intact_bytes = source->size;
    return Status::ok();
  }
  schemas.clear();
  channels.clear();
  chunks.clear();
  attachments.clear();
  metadata.clear();
  stats = {};
  scan();
  // A truncated file reports where its data section breaks (from the scan); a bad summary in
  // an otherwise sound file is reported as such.
  if (summary == Summary::kDamaged)
    recovery.damages.insert(recovery.damages.begin(), {why_offset, why});
  if (summary == Summary::kNoFooter && recovery.damages.empty())
    addDamage(source->size,
              "the file ends after its data section but without a complete summary "
              "and footer (truncated): every message is intact, the index is lost");
  recovery.intact_bytes = recovery.damages.empty() ? source->size : recovery.damages.front().offset;
  return Status::ok();
}

McapReader::McapReader() = default;
McapReader::~McapReader() = default;

Status McapReader::open(const std::string& path, const McapReaderOptions& options) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return ioError("cannot open '{}': {}", path, std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return ioError("'{}' is not a regular file", path);
  }
  auto impl = std::make_shared<Impl>();
  impl->path = path;
  impl->options = options;
  impl->source = std::make_unique<FileSource>(fd, path);
  impl->source->size = static_cast<std::uint64_t>(st.st_size);
  CDFF_RETURN_IF_ERROR(impl->open());
  impl_ = std::move(impl);
  return Status::ok();
}

Status McapReader::openBuffer(std::vector<std::uint8_t> bytes, const std::string& name,
                              const McapReaderOptions& options) {
  auto impl = std::make_shared<Impl>();
  impl->path = name;
  impl->options = options;
  impl->source = std::make_unique<MemorySource>(std::move(bytes));
  CDFF_RETURN_IF_ERROR(impl->open());
  impl_ = std::move(impl);
  return Status::ok();
}

namespace {
const std::string kEmptyString;
const std::map<std::uint16_t, Schema> kNoSchemas;
const std::map<std::uint16_t, Channel> kNoChannels;
const Statistics kNoStatistics;
const std::vector<ChunkInfo> kNoChunks;
const std::vector<AttachmentInfo> kNoAttachments;
const std::vector<MetadataInfo> kNoMetadata;
const RecoveryReport kNoRecovery;
}  // namespace

const std::string& McapReader::path() const {
  return impl_ ? impl_->path : kEmptyString;
}
std::uint64_t McapReader::fileSize() const {
  return impl_ ? impl_->source->size : 0;
}
const std::string& McapReader::profile() const {
  return impl_ ? impl_->profile : kEmptyString;
}
const std::string& McapReader::library() const {
  return impl_ ? impl_->library : kEmptyString;
}
const std::map<std::uint16_t, Schema>& McapReader::schemas() const {
  return impl_ ? impl_->schemas : kNoSchemas;
}
const std::map<std::uint16_t, Channel>& McapReader::channels() const {
  return impl_ ? impl_->channels : kNoChannels;
}
const Channel* McapReader::channel(std::string_view topic) const {
  if (!impl_) return nullptr;
  for (const auto& [id, c] : impl_->channels)
    if (c.topic == topic) return &c;
  return nullptr;
}
const Schema* McapReader::schemaOf(const Channel& channel) const {
  if (!impl_ || channel.schema_id == 0) return nullptr;
  auto it = impl_->schemas.find(channel.schema_id);
  return it == impl_->schemas.end() ? nullptr : &it->second;
}
const Statistics& McapReader::statistics() const {
  return impl_ ? impl_->stats : kNoStatistics;
}
const std::vector<ChunkInfo>& McapReader::chunks() const {
  return impl_ ? impl_->chunks : kNoChunks;
}
const std::vector<AttachmentInfo>& McapReader::attachments() const {
  return impl_ ? impl_->attachments : kNoAttachments;
}
const std::vector<MetadataInfo>& McapReader::metadata() const {
  return impl_ ? impl_->metadata : kNoMetadata;
}
const RecoveryReport& McapReader::recovery() const {
  return impl_ ? impl_->recovery : kNoRecovery;
}

Result<std::vector<std::uint8_t>> McapReader::readAttachment(const AttachmentInfo& a) const {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP reader is not open"};
  if (a.offset > impl_->source->size || a.length > impl_->source->size - a.offset ||
      a.length > impl_->options.max_chunk_bytes)
    return impl_->fileError(
        fmt::format("attachment '{}' at byte offset {} (+{}) lies outside "
                    "the file",
                    a.name, a.offset, a.length));
  ByteVector rec;
  CDFF_RETURN_IF_ERROR(impl_->readAt(a.offset, static_cast<std::size_t>(a.length), rec));
  Cursor c(rec.data(), rec.size(), a.offset);
  std::uint8_t op = 0;
  std::uint64_t len = 0, log_time = 0, create_time = 0;
  std::string name, media_type;
  Bytes data;
  std::uint32_t crc = 0;
  if (!c.read(op, "Attachment opcode") || !c.read(len, "Attachment length") || op != kAttachment)
    return impl_->fileError(fmt::format("byte offset {}: expected an Attachment record", a.offset));
  const std::size_t content_start = c.position();
  if (!c.read(log_time, "Attachment log time") || !c.read(create_time, "Attachment create time") ||
      !c.string(name, "Attachment name") || !c.string(media_type, "Attachment media type") ||
      !c.bytes64(data, "Attachment data"))
    return impl_->fileError(c.error());
  const std::size_t crc_at = c.position();
  if (!c.read(crc, "Attachment CRC")) return impl_->fileError(c.error());
  if (crc != 0 && impl_->options.verify_crcs) {
    const std::uint32_t actual = crc32Update(0, rec.data() + content_start, crc_at - content_start);
    if (actual != crc)
      return impl_->fileError(
          fmt::format("byte offset {}: attachment '{}' CRC mismatch (0x{:08X}, "
                      "expected 0x{:08X})",
                      a.offset, name, actual, crc));
  }
  return std::vector<std::uint8_t>(data.begin(), data.end());
}

Result<std::map<std::string, std::string>> McapReader::readMetadata(const MetadataInfo& m) const {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP reader is not open"};
  if (m.offset > impl_->source->size || m.length > impl_->source->size - m.offset ||
      m.length > impl_->options.max_chunk_bytes)
    return impl_->fileError(
        fmt::format("metadata '{}' at byte offset {} lies outside the file", m.name, m.offset));
  ByteVector rec;
  CDFF_RETURN_IF_ERROR(impl_->readAt(m.offset, static_cast<std::size_t>(m.length), rec));
  Cursor c(rec.data(), rec.size(), m.offset);
  std::uint8_t op = 0;
  std::uint64_t len = 0;
  std::string name;
  std::map<std::string, std::string> values;
  if (!c.read(op, "Metadata opcode") || !c.read(len, "Metadata length") || op != kMetadata)
    return impl_->fileError(fmt::format("byte offset {}: expected a Metadata record", m.offset));
  if (!c.string(name, "Metadata name") || !c.stringMap(values, "Metadata values"))
    return impl_->fileError(c.error());
  return values;
}

std::vector<Damage> McapReader::verify(bool chunks) const {
  std::vector<Damage> damages;
  if (!impl_) return damages;
  const Impl& r = *impl_;
  Decompressor d;
  for (const ChunkInfo& chunk : r.chunks) {
    if (!chunks) break;
    std::shared_ptr<ByteVector> storage;
    Bytes records;
    std::string error = r.loadChunk(chunk, d, storage, records);
    if (error.empty()) {
      std::uint16_t unknown = 0;
      bool has_unknown = false;
      error = parseRecords(
          records,
          [&](std::size_t, std::uint16_t channel, std::uint32_t, std::uint64_t, std::uint64_t,
              Bytes) {
            if (!r.channels.count(channel) && !has_unknown) {
              has_unknown = true;
              unknown = channel;
            }
          },
          [](std::size_t, Schema) {}, [](std::size_t, Channel) {});
      if (error.empty() && has_unknown)
        error =
            fmt::format("a message is on channel id {}, which no Channel record defines", unknown);
    }
    if (!error.empty()) damages.push_back({chunk.offset, error});
  }
  if (r.recovery.indexed && r.data_section_crc != 0 && r.options.verify_crcs && r.data_end > 0) {
    ByteVector block;
    std::uint32_t crc = 0;
    for (std::uint64_t at = 0; at < r.data_end;) {
      const std::size_t n =
          static_cast<std::size_t>(std::min<std::uint64_t>(4u << 20, r.data_end - at));
      if (Status s = r.readAt(at, n, block); !s.isOk()) {
        damages.push_back({at, s.message()});
        return damages;
      }
      crc = crc32Update(crc, block.data(), n);
      at += n;
    }
    if (crc != r.data_section_crc)
      damages.push_back({r.data_end, fmt::format("data section CRC mismatch: bytes [0, {}) have "
                                                 "CRC 0x{:08X}, the Data End record says 0x{:08X}",
                                                 r.data_end, crc, r.data_section_crc)});
  }
  return damages;
}

// ---- iteration -------------------------------------------------------------------------------

namespace {

struct Entry {
  std::uint64_t log_time;
  std::uint64_t publish_time;
  std::uint32_t sequence;
  std::uint16_t channel;
  std::size_t data_offset;  // into the chunk's records
  std::size_t data_size;
};

struct LoadedChunk {
  std::shared_ptr<ByteVector> storage;
  Bytes records;
  std::vector<Entry> entries;
  std::size_t next = 0;
  std::size_t order = 0;  // position in file order, for ties
};

}  // namespace

struct MessageIterator::Impl {
  std::shared_ptr<const McapReader::Impl> reader;
  ReadOptions options;
  std::vector<bool> wanted;          // by channel id; empty: all
  std::vector<std::size_t> pending;  // chunk indices by (start time, offset)
  std::size_t next_pending = 0;
  std::vector<std::unique_ptr<LoadedChunk>> heap;  // min-heap on the next entry
  Decompressor decompressor;
  MessageView current;
  std::vector<Damage> damages;
  std::size_t loaded = 0;

  static bool later(const std::unique_ptr<LoadedChunk>& a, const std::unique_ptr<LoadedChunk>& b) {
    const Entry& ea = a->entries[a->next];
    const Entry& eb = b->entries[b->next];
    if (ea.log_time != eb.log_time) return ea.log_time > eb.log_time;
    return a->order > b->order;
  }

  bool channelWanted(std::uint16_t id) const {
    return wanted.empty() || (id < wanted.size() && wanted[id]);
  }

  void load(std::size_t index) {
    const ChunkInfo& info = reader->chunks[index];
    auto chunk = std::make_unique<LoadedChunk>();
    chunk->order = index;
    std::string error = reader->loadChunk(info, decompressor, chunk->storage, chunk->records);
    ++loaded;
    if (!error.empty()) {
      damages.push_back(
          {info.offset, (info.unchunked ? "records skipped: " : "chunk skipped: ") + error});
      return;
    }
    const std::uint64_t lo = options.start_time.value_or(0);
    const std::uint64_t hi = options.end_time.value_or(std::numeric_limits<std::uint64_t>::max());
    std::string unknown;
    const std::uint8_t* base = chunk->records.data();
    error = parseRecords(
        chunk->records,
        [&](std::size_t at, std::uint16_t channel, std::uint32_t sequence, std::uint64_t t,
            std::uint64_t publish, Bytes data) {
          if (t < lo || t > hi || !channelWanted(channel)) return;
          if (!reader->channels.count(channel)) {
            if (unknown.empty())
              unknown = fmt::format(
                  "message at records offset {} is on channel id {}, which no "
                  "Channel record defines; skipped",
                  at, channel);
            return;
          }
          chunk->entries.push_back({t, publish, sequence, channel,
                                    static_cast<std::size_t>(data.data() - base), data.size()});
        },
        [](std::size_t, Schema) {}, [](std::size_t, Channel) {});
    if (!error.empty()) damages.push_back({info.offset, "chunk partly read: " + error});
    if (!unknown.empty()) damages.push_back({info.offset, unknown});
    if (chunk->entries.empty()) return;
    if (!std::is_sorted(chunk->entries.begin(), chunk->entries.end(),
                        [](const Entry& a, const Entry& b) { return a.log_time < b.log_time; }))
      std::stable_sort(chunk->entries.begin(), chunk->entries.end(),
                       [](const Entry& a, const Entry& b) { return a.log_time < b.log_time; });
    heap.push_back(std::move(chunk));
    std::push_heap(heap.begin(), heap.end(), later);
  }

  bool next() {
    for (;;) {
      while (next_pending < pending.size()) {
        const ChunkInfo& c = reader->chunks[pending[next_pending]];
        if (!heap.empty()) {
          const LoadedChunk& top = *heap.front();
          if (c.message_start_time > top.entries[top.next].log_time) break;
        }
        load(pending[next_pending++]);
      }
      if (heap.empty()) return false;
      std::pop_heap(heap.begin(), heap.end(), later);
      LoadedChunk& chunk = *heap.back();
      const Entry& e = chunk.entries[chunk.next];
      const Channel& channel = reader->channels.at(e.channel);
      current.channel = &channel;
      auto schema = reader->schemas.find(channel.schema_id);
      current.schema = schema == reader->schemas.end() ? nullptr : &schema->second;
      current.sequence = e.sequence;
      current.log_time = e.log_time;
      current.publish_time = e.publish_time;
      current.data = Bytes(chunk.records.data() + e.data_offset, e.data_size);
      current.owner = chunk.storage;
      if (++chunk.next < chunk.entries.size()) {
        std::push_heap(heap.begin(), heap.end(), later);
      } else {
        heap.pop_back();
      }
      return true;
    }
  }
};

MessageIterator::MessageIterator(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
MessageIterator::MessageIterator(MessageIterator&&) noexcept = default;
MessageIterator& MessageIterator::operator=(MessageIterator&&) noexcept = default;
MessageIterator::~MessageIterator() = default;

bool MessageIterator::next() {
  return impl_ && impl_->next();
}
const MessageView& MessageIterator::message() const {
  return impl_->current;
}
const std::vector<Damage>& MessageIterator::damages() const {
  return impl_->damages;
}
std::size_t MessageIterator::chunksLoaded() const {
  return impl_ ? impl_->loaded : 0;
}
Status MessageIterator::status() const {
  if (!impl_ || impl_->damages.empty()) return Status::ok();
  return corrupt(fmt::format("'{}': {}", impl_->reader->path, impl_->damages.front().toString()));
}

MessageIterator McapReader::messages(const ReadOptions& options) const {
  auto it = std::make_unique<MessageIterator::Impl>();
  if (!impl_) return MessageIterator(std::move(it));
  it->reader = impl_;
  it->options = options;
  if (!options.channels.empty()) {
    it->wanted.assign(65536, false);
    for (std::uint16_t id : options.channels) it->wanted[id] = true;
  }
  const std::uint64_t lo = options.start_time.value_or(0);
  const std::uint64_t hi = options.end_time.value_or(std::numeric_limits<std::uint64_t>::max());
  for (std::size_t i = 0; i < impl_->chunks.size(); ++i) {
    const ChunkInfo& c = impl_->chunks[i];
    if (c.message_end_time < lo || c.message_start_time > hi) continue;
    if (!it->wanted.empty() && !c.channels.empty() &&
        std::none_of(c.channels.begin(), c.channels.end(),
                     [&](std::uint16_t id) { return it->wanted[id]; }))
      continue;
    it->pending.push_back(i);
  }
  std::stable_sort(it->pending.begin(), it->pending.end(), [&](std::size_t a, std::size_t b) {
    return impl_->chunks[a].message_start_time < impl_->chunks[b].message_start_time;
  });
  return MessageIterator(std::move(it));
}

}  // namespace cdff::io
