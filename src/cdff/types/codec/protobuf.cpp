#include "cdff/types/codec/protobuf.hpp"

#include <algorithm>
#include <functional>
#include <set>

#include <fmt/format.h>

namespace cdff::codec::pb {

void Writer::packedInt32(std::uint32_t f, std::span<const std::int32_t> values) {
  if (values.empty()) return;
  std::size_t n = 0;
  for (std::int32_t v : values)
    n += varintSize(static_cast<std::uint64_t>(static_cast<std::int64_t>(v)));
  lengthPrefix(f, n);
  for (std::int32_t v : values) varint(static_cast<std::uint64_t>(static_cast<std::int64_t>(v)));
}

void Writer::end(std::size_t start) {
  const std::size_t length = out_.size() - start;
  const std::size_t width = varintSize(length);
  if (width > 1) out_.insert(out_.begin() + static_cast<std::ptrdiff_t>(start), width - 1, 0);
  std::uint8_t* p = out_.data() + start - 1;
  std::uint64_t v = length;
  while (v >= 0x80) {
    *p++ = static_cast<std::uint8_t>(v | 0x80);
    v >>= 7;
  }
  *p = static_cast<std::uint8_t>(v);
}

bool Reader::fail(std::string what) {
  if (error_.empty())
    error_ =
        fmt::format("protobuf field {} at byte offset {}: {}", field_, base_ + value_at_, what);
  return false;
}

bool Reader::readVarint(std::uint64_t& v) {
  v = 0;
  for (int shift = 0; shift < 64; shift += 7) {
    if (pos_ >= data_.size()) return false;
    const std::uint8_t b = data_[pos_++];
    v |= static_cast<std::uint64_t>(b & 0x7F) << shift;
    if ((b & 0x80) == 0) return true;
  }
  return false;
}

bool Reader::next() {
  if (!error_.empty() || pos_ >= data_.size()) return false;
  value_at_ = pos_;
  std::uint64_t key = 0;
  if (!readVarint(key)) return fail("truncated or overlong tag");
  field_ = static_cast<std::uint32_t>(key >> 3);
  const auto wire = static_cast<std::uint32_t>(key & 7);
  if (field_ == 0 || key >> 3 > 0x1FFFFFFF) return fail("invalid field number");
  value_at_ = pos_;
  switch (wire) {
    case 0:
      type_ = WireType::kVarint;
      if (!readVarint(scalar_)) return fail("truncated varint");
      return true;
    case 1:
      type_ = WireType::kFixed64;
      if (data_.size() - pos_ < 8) return fail("truncated 64-bit value");
      std::memcpy(&scalar_, data_.data() + pos_, 8);
      pos_ += 8;
      return true;
    case 5: {
      type_ = WireType::kFixed32;
      if (data_.size() - pos_ < 4) return fail("truncated 32-bit value");
      std::uint32_t v;
      std::memcpy(&v, data_.data() + pos_, 4);
      scalar_ = v;
      pos_ += 4;
      return true;
    }
    case 2: {
      type_ = WireType::kLen;
      std::uint64_t n = 0;
      if (!readVarint(n)) return fail("truncated length");
      if (n > data_.size() - pos_)
        return fail(fmt::format("length {} exceeds the {} bytes left in the message", n,
                                data_.size() - pos_));
      value_at_ = pos_;
      span_ = data_.subspan(pos_, static_cast<std::size_t>(n));
      pos_ += static_cast<std::size_t>(n);
      return true;
    }
    default:
      return fail(fmt::format("unsupported wire type {}", wire));
  }
}

bool unpackVarints(Bytes data, std::vector<std::int64_t>& out) {
  std::size_t pos = 0;
  while (pos < data.size()) {
    std::uint64_t v = 0;
    bool done = false;
    for (int shift = 0; shift < 64 && pos < data.size(); shift += 7) {
      const std::uint8_t b = data[pos++];
      v |= static_cast<std::uint64_t>(b & 0x7F) << shift;
      if ((b & 0x80) == 0) {
        done = true;
        break;
      }
    }
    if (!done) return false;
    out.push_back(static_cast<std::int64_t>(v));
  }
  return true;
}

bool Reader::appendVarint(std::vector<std::int64_t>& out) {
  if (type_ == WireType::kVarint) {
    out.push_back(static_cast<std::int64_t>(scalar_));
    return true;
  }
  if (type_ != WireType::kLen) return fail("a repeated varint field has a wrong wire type");
  if (!unpackVarints(span_, out)) return fail("truncated packed varint");
  return true;
}

const FieldDef* MessageDef::field(int number) const {
  for (const FieldDef& f : fields)
    if (f.number == number) return &f;
  return nullptr;
}

void DescriptorPool::add(MessageDef message) {
  for (const EnumDef& e : message.enums) enums_[e.full_name] = e;
  const std::string name = message.full_name;
  messages_[name] = std::move(message);
}

const MessageDef* DescriptorPool::message(std::string_view full_name) const {
  auto it = messages_.find(full_name);
  return it == messages_.end() ? nullptr : &it->second;
}

const EnumDef* DescriptorPool::enumType(std::string_view full_name) const {
  auto it = enums_.find(full_name);
  return it == enums_.end() ? nullptr : &it->second;
}

namespace {

std::string_view simpleName(std::string_view full) {
  const auto dot = full.rfind('.');
  return dot == std::string_view::npos ? full : full.substr(dot + 1);
}

std::string_view packageOf(std::string_view full) {
  const auto dot = full.rfind('.');
  return dot == std::string_view::npos ? std::string_view{} : full.substr(0, dot);
}

}  // namespace

Result<std::vector<std::uint8_t>> DescriptorPool::fileDescriptorSet(std::string_view root) const {
  // The message that owns a type name (itself, or the message an enum is nested in).
  auto owner = [&](const std::string& type_name) -> const MessageDef* {
    if (const MessageDef* m = message(type_name)) return m;
    if (enumType(type_name)) return message(packageOf(type_name));
    return nullptr;
  };
  std::vector<const MessageDef*> order;
  std::set<std::string> visited;
  Status status;
  std::function<void(const MessageDef&)> visit = [&](const MessageDef& m) {
    if (!visited.insert(m.full_name).second) return;
    for (const FieldDef& f : m.fields) {
      if (f.type != FieldType::kMessage && f.type != FieldType::kEnum) continue;
      const MessageDef* dep = owner(f.type_name);
      if (!dep) {
        status = invalidInput("protobuf schema {}: field '{}' has unknown type '{}'", m.full_name,
                              f.name, f.type_name);
        continue;
      }
      visit(*dep);
    }
    order.push_back(&m);
  };
  const MessageDef* top = message(root);
  if (!top) return notFound("no protobuf schema named '{}'", root);
  visit(*top);
  CDFF_RETURN_IF_ERROR(status);

  std::vector<std::uint8_t> set;
  Writer out(set);
  for (const MessageDef* m : order) {
    const std::size_t file = out.begin(1);
    out.string(1, m->file);
    out.string(2, packageOf(m->full_name));
    std::set<std::string> deps;
    for (const FieldDef& f : m->fields)
      if (f.type == FieldType::kMessage || f.type == FieldType::kEnum)
        if (const MessageDef* dep = owner(f.type_name); dep && dep != m) deps.insert(dep->file);
    for (const std::string& dep : deps) out.string(3, dep);
    const std::size_t msg = out.begin(4);
    out.string(1, simpleName(m->full_name));
    for (const FieldDef& f : m->fields) {
      const std::size_t field = out.begin(2);
      out.string(1, f.name);
      out.int32(3, f.number);
      out.int32(4, f.repeated ? 3 : 1);
      out.int32(5, static_cast<int>(f.type));
      if (!f.type_name.empty()) out.string(6, "." + f.type_name);
      out.string(10, f.name);  // json_name: keep snake_case, as Foxglove's descriptors do
      out.end(field);
    }
    for (const EnumDef& e : m->enums) {
      const std::size_t en = out.begin(4);
      out.string(1, simpleName(e.full_name));
      for (const auto& [name, number] : e.values) {
        const std::size_t value = out.begin(2);
        out.string(1, name);
        out.int32(2, number);
        out.end(value);
      }
      out.end(en);
    }
    out.end(msg);
    out.string(12, "proto3");
    out.end(file);
  }
  return set;
}

namespace {

Status parseEnum(Bytes data, const std::string& prefix, DescriptorPool& pool, EnumDef& e) {
  Reader r(data);
  while (r.next()) {
    if (r.field() == 1 && r.type() == WireType::kLen) {
      e.full_name = prefix + "." + r.string();
    } else if (r.field() == 2 && r.type() == WireType::kLen) {
      Reader v(r.bytes());
      std::string name;
      int number = 0;
      while (v.next()) {
        if (v.field() == 1 && v.type() == WireType::kLen) name = v.string();
        if (v.field() == 2 && v.type() == WireType::kVarint) number = v.i32();
      }
      if (!v.ok()) return {StatusCode::kCorruptData, "enum value descriptor: " + v.error()};
      e.values.emplace_back(name, number);
    }
  }
  if (!r.ok()) return {StatusCode::kCorruptData, "enum descriptor: " + r.error()};
  return Status::ok();
}

Status parseMessage(Bytes data, const std::string& prefix, const std::string& file,
                    DescriptorPool& pool, int depth) {
  if (depth > 32) return {StatusCode::kCorruptData, "protobuf descriptors nested too deeply"};
  MessageDef m;
  m.file = file;
  std::vector<Bytes> nested, enums;
  Reader r(data);
  while (r.next()) {
    if (r.type() != WireType::kLen) continue;
    switch (r.field()) {
      case 1:
        m.full_name = prefix.empty() ? r.string() : prefix + "." + r.string();
        break;
      case 2: {
        FieldDef f;
        Reader fr(r.bytes());
        while (fr.next()) {
          switch (fr.field()) {
            case 1:
              f.name = fr.string();
              break;
            case 3:
              f.number = fr.i32();
              break;
            case 4:
              f.repeated = fr.u64() == 3;
              break;
            case 5:
              f.type = static_cast<FieldType>(fr.u64());
              break;
            case 6: {
              f.type_name = fr.string();
              if (!f.type_name.empty() && f.type_name[0] == '.') f.type_name.erase(0, 1);
              break;
            }
            default:
              break;
          }
        }
        if (!fr.ok()) return {StatusCode::kCorruptData, "field descriptor: " + fr.error()};
        m.fields.push_back(std::move(f));
        break;
      }
      case 3:
        nested.push_back(r.bytes());
        break;
      case 4:
        enums.push_back(r.bytes());
        break;
      default:
        break;
    }
  }
  if (!r.ok()) return {StatusCode::kCorruptData, "message descriptor: " + r.error()};
  for (Bytes e : enums) {
    EnumDef def;
    CDFF_RETURN_IF_ERROR(parseEnum(e, m.full_name, pool, def));
    m.enums.push_back(std::move(def));
  }
  for (Bytes n : nested) CDFF_RETURN_IF_ERROR(parseMessage(n, m.full_name, file, pool, depth + 1));
  pool.add(std::move(m));
  return Status::ok();
}

}  // namespace

Result<DescriptorPool> DescriptorPool::parse(Bytes file_descriptor_set) {
  DescriptorPool pool;
  Reader set(file_descriptor_set);
  while (set.next()) {
    if (set.field() != 1 || set.type() != WireType::kLen) continue;
    Reader file(set.bytes());
    std::string name, package;
    std::vector<Bytes> messages, enums;
    while (file.next()) {
      if (file.type() != WireType::kLen) continue;
      if (file.field() == 1) name = file.string();
      if (file.field() == 2) package = file.string();
      if (file.field() == 4) messages.push_back(file.bytes());
      if (file.field() == 5) enums.push_back(file.bytes());
    }
    if (!file.ok()) return Status{StatusCode::kCorruptData, "FileDescriptorProto: " + file.error()};
    for (Bytes m : messages) CDFF_RETURN_IF_ERROR(parseMessage(m, package, name, pool, 0));
    for (Bytes e : enums) {
      EnumDef def;
      CDFF_RETURN_IF_ERROR(parseEnum(e, package, pool, def));
      if (package.empty() && !def.full_name.empty() && def.full_name[0] == '.')
        def.full_name.erase(0, 1);
      pool.enums_[def.full_name] = std::move(def);
    }
  }
  if (!set.ok()) return Status{StatusCode::kCorruptData, "FileDescriptorSet: " + set.error()};
  return pool;
}

}  // namespace cdff::codec::pb
