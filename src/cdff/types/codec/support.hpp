#pragma once
// What the codecs share: protobuf field helpers for the Foxglove building blocks (time stamps,
// vectors, quaternions, poses) and JSON helpers (times, numbers that may be NaN). Internal to
// src/cdff/types/codec/.

#include <cmath>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "cdff/types/codec/codec.hpp"
#include "cdff/types/codec/protobuf.hpp"

namespace cdff::codec::detail {

using nlohmann::json;
using pb::WireType;

Status negativeStamp(std::string_view what, Timestamp stamp);
Status corruptMessage(std::string_view schema, const std::string& what);

// ---- protobuf writing
void putTimestamp(pb::Writer& w, std::uint32_t f, Timestamp us);
void putXyz(pb::Writer& w, std::uint32_t f, double x, double y, double z);
void putQuaternion(pb::Writer& w, std::uint32_t f, const Eigen::Quaterniond& q);
void putPose(pb::Writer& w, std::uint32_t f, const Eigen::Vector3d& t, const Eigen::Quaterniond& q);

// ---- protobuf reading
/// Runs `on_field` on every field of `data`; fails with the reader's error.
template <typename OnField>
Status forFields(Bytes data, std::string_view schema, OnField&& on_field) {
  pb::Reader r(data);
  while (r.next())
    if (!on_field(r)) break;
  if (!r.ok()) return corruptMessage(schema, r.error());
  return Status::ok();
}
inline bool isLen(const pb::Reader& r) {
  return r.type() == WireType::kLen;
}
inline double fixed64Double(const pb::Reader& r) {
  return r.type() == WireType::kFixed64 ? r.f64() : 0.0;
}
template <typename T>
bool appendRepeated(pb::Reader& r, std::vector<T>& out) {
  return r.appendFixed(out);
}
Status readTimestamp(Bytes data, Timestamp& out);
Status readXyz(Bytes data, Eigen::Vector3d& v);
Status readQuaternion(Bytes data, Eigen::Quaterniond& q);
Status readPose(Bytes data, Eigen::Vector3d& t, Eigen::Quaterniond& q);
/// Bytes from a message: shared with `owner` when aligned for `alignment`, else copied.
Buffer<std::uint8_t> shareBytes(Bytes data, const std::shared_ptr<const void>& owner,
                                std::size_t alignment);

// ---- JSON
/// {"sec", "nsec"}, as Foxglove writes times.
json timeJson(Timestamp us);
Timestamp jsonTime(const json& j);
/// NaN and infinities become null (JSON has no such numbers); jsonNumber turns null into NaN.
json number(double v);
double jsonNumber(const json& j);
json xyz(const Eigen::Vector3d& v);
Eigen::Vector3d jsonXyz(const json& j);
json rowMajor3(const Eigen::Matrix3d& m);
Eigen::Matrix3d jsonMatrix3(const json& j);
json numbers(const std::vector<double>& v);
std::vector<double> jsonNumbers(const json& j);
/// The message text of `j` (invalid UTF-8 replaced).
void dumpTo(const json& j, Encoded& out);
Status parseJson(Bytes data, std::string_view schema, json& out);

/// Parses a JSON message and runs `fill` on it; nlohmann's exceptions (a missing key, a wrong
/// type) become a corrupt-data status naming the schema.
template <typename Fill>
Status fromJsonMessage(Bytes data, std::string_view schema, Fill&& fill) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, schema, j));
  try {
    fill(j);
  } catch (const std::exception& e) {
    return corruptMessage(schema, fmt::format("missing or malformed field: {}", e.what()));
  }
  return Status::ok();
}

/// Runs `fill` on a product's JSON value; exceptions become a corrupt-data status.
template <typename Fill>
Status readJsonValue(std::string_view what, Fill&& fill) {
  try {
    fill();
  } catch (const std::exception& e) {
    return corruptData("{}: missing or malformed field: {}", what, e.what());
  }
  return Status::ok();
}

}  // namespace cdff::codec::detail
