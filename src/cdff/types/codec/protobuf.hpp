#pragma once
// A small protobuf (proto3) wire-format encoder and decoder, and protobuf descriptors: enough to
// write and read the Foxglove schemas and CDFF's own without libprotobuf, and to embed every
// schema as a google.protobuf.FileDescriptorSet (MCAP schema encoding "protobuf").
// Little-endian hosts only, like the rest of the MCAP code.

#include <cstdint>
#include <cstring>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "cdff/types/status.hpp"

namespace cdff::codec::pb {

using Bytes = std::span<const std::uint8_t>;

enum class WireType : std::uint8_t { kVarint = 0, kFixed64 = 1, kLen = 2, kFixed32 = 5 };

inline std::size_t varintSize(std::uint64_t v) {
  std::size_t n = 1;
  while (v >= 0x80) {
    v >>= 7;
    ++n;
  }
  return n;
}

/// Appends protobuf fields to a byte vector.
class Writer {
 public:
  explicit Writer(std::vector<std::uint8_t>& out) : out_(out) {}

  void varint(std::uint64_t v) {
    while (v >= 0x80) {
      out_.push_back(static_cast<std::uint8_t>(v | 0x80));
      v >>= 7;
    }
    out_.push_back(static_cast<std::uint8_t>(v));
  }
  void tag(std::uint32_t field, WireType type) {
    varint((static_cast<std::uint64_t>(field) << 3) | static_cast<std::uint32_t>(type));
  }
  void uint64(std::uint32_t f, std::uint64_t v) {
    tag(f, WireType::kVarint);
    varint(v);
  }
  void int64(std::uint32_t f, std::int64_t v) { uint64(f, static_cast<std::uint64_t>(v)); }
  // Negative int32 / enum values are sign-extended to 10 bytes, as protobuf specifies.
  void int32(std::uint32_t f, std::int32_t v) {
    uint64(f, static_cast<std::uint64_t>(static_cast<std::int64_t>(v)));
  }
  void boolean(std::uint32_t f, bool v) { uint64(f, v ? 1 : 0); }
  void fixed32(std::uint32_t f, std::uint32_t v) {
    tag(f, WireType::kFixed32);
    raw(&v, 4);
  }
  void float32(std::uint32_t f, float v) {
    tag(f, WireType::kFixed32);
    raw(&v, 4);
  }
  void float64(std::uint32_t f, double v) {
    tag(f, WireType::kFixed64);
    raw(&v, 8);
  }
  void string(std::uint32_t f, std::string_view s) {
    lengthPrefix(f, s.size());
    raw(s.data(), s.size());
  }
  void bytes(std::uint32_t f, Bytes b) {
    lengthPrefix(f, b.size());
    raw(b.data(), b.size());
  }
  /// Tag and length of a length-delimited field whose bytes the caller appends (or sends as a
  /// separate part, for large payloads).
  void lengthPrefix(std::uint32_t f, std::size_t n) {
    tag(f, WireType::kLen);
    varint(n);
  }
  /// A packed repeated field of fixed-size values (float, double, fixed32).
  template <typename T>
  void packed(std::uint32_t f, std::span<const T> values) {
    if (values.empty()) return;
    lengthPrefix(f, values.size_bytes());
    raw(values.data(), values.size_bytes());
  }
  /// A packed repeated field of int32 varints.
  void packedInt32(std::uint32_t f, std::span<const std::int32_t> values);

  /// Nested message: begin() writes the tag, end() the length (both minimal varints).
  std::size_t begin(std::uint32_t f) {
    tag(f, WireType::kLen);
    out_.push_back(0);  // one byte reserved for the length; end() widens it when needed
    return out_.size();
  }
  void end(std::size_t start);

  void raw(const void* data, std::size_t n) {
    if (n == 0) return;
    const std::size_t at = out_.size();
    out_.resize(at + n);
    std::memcpy(out_.data() + at, data, n);
  }
  std::vector<std::uint8_t>& buffer() { return out_; }

 private:
  std::vector<std::uint8_t>& out_;
};

/// Reads the fields of one message, in order. next() reads a tag and its value; the accessors
/// read that value. A malformed message stops next() and sets error().
class Reader {
 public:
  explicit Reader(Bytes data, std::uint64_t base = 0) : data_(data), base_(base) {}

  bool next();
  std::uint32_t field() const { return field_; }
  WireType type() const { return type_; }
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  /// Offset of the current field's value (base + position in the message).
  std::uint64_t offset() const { return base_ + value_at_; }

  std::uint64_t u64() const { return scalar_; }
  std::int64_t i64() const { return static_cast<std::int64_t>(scalar_); }
  std::int32_t i32() const { return static_cast<std::int32_t>(scalar_); }
  bool boolean() const { return scalar_ != 0; }
  double f64() const {
    double v;
    std::memcpy(&v, &scalar_, 8);
    return v;
  }
  float f32() const {
    const auto bits = static_cast<std::uint32_t>(scalar_);
    float v;
    std::memcpy(&v, &bits, 4);
    return v;
  }
  Bytes bytes() const { return span_; }
  std::string string() const { return {reinterpret_cast<const char*>(span_.data()), span_.size()}; }

  /// Appends a repeated fixed-size field (packed or not) of T (float: kFixed32, double:
  /// kFixed64, uint32 for fixed32) to `out`; false (and error()) when the wire type does not fit.
  template <typename T>
  bool appendFixed(std::vector<T>& out) {
    constexpr WireType expected = sizeof(T) == 8 ? WireType::kFixed64 : WireType::kFixed32;
    if (type_ == expected) {
      T v;
      std::memcpy(&v, &scalar_, sizeof(T));
      out.push_back(v);
      return true;
    }
    if (type_ != WireType::kLen || span_.size() % sizeof(T) != 0)
      return fail("a repeated fixed-size field has a wrong wire type or length");
    const std::size_t at = out.size();
    out.resize(at + span_.size() / sizeof(T));
    std::memcpy(out.data() + at, span_.data(), span_.size());
    return true;
  }
  /// Appends a repeated varint field (packed or not).
  bool appendVarint(std::vector<std::int64_t>& out);

  bool fail(std::string what);

 private:
  bool readVarint(std::uint64_t& v);

  Bytes data_;
  std::uint64_t base_;
  std::size_t pos_ = 0;
  std::size_t value_at_ = 0;
  std::uint32_t field_ = 0;
  WireType type_ = WireType::kVarint;
  std::uint64_t scalar_ = 0;
  Bytes span_;
  std::string error_;
};

/// Parses the payload of a packed repeated varint field; false when it ends inside a varint.
bool unpackVarints(Bytes data, std::vector<std::int64_t>& out);

// ---- descriptors ---------------------------------------------------------------------------

enum class FieldType : std::uint8_t {
  kDouble = 1,
  kFloat = 2,
  kInt64 = 3,
  kUint64 = 4,
  kInt32 = 5,
  kFixed64 = 6,
  kFixed32 = 7,
  kBool = 8,
  kString = 9,
  kGroup = 10,
  kMessage = 11,
  kBytes = 12,
  kUint32 = 13,
  kEnum = 14,
  kSfixed32 = 15,
  kSfixed64 = 16,
  kSint32 = 17,
  kSint64 = 18,
};

struct FieldDef {
  std::string name;
  int number = 0;
  FieldType type = FieldType::kInt32;
  bool repeated = false;
  std::string type_name;  // full name (no leading dot) of a message or enum type
};

struct EnumDef {
  std::string full_name;  // e.g. "foxglove.PackedElementField.NumericType"
  std::vector<std::pair<std::string, int>> values;
};

struct MessageDef {
  std::string full_name;  // e.g. "foxglove.RawImage"
  std::string file;       // e.g. "foxglove/RawImage.proto"
  std::vector<FieldDef> fields;
  std::vector<EnumDef> enums;  // nested enums (full names below this message)

  const FieldDef* field(int number) const;
};

/// Message definitions by full name.
class DescriptorPool {
 public:
  void add(MessageDef message);
  const MessageDef* message(std::string_view full_name) const;
  const EnumDef* enumType(std::string_view full_name) const;

  /// The serialized google.protobuf.FileDescriptorSet holding `root` and every message it uses:
  /// one file per message (as Foxglove's own schemas), dependencies first, proto3 syntax.
  Result<std::vector<std::uint8_t>> fileDescriptorSet(std::string_view root) const;

  /// Parses a serialized FileDescriptorSet (e.g. the schema data of a channel).
  static Result<DescriptorPool> parse(Bytes file_descriptor_set);

 private:
  std::map<std::string, MessageDef, std::less<>> messages_;
  std::map<std::string, EnumDef, std::less<>> enums_;
};

}  // namespace cdff::codec::pb
