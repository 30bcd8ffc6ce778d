#pragma once
// Internal to cdff_io: MCAP record opcodes and the little-endian serialisation helpers shared by
// the writer and the reader.

#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <fmt/format.h>

#include "cdff/io/mcap.hpp"

namespace cdff::io::format {

/// Grows without zero-filling: chunk and decompression buffers are overwritten right away, and
/// clearing megabytes first would cost as much as copying them.
template <typename T>
struct DefaultInitAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <typename U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
using ByteVector = std::vector<std::uint8_t, DefaultInitAllocator<std::uint8_t>>;

inline constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

const char* opcodeName(std::uint8_t opcode);

inline constexpr std::size_t kRecordPrefix = 9;   // opcode + uint64 length
inline constexpr std::size_t kMessageFixed = 22;  // channel, sequence, log and publish time
inline constexpr std::size_t kFooterContent = 20;
inline constexpr std::size_t kDataEndContent = 4;

// ---- writing: append to a byte vector -------------------------------------------------------

inline void putU8(ByteVector& b, std::uint8_t v) {
  b.push_back(v);
}
template <typename T>
inline void putLe(ByteVector& b, T v) {
  const std::size_t at = b.size();
  b.resize(at + sizeof(T));
  std::memcpy(b.data() + at, &v, sizeof(T));  // little-endian hosts
}
inline void putU16(ByteVector& b, std::uint16_t v) {
  putLe(b, v);
}
inline void putU32(ByteVector& b, std::uint32_t v) {
  putLe(b, v);
}
inline void putU64(ByteVector& b, std::uint64_t v) {
  putLe(b, v);
}
inline void putBytes(ByteVector& b, const void* data, std::size_t size) {
  if (size == 0) return;
  const std::size_t at = b.size();
  b.resize(at + size);
  std::memcpy(b.data() + at, data, size);
}
inline void putString(ByteVector& b, std::string_view s) {
  putU32(b, static_cast<std::uint32_t>(s.size()));
  putBytes(b, s.data(), s.size());
}
inline void patchU32(ByteVector& b, std::size_t at, std::uint32_t v) {
  std::memcpy(b.data() + at, &v, 4);
}
inline void patchU64(ByteVector& b, std::size_t at, std::uint64_t v) {
  std::memcpy(b.data() + at, &v, 8);
}

/// Starts a record: opcode and a length placeholder; returns the position to finish it at.
inline std::size_t beginRecord(ByteVector& b, std::uint8_t opcode) {
  b.push_back(opcode);
  const std::size_t at = b.size();
  putU64(b, 0);
  return at;
}
inline void endRecord(ByteVector& b, std::size_t length_at) {
  patchU64(b, length_at, b.size() - length_at - 8);
}

void putSchema(ByteVector& b, const Schema& schema);
void putChannel(ByteVector& b, const Channel& channel);
void putStringMap(ByteVector& b, const std::map<std::string, std::string>& map);

// ---- reading: a bounds-checked cursor over a byte range -------------------------------------

/// Reads little-endian fields from [data, data + size); the first read past the end fails and
/// the cursor remembers what and where (`base` is the file offset of data[0], or the offset in
/// the decompressed chunk, depending on `where`).
class Cursor {
 public:
  Cursor(const std::uint8_t* data, std::size_t size, std::uint64_t base = 0)
      : data_(data), size_(size), base_(base) {}

  bool ok() const { return ok_; }
  std::size_t position() const { return pos_; }
  std::size_t remaining() const { return size_ - pos_; }
  std::uint64_t offset() const { return base_ + pos_; }
  const std::string& error() const { return error_; }
  const std::uint8_t* here() const { return data_ + pos_; }

  template <typename T>
  bool read(T& v, const char* field) {
    if (!need(sizeof(T), field)) return false;
    std::memcpy(&v, data_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return true;
  }
  bool string(std::string& s, const char* field) {
    std::uint32_t n = 0;
    if (!read(n, field) || !need(n, field)) return false;
    s.assign(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return true;
  }
  /// uint32-prefixed bytes.
  bool bytes32(Bytes& out, const char* field) {
    std::uint32_t n = 0;
    if (!read(n, field) || !need(n, field)) return false;
    out = Bytes(data_ + pos_, n);
    pos_ += n;
    return true;
  }
  bool bytes64(Bytes& out, const char* field) {
    std::uint64_t n = 0;
    if (!read(n, field) || !need(n, field)) return false;
    out = Bytes(data_ + pos_, static_cast<std::size_t>(n));
    pos_ += static_cast<std::size_t>(n);
    return true;
  }
  bool skip(std::size_t n, const char* field) {
    if (!need(n, field)) return false;
    pos_ += n;
    return true;
  }
  bool stringMap(std::map<std::string, std::string>& map, const char* field);
  bool fail(std::string message) {
    if (ok_) {
      ok_ = false;
      error_ = std::move(message);
    }
    return false;
  }

 private:
  bool need(std::uint64_t n, const char* field) {
    if (!ok_) return false;
    if (n > size_ - pos_)
      return fail(fmt::format("{} needs {} bytes at byte offset {} but only {} remain", field, n,
                              base_ + pos_, size_ - pos_));
    return true;
  }

  const std::uint8_t* data_;
  std::size_t size_;
  std::uint64_t base_;
  std::size_t pos_ = 0;
  bool ok_ = true;
  std::string error_;
};

bool parseSchema(Cursor& c, Schema& schema);
bool parseChannel(Cursor& c, Channel& channel);

inline Status corrupt(std::string message) {
  return {StatusCode::kCorruptData, std::move(message)};
}

}  // namespace cdff::io::format
