#pragma once
// CRC-32/ISO-HDLC (the zlib / PNG / MCAP checksum: reflected polynomial 0xEDB88320, initial and
// final value 0xFFFFFFFF), computed slice-by-16. Same calling convention as zlib's crc32():
// crc32Update(0, data, n) is the checksum of data, and crc32Update(crc32Update(0, a), b) that of
// a followed by b.

#include <cstddef>
#include <cstdint>
#include <span>

namespace cdff::io {

std::uint32_t crc32Update(std::uint32_t crc, const void* data, std::size_t size);

inline std::uint32_t crc32(std::span<const std::uint8_t> data) {
  return crc32Update(0, data.data(), data.size());
}

/// The CRC of A followed by B from crc(A), crc(B) and the length of B, without reading the bytes
/// (as zlib's crc32_combine). The writer uses it to fold an uncompressed chunk's CRC into the
/// data-section CRC instead of reading the chunk a second time.
std::uint32_t crc32Combine(std::uint32_t crc_a, std::uint32_t crc_b, std::uint64_t size_b);

}  // namespace cdff::io
