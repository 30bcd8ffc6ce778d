// Codecs of the JSON-encoded types: IMU samples, wrenches, joint states, free-form records,
// track states and scalars. Each has one JSON form (toJson/fromJson): an object type's MCAP
// message is that object, with its own stamp as "timestamp"; a scalar's message wraps it as
// {"timestamp", "value"}; the Data Product Manager saves the same JSON inline.
#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory

namespace {

/// The message of an object type: its JSON form.
template <typename T>
Status encodeObject(const T& v, Timestamp own_stamp, std::string_view what, Encoded& out) {
  out.clear();
  if (own_stamp < 0) return negativeStamp(what, own_stamp);
  dumpTo(toJson(v), out);
  return Status::ok();
}

template <typename T>
Status decodeObject(Bytes data, std::string_view schema, T& out) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, schema, j));
  return fromJson(j, out);
}

/// The message of a scalar: {"timestamp", "value"}.
template <typename T>
Status encodeWrapped(const T& v, Timestamp stamp, std::string_view what, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp(what, stamp);
  dumpTo({{"timestamp", timeJson(stamp)}, {"value", toJson(v)}}, out);
  return Status::ok();
}

template <typename T>
Status decodeWrapped(Bytes data, std::string_view schema, T& out) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, schema, j));
  if (!j.contains("value")) return corruptMessage(schema, "has no 'value'");
  return fromJson(j.at("value"), out).withContext(fmt::format("{} message", schema));
}

Status wrongJson(std::string_view expected, const json& j) {
  return corruptData("JSON value {} is a {}; expected {}", j.dump(), j.type_name(), expected);
}

}  // namespace

// ---- IMU samples, wrenches, joint states -------------------------------------------------------

json toJson(const ImuSample& v) {
  return {{"timestamp", timeJson(v.stamp)},
          {"frame_id", v.frame_id},
          {"angular_velocity", xyz(v.angular_velocity)},
          {"linear_acceleration", xyz(v.linear_acceleration)},
          {"angular_velocity_covariance", rowMajor3(v.angular_velocity_covariance)},
          {"linear_acceleration_covariance", rowMajor3(v.linear_acceleration_covariance)}};
}

Status fromJson(const json& j, ImuSample& out) {
  return readJsonValue("cdff.ImuSample", [&] {
    ImuSample v;
    v.stamp = jsonTime(j);
    v.frame_id = j.at("frame_id").get<std::string>();
    v.angular_velocity = jsonXyz(j.at("angular_velocity"));
    v.linear_acceleration = jsonXyz(j.at("linear_acceleration"));
    v.angular_velocity_covariance = jsonMatrix3(j.at("angular_velocity_covariance"));
    v.linear_acceleration_covariance = jsonMatrix3(j.at("linear_acceleration_covariance"));
    out = std::move(v);
  });
}

json toJson(const Wrench& v) {
  return {{"timestamp", timeJson(v.stamp)},
          {"frame_id", v.frame_id},
          {"force", xyz(v.force)},
          {"torque", xyz(v.torque)}};
}

Status fromJson(const json& j, Wrench& out) {
  return readJsonValue("cdff.Wrench", [&] {
    Wrench v;
    v.stamp = jsonTime(j);
    v.frame_id = j.at("frame_id").get<std::string>();
    v.force = jsonXyz(j.at("force"));
    v.torque = jsonXyz(j.at("torque"));
    out = std::move(v);
  });
}

json toJson(const JointState& v) {
  return {{"timestamp", timeJson(v.stamp)},
          {"name", v.names},
          {"position", numbers(v.position)},
          {"velocity", numbers(v.velocity)},
          {"effort", numbers(v.effort)}};
}

Status fromJson(const json& j, JointState& out) {
  return readJsonValue("cdff.JointState", [&] {
    JointState v;
    v.stamp = jsonTime(j);
    v.names = j.at("name").get<std::vector<std::string>>();
    v.position = jsonNumbers(j.at("position"));
    v.velocity = jsonNumbers(j.at("velocity"));
    v.effort = jsonNumbers(j.at("effort"));
    out = std::move(v);
  });
}

Status encode(const ImuSample& v, Timestamp, Encoded& out) {
  return encodeObject(v, v.stamp, "IMU sample", out);
}
Status encode(const Wrench& v, Timestamp, Encoded& out) {
  return encodeObject(v, v.stamp, "wrench", out);
}
Status encode(const JointState& v, Timestamp, Encoded& out) {
  return encodeObject(v, v.stamp, "joint state", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, ImuSample& out) {
  return decodeObject(data, "cdff.ImuSample", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, Wrench& out) {
  return decodeObject(data, "cdff.Wrench", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, JointState& out) {
  return decodeObject(data, "cdff.JointState", out);
}

// ---- free-form records
// ---------------------------------------------------------------------------

json toJson(const json& v) {
  return v;
}

Status fromJson(const json& j, json& out) {
  out = j;
  return Status::ok();
}

/// A record's message is the object with "timestamp": {"sec", "nsec"} added unless present.
Status encode(const json& v, Timestamp stamp, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp("record", stamp);
  if (!v.is_object())
    return invalidInput("a JSON record must be an object; got a {}", v.type_name());
  if (v.contains("timestamp")) {
    dumpTo(v, out);
  } else {
    json copy = v;
    copy["timestamp"] = timeJson(stamp);
    dumpTo(copy, out);
  }
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, json& out) {
  return parseJson(data, "JSON record", out);
}

// ---- track states and scalars
// ----------------------------------------------------------------------

json toJson(TrackState v) {
  return std::string(toString(v));
}

Status fromJson(const json& j, TrackState& out) {
  const std::optional<TrackState> state =
      j.is_string() ? parseTrackState(j.get<std::string>()) : std::nullopt;
  if (!state)
    return wrongJson("a track state (UNINITIALISED, ACQUIRING, TRACKING, DEGRADED, LOST)", j);
  out = *state;
  return Status::ok();
}

/// NaN is null; infinities are +-1e308 (JSON has neither).
json toJson(double v) {
  if (std::isfinite(v)) return v;
  return std::isnan(v) ? json(nullptr) : json(v > 0 ? 1e308 : -1e308);
}

Status fromJson(const json& j, double& out) {
  if (j.is_null()) {
    out = std::nan("");
    return Status::ok();
  }
  if (!j.is_number()) return wrongJson("a number or null", j);
  out = j.get<double>();
  return Status::ok();
}

json toJson(bool v) {
  return v;
}
Status fromJson(const json& j, bool& out) {
  if (!j.is_boolean()) return wrongJson("true or false", j);
  out = j.get<bool>();
  return Status::ok();
}

json toJson(int v) {
  return v;
}
Status fromJson(const json& j, int& out) {
  if (!j.is_number_integer()) return wrongJson("an integer", j);
  out = j.get<int>();
  return Status::ok();
}

json toJson(std::int64_t v) {
  return v;
}
Status fromJson(const json& j, std::int64_t& out) {
  if (!j.is_number_integer()) return wrongJson("an integer", j);
  out = j.get<std::int64_t>();
  return Status::ok();
}

json toJson(const std::string& v) {
  return v;
}
Status fromJson(const json& j, std::string& out) {
  if (!j.is_string()) return wrongJson("a string", j);
  out = j.get<std::string>();
  return Status::ok();
}

Status encode(const TrackState& v, Timestamp stamp, Encoded& out) {
  return encodeWrapped(v, stamp, "track state", out);
}
Status encode(const double& v, Timestamp stamp, Encoded& out) {
  return encodeWrapped(v, stamp, "scalar", out);
}
Status encode(const bool& v, Timestamp stamp, Encoded& out) {
  return encodeWrapped(v, stamp, "scalar", out);
}
Status encode(const int& v, Timestamp stamp, Encoded& out) {
  return encodeWrapped(v, stamp, "scalar", out);
}
Status encode(const std::int64_t& v, Timestamp stamp, Encoded& out) {
  return encodeWrapped(v, stamp, "scalar", out);
}
Status encode(const std::string& v, Timestamp stamp, Encoded& out) {
  return encodeWrapped(v, stamp, "scalar", out);
}

Status decode(Bytes data, const std::shared_ptr<const void>&, TrackState& out) {
  return decodeWrapped(data, "cdff.TrackState", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, double& out) {
  return decodeWrapped(data, "cdff.Double", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, bool& out) {
  return decodeWrapped(data, "cdff.Bool", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, int& out) {
  return decodeWrapped(data, "cdff.Int", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, std::int64_t& out) {
  return decodeWrapped(data, "cdff.Timestamp", out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, std::string& out) {
  return decodeWrapped(data, "cdff.String", out);
}

}  // namespace cdff::codec
