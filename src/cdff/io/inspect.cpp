#include "cdff/io/inspect.hpp"

#include <cmath>

namespace cdff::io {

using nlohmann::json;
using pb::FieldType;
using pb::WireType;

namespace {

std::string hex(Bytes b, std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < std::min(n, b.size()); ++i) s += fmt::format("{:02x}", b[i]);
  return s;
}

json bytesJson(Bytes b, const InspectOptions& o) {
  if (b.size() <= o.max_array) return hex(b, b.size());
  return {{"$bytes", b.size()}, {"head", hex(b, o.head)}};
}

json summarise(json array, const InspectOptions& o) {
  if (array.size() <= o.max_array) return array;
  json head = json::array();
  for (std::size_t i = 0; i < o.head && i < array.size(); ++i) head.push_back(array[i]);
  return {{"$array", array.size()}, {"head", head}};
}

json number(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

// Summarises the long arrays of a parsed JSON message, recursively.
json summariseJson(const json& j, const InspectOptions& o, int depth) {
  if (depth > 64) return "...";
  if (j.is_array()) {
    json out = json::array();
    for (const json& e : j) out.push_back(summariseJson(e, o, depth + 1));
    return summarise(std::move(out), o);
  }
  if (j.is_object()) {
    json out = json::object();
    for (const auto& [k, v] : j.items()) out[k] = summariseJson(v, o, depth + 1);
    return out;
  }
  return j;
}

class ProtoJson {
 public:
  ProtoJson(const pb::DescriptorPool& pool, const InspectOptions& o) : pool_(pool), o_(o) {}

  Status message(const pb::MessageDef& def, Bytes data, int depth, json& out) const {
    if (depth > 64) return {StatusCode::kCorruptData, "protobuf messages nested too deeply"};
    out = json::object();
    std::map<std::string, json> arrays;  // repeated fields, in declaration order below
    pb::Reader r(data);
    while (r.next()) {
      const pb::FieldDef* f = def.field(static_cast<int>(r.field()));
      const std::string name = f ? f->name : std::to_string(r.field());
      json value;
      if (!f) {
        value = raw(r);
      } else if (f->repeated && r.type() == WireType::kLen && isPackable(f->type)) {
        CDFF_RETURN_IF_ERROR(packed(*f, r.bytes(), arrays[name]));
        continue;
      } else {
        CDFF_RETURN_IF_ERROR(scalar(*f, r, depth, value));
      }
      if (f && f->repeated) {
        arrays[name].push_back(std::move(value));
      } else {
        out[name] = std::move(value);
      }
    }
    if (!r.ok()) return {StatusCode::kCorruptData, def.full_name + " message: " + r.error()};
    for (auto& [name, values] : arrays) out[name] = summarise(std::move(values), o_);
    return Status::ok();
  }

 private:
  static bool isPackable(FieldType t) {
    return t != FieldType::kString && t != FieldType::kBytes && t != FieldType::kMessage &&
           t != FieldType::kGroup;
  }

  static json raw(const pb::Reader& r) {
    switch (r.type()) {
      case WireType::kVarint:
        return r.u64();
      case WireType::kFixed64:
        return number(r.f64());
      case WireType::kFixed32:
        return number(r.f32());
      case WireType::kLen:
        return {{"$bytes", r.bytes().size()}};
    }
    return nullptr;
  }

  json enumValue(const pb::FieldDef& f, std::int64_t v) const {
    if (const pb::EnumDef* e = pool_.enumType(f.type_name))
      for (const auto& [name, number] : e->values)
        if (number == v) return name;
    return v;
  }

  Status scalar(const pb::FieldDef& f, const pb::Reader& r, int depth, json& out) const {
    const auto mismatch = [&]() {
      return Status{StatusCode::kCorruptData,
                    fmt::format("field '{}' ({}) has wire type {}, which does not fit its type",
                                f.name, f.number, static_cast<int>(r.type()))};
    };
    switch (f.type) {
      case FieldType::kDouble:
      case FieldType::kFixed64:
      case FieldType::kSfixed64:
        if (r.type() != WireType::kFixed64) return mismatch();
        if (f.type == FieldType::kDouble)
          out = number(r.f64());
        else if (f.type == FieldType::kFixed64)
          out = r.u64();
        else
          out = r.i64();
        return Status::ok();
      case FieldType::kFloat:
      case FieldType::kFixed32:
      case FieldType::kSfixed32:
        if (r.type() != WireType::kFixed32) return mismatch();
        if (f.type == FieldType::kFloat)
          out = number(r.f32());
        else if (f.type == FieldType::kFixed32)
          out = static_cast<std::uint32_t>(r.u64());
        else
          out = static_cast<std::int32_t>(r.u64());
        return Status::ok();
      case FieldType::kString:
        if (r.type() != WireType::kLen) return mismatch();
        out = r.string();  // dump() with error_handler_t::replace copes with invalid UTF-8
        return Status::ok();
      case FieldType::kBytes:
        if (r.type() != WireType::kLen) return mismatch();
        out = bytesJson(r.bytes(), o_);
        return Status::ok();
      case FieldType::kMessage: {
        if (r.type() != WireType::kLen) return mismatch();
        const pb::MessageDef* def = pool_.message(f.type_name);
        if (!def) {
          out = {{"$bytes", r.bytes().size()}};
          return Status::ok();
        }
        return message(*def, r.bytes(), depth + 1, out);
      }
      case FieldType::kGroup:
        out = nullptr;
        return Status::ok();
      default:
        if (r.type() != WireType::kVarint) return mismatch();
        out = varint(f, r.u64());
        return Status::ok();
    }
  }

  json varint(const pb::FieldDef& f, std::uint64_t v) const {
    switch (f.type) {
      case FieldType::kBool:
        return v != 0;
      case FieldType::kInt32:
        return static_cast<std::int32_t>(v);
      case FieldType::kInt64:
        return static_cast<std::int64_t>(v);
      case FieldType::kUint32:
        return static_cast<std::uint32_t>(v);
      case FieldType::kSint32:
      case FieldType::kSint64:
        return static_cast<std::int64_t>((v >> 1) ^ (~(v & 1) + 1));
      case FieldType::kEnum:
        return enumValue(f, static_cast<std::int64_t>(v));
      default:
        return v;
    }
  }

  Status packed(const pb::FieldDef& f, Bytes data, json& values) const {
    if (!values.is_array()) values = json::array();
    const auto bad = [&]() {
      return Status{StatusCode::kCorruptData,
                    fmt::format("packed field '{}' has {} bytes, not a whole number of values",
                                f.name, data.size())};
    };
    switch (f.type) {
      case FieldType::kDouble:
      case FieldType::kFixed64:
      case FieldType::kSfixed64: {
        if (data.size() % 8) return bad();
        for (std::size_t i = 0; i < data.size(); i += 8) {
          std::uint64_t bits;
          std::memcpy(&bits, data.data() + i, 8);
          double d;
          std::memcpy(&d, &bits, 8);
          if (f.type == FieldType::kDouble)
            values.push_back(number(d));
          else if (f.type == FieldType::kFixed64)
            values.push_back(bits);
          else
            values.push_back(static_cast<std::int64_t>(bits));
        }
        return Status::ok();
      }
      case FieldType::kFloat:
      case FieldType::kFixed32:
      case FieldType::kSfixed32: {
        if (data.size() % 4) return bad();
        for (std::size_t i = 0; i < data.size(); i += 4) {
          std::uint32_t bits;
          std::memcpy(&bits, data.data() + i, 4);
          float v;
          std::memcpy(&v, &bits, 4);
          if (f.type == FieldType::kFloat)
            values.push_back(number(v));
          else if (f.type == FieldType::kFixed32)
            values.push_back(bits);
          else
            values.push_back(static_cast<std::int32_t>(bits));
        }
        return Status::ok();
      }
      default: {
        std::vector<std::int64_t> raw;
        if (!pb::unpackVarints(data, raw)) return bad();
        for (std::int64_t v : raw) values.push_back(varint(f, static_cast<std::uint64_t>(v)));
        return Status::ok();
      }
    }
  }

  const pb::DescriptorPool& pool_;
  const InspectOptions& o_;
};

}  // namespace

Result<MessageInspector> MessageInspector::create(const Channel& channel, const Schema* schema,
                                                  const InspectOptions& options) {
  MessageInspector m;
  m.options_ = options;
  if (channel.message_encoding == "json") {
    m.kind_ = Kind::kJson;
  } else if (channel.message_encoding == "protobuf" && schema && schema->encoding == "protobuf") {
    auto pool = pb::DescriptorPool::parse(schema->data);
    if (!pool)
      return pool.status().withContext(
          fmt::format("channel '{}' schema '{}'", channel.topic, schema->name));
    if (!pool->message(schema->name))
      return Status{StatusCode::kCorruptData,
                    fmt::format("channel '{}': schema '{}' is not defined in its own "
                                "FileDescriptorSet",
                                channel.topic, schema->name)};
    m.pool_ = std::move(pool).value();
    m.root_ = schema->name;
    m.kind_ = Kind::kProtobuf;
  }
  return m;
}

Result<json> MessageInspector::toJson(Bytes data) const {
  switch (kind_) {
    case Kind::kJson: {
      const json j = json::parse(data.begin(), data.end(), nullptr, false);
      if (j.is_discarded()) return Status{StatusCode::kCorruptData, "message is not valid JSON"};
      return summariseJson(j, options_, 0);
    }
    case Kind::kProtobuf: {
      json out;
      CDFF_RETURN_IF_ERROR(ProtoJson(pool_, options_).message(*pool_.message(root_), data, 0, out));
      return out;
    }
    case Kind::kOpaque:
      return json{{"$bytes", data.size()}};
  }
  return json();
}

}  // namespace cdff::io
