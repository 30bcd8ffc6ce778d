// The codecs of far-range tracking's types, ImageRegion and Bearing: one JSON form each
// (toJson/fromJson), which is also the MCAP message (with its own stamp as "timestamp") and the
// inline product value. A bearing also writes its azimuth and elevation (degrees), for plots;
// they are recomputed from the direction on reading.
#include "cdff/types/codec/support.hpp"

#include <cmath>
#include <numbers>

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory

json toJson(const ImageRegion& v) {
  json h = json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) h.push_back(number(v.homography(r, c)));
  const Eigen::Vector2d centre = v.centre();
  return {{"timestamp", timeJson(v.stamp)},
          {"frame_id", v.frame_id},
          {"homography", h},
          {"size", {v.width, v.height}},
          {"centre", {number(centre.x()), number(centre.y())}},
          {"score", number(v.score)},
          {"covariance",
           {number(v.covariance(0, 0)), number(v.covariance(0, 1)), number(v.covariance(1, 0)),
            number(v.covariance(1, 1))}},
          {"source", v.source}};
}

Status fromJson(const json& j, ImageRegion& out) {
  return readJsonValue("cdff.ImageRegion", [&] {  // a missing key is a corrupt-data status
    ImageRegion v;
    v.stamp = jsonTime(j);
    v.frame_id = j.at("frame_id").get<std::string>();
    const std::vector<double> h = jsonNumbers(j.at("homography"));
    const std::vector<double> c = jsonNumbers(j.at("covariance"));
    const json& size = j.at("size");
    if (h.size() != 9 || c.size() != 4 || !size.is_array() || size.size() != 2)
      throw std::runtime_error(
          "expected 'homography' of 9 numbers, 'covariance' of 4 and 'size' of 2");
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col) v.homography(r, col) = h[3 * r + col];
    v.covariance << c[0], c[1], c[2], c[3];
    v.width = size[0].get<int>();
    v.height = size[1].get<int>();
    v.score = jsonNumber(j.at("score"));
    v.source = j.at("source").get<std::string>();
    out = std::move(v);
  });
}

json toJson(const Bearing& v) {
  constexpr double kDeg = 180.0 / std::numbers::pi;
  return {{"timestamp", timeJson(v.stamp)},
          {"frame_id", v.frame_id},
          {"direction", xyz(v.direction)},
          {"covariance", rowMajor3(v.covariance)},
          {"azimuth_deg", number(v.azimuth() * kDeg)},
          {"elevation_deg", number(v.elevation() * kDeg)},
          {"range", number(v.range)},
          {"range_variance", number(v.range_variance)},
          {"range_rate", number(v.range_rate)},
          {"range_rate_variance", number(v.range_rate_variance)},
          {"designation", v.designation}};
}

Status fromJson(const json& j, Bearing& out) {
  return readJsonValue("cdff.Bearing", [&] {
    Bearing v;
    v.stamp = jsonTime(j);
    v.frame_id = j.at("frame_id").get<std::string>();
    v.direction = jsonXyz(j.at("direction"));
    v.covariance = jsonMatrix3(j.at("covariance"));
    v.range = jsonNumber(j.at("range"));
    v.range_variance = jsonNumber(j.at("range_variance"));
    v.range_rate = jsonNumber(j.at("range_rate"));
    v.range_rate_variance = jsonNumber(j.at("range_rate_variance"));
    v.designation = j.at("designation").get<std::string>();
    out = std::move(v);
  });
}

Status encode(const ImageRegion& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("image region", v.stamp);
  dumpTo(toJson(v), out);
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, ImageRegion& out) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, "cdff.ImageRegion", j));
  return fromJson(j, out);
}

Status encode(const Bearing& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("bearing", v.stamp);
  dumpTo(toJson(v), out);
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, Bearing& out) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, "cdff.Bearing", j));
  return fromJson(j, out);
}

}  // namespace cdff::codec
