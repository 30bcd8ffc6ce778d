// The MCAP reader's chunk loading: read, check, decompress (mcap_reader_impl.hpp).
#include <string>

#include "cdff/io/crc32.hpp"
#include "cdff/io/mcap_reader_impl.hpp"

namespace cdff::io {

using namespace format;
using detail::Decompressor;

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

}  // namespace cdff::io
