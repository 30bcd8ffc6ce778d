// The codec of LidarInfo: one JSON form (toJson/fromJson), which is also its MCAP message (with
// its own stamp as "timestamp") and its inline product value.
#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory

json toJson(const LidarInfo& v) {
  return {{"timestamp", timeJson(v.stamp)},      {"frame_id", v.frame_id},
          {"elevations", numbers(v.elevations)}, {"rotation_rate", number(v.rotation_rate)},
          {"min_range", number(v.min_range)},    {"max_range", number(v.max_range)},
          {"range_noise", number(v.range_noise)}};
}

Status fromJson(const json& j, LidarInfo& out) {
  return readJsonValue("cdff.LidarInfo", [&] {  // a missing key is a corrupt-data status
    LidarInfo v;
    v.stamp = jsonTime(j);
    v.frame_id = j.at("frame_id").get<std::string>();
    v.elevations = jsonNumbers(j.at("elevations"));
    v.rotation_rate = jsonNumber(j.at("rotation_rate"));
    v.min_range = jsonNumber(j.at("min_range"));
    v.max_range = jsonNumber(j.at("max_range"));
    v.range_noise = jsonNumber(j.at("range_noise"));
    out = std::move(v);
  });
}

/// The MCAP message is the JSON form; `stamp` is ignored (the description has its own).
Status encode(const LidarInfo& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("LIDAR info", v.stamp);
  dumpTo(toJson(v), out);
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, LidarInfo& out) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, "cdff.LidarInfo", j));
  return fromJson(j, out);
}

}  // namespace cdff::codec
