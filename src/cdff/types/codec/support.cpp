// The helpers the codecs share (support.hpp).
#include "cdff/types/codec/support.hpp"

namespace cdff::codec::detail {

Status negativeStamp(std::string_view what, Timestamp stamp) {
  return invalidInput("{} stamp is {} us; MCAP times are unsigned, expected a stamp >= 0", what,
                      stamp);
}

void putTimestamp(pb::Writer& w, std::uint32_t f, Timestamp us) {
  std::int64_t sec = us / kMicrosecondsPerSecond;
  std::int64_t rem = us % kMicrosecondsPerSecond;
  if (rem < 0) {
    rem += kMicrosecondsPerSecond;
    --sec;
  }
  const std::size_t s = w.begin(f);
  w.int64(1, sec);
  w.int32(2, static_cast<std::int32_t>(rem * 1000));
  w.end(s);
}

void putXyz(pb::Writer& w, std::uint32_t f, double x, double y, double z) {
  const std::size_t s = w.begin(f);
  w.float64(1, x);
  w.float64(2, y);
  w.float64(3, z);
  w.end(s);
}

void putQuaternion(pb::Writer& w, std::uint32_t f, const Eigen::Quaterniond& q) {
  const std::size_t s = w.begin(f);
  w.float64(1, q.x());
  w.float64(2, q.y());
  w.float64(3, q.z());
  w.float64(4, q.w());
  w.end(s);
}

void putPose(pb::Writer& w, std::uint32_t f, const Eigen::Vector3d& t,
             const Eigen::Quaterniond& q) {
  const std::size_t s = w.begin(f);
  putXyz(w, 1, t.x(), t.y(), t.z());
  putQuaternion(w, 2, q);
  w.end(s);
}

Status corruptMessage(std::string_view schema, const std::string& what) {
  return {StatusCode::kCorruptData, fmt::format("{} message: {}", schema, what)};
}

Status readTimestamp(Bytes data, Timestamp& out) {
  std::int64_t sec = 0, nsec = 0;
  CDFF_RETURN_IF_ERROR(forFields(data, "google.protobuf.Timestamp", [&](pb::Reader& r) {
    if (r.field() == 1 && r.type() == WireType::kVarint) sec = r.i64();
    if (r.field() == 2 && r.type() == WireType::kVarint) nsec = r.i32();
    return true;
  }));
  out = sec * kMicrosecondsPerSecond + nsec / 1000;
  return Status::ok();
}

Status readXyz(Bytes data, Eigen::Vector3d& v) {
  v.setZero();
  return forFields(data, "foxglove.Vector3", [&](pb::Reader& r) {
    if (r.field() >= 1 && r.field() <= 3) v[r.field() - 1] = fixed64Double(r);
    return true;
  });
}

Status readQuaternion(Bytes data, Eigen::Quaterniond& q) {
  double c[4] = {0, 0, 0, 0};
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.Quaternion", [&](pb::Reader& r) {
    if (r.field() >= 1 && r.field() <= 4) c[r.field() - 1] = fixed64Double(r);
    return true;
  }));
  // An absent orientation (all fields zero) is the identity, as Foxglove reads it.
  q = (c[0] == 0 && c[1] == 0 && c[2] == 0 && c[3] == 0)
          ? Eigen::Quaterniond::Identity()
          : Eigen::Quaterniond(c[3], c[0], c[1], c[2]);
  return Status::ok();
}

Status readPose(Bytes data, Eigen::Vector3d& t, Eigen::Quaterniond& q) {
  t.setZero();
  q = Eigen::Quaterniond::Identity();
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.Pose", [&](pb::Reader& r) {
    if (r.field() == 1 && isLen(r)) inner = readXyz(r.bytes(), t);
    if (r.field() == 2 && isLen(r)) inner = readQuaternion(r.bytes(), q);
    return inner.isOk();
  }));
  return inner;
}

Buffer<std::uint8_t> shareBytes(Bytes data, const std::shared_ptr<const void>& owner,
                                std::size_t alignment) {
  const bool aligned = reinterpret_cast<std::uintptr_t>(data.data()) % alignment == 0;
  if (owner && aligned) return Buffer<std::uint8_t>::view(owner, data.data(), data.size());
  return Buffer<std::uint8_t>::copyOf(data);
}

json timeJson(Timestamp us) {
  std::int64_t sec = us / kMicrosecondsPerSecond;
  std::int64_t rem = us % kMicrosecondsPerSecond;
  if (rem < 0) {
    rem += kMicrosecondsPerSecond;
    --sec;
  }
  return {{"sec", sec}, {"nsec", rem * 1000}};
}

// NaN and infinities become null (JSON has no such numbers); decoding turns null into NaN.
json number(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

json xyz(const Eigen::Vector3d& v) {
  return {{"x", number(v.x())}, {"y", number(v.y())}, {"z", number(v.z())}};
}

json rowMajor3(const Eigen::Matrix3d& m) {
  json a = json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a.push_back(number(m(r, c)));
  return a;
}

json numbers(const std::vector<double>& v) {
  json a = json::array();
  for (double x : v) a.push_back(number(x));
  return a;
}

void dumpTo(const json& j, Encoded& out) {
  const std::string text = j.dump(-1, ' ', false, json::error_handler_t::replace);
  out.bytes.assign(text.begin(), text.end());
}

Status parseJson(Bytes data, std::string_view schema, json& out) {
  out = json::parse(data.begin(), data.end(), nullptr, false);
  if (out.is_discarded()) return corruptMessage(schema, "is not valid JSON");
  if (!out.is_object()) return corruptMessage(schema, "is not a JSON object");
  return Status::ok();
}

double jsonNumber(const json& j) {
  return j.is_number() ? j.get<double>() : std::nan("");
}

Timestamp jsonTime(const json& j) {
  const json& t = j.at("timestamp");
  return t.at("sec").get<std::int64_t>() * kMicrosecondsPerSecond +
         t.at("nsec").get<std::int64_t>() / 1000;
}

Eigen::Vector3d jsonXyz(const json& j) {
  return {jsonNumber(j.at("x")), jsonNumber(j.at("y")), jsonNumber(j.at("z"))};
}

Eigen::Matrix3d jsonMatrix3(const json& j) {
  Eigen::Matrix3d m;
  if (j.size() != 9) throw std::out_of_range("expected 9 entries");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = jsonNumber(j.at(static_cast<std::size_t>(r * 3 + c)));
  return m;
}

std::vector<double> jsonNumbers(const json& j) {
  std::vector<double> v;
  for (const json& x : j) v.push_back(jsonNumber(x));
  return v;
}

}  // namespace cdff::codec::detail

namespace cdff::codec {

std::vector<Bytes> Encoded::parts() const {
  std::vector<Bytes> parts;
  std::size_t previous = 0;
  for (const Reference& r : references_) {
    if (r.at > previous) parts.emplace_back(bytes.data() + previous, r.at - previous);
    if (!r.data.empty()) parts.push_back(r.data);
    previous = r.at;
  }
  if (bytes.size() > previous) parts.emplace_back(bytes.data() + previous, bytes.size() - previous);
  return parts;
}

std::size_t Encoded::size() const {
  std::size_t n = bytes.size();
  for (const Reference& r : references_) n += r.data.size();
  return n;
}

std::vector<std::uint8_t> Encoded::flatten() const {
  std::vector<std::uint8_t> all;
  all.reserve(size());
  for (const Bytes& part : parts()) all.insert(all.end(), part.begin(), part.end());
  return all;
}

}  // namespace cdff::codec
