// The codec of Detections: one JSON form (toJson/fromJson), which is also its MCAP message (with
// its own stamp as "timestamp") and its inline product value. Each detection's pose is written
// as products.json writes a Transform.
#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory

json toJson(const Detections& v) {
  json detections = json::array();
  for (const Detection& d : v.detections)
    detections.push_back({{"pose", toJson(d.pose)},
                          {"similarity", number(d.similarity)},
                          {"depth_agreement", number(d.depth_agreement)},
                          {"template_id", d.template_id},
                          {"box", {d.x, d.y, d.width, d.height}}});
  return {{"timestamp", timeJson(v.stamp)}, {"frame_id", v.frame_id}, {"detections", detections}};
}

Status fromJson(const json& j, Detections& out) {
  return readJsonValue("cdff.Detections", [&] {  // a missing key is a corrupt-data status
    Detections v;
    v.stamp = jsonTime(j);
    v.frame_id = j.at("frame_id").get<std::string>();
    const json& detections = j.at("detections");
    if (!detections.is_array()) throw std::runtime_error("expected 'detections' to be an array");
    for (std::size_t i = 0; i < detections.size(); ++i) {
      const json& d = detections[i];
      Detection det;
      if (Status s = fromJson(d.at("pose"), det.pose); !s)
        throw std::runtime_error(fmt::format("detection {} pose: {}", i, s.message()));
      det.similarity = jsonNumber(d.at("similarity"));
      det.depth_agreement = jsonNumber(d.at("depth_agreement"));
      det.template_id = d.at("template_id").get<std::string>();
      const json& box = d.at("box");
      if (!box.is_array() || box.size() != 4)
        throw std::runtime_error(
            fmt::format("detection {} box is {}; expected [x, y, width, height]", i, box.dump()));
      det.x = box[0].get<int>();
      det.y = box[1].get<int>();
      det.width = box[2].get<int>();
      det.height = box[3].get<int>();
      v.detections.push_back(std::move(det));
    }
    out = std::move(v);
  });
}

/// The MCAP message is the JSON form; `stamp` is ignored (the detections have their own).
Status encode(const Detections& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("detections", v.stamp);
  dumpTo(toJson(v), out);
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, Detections& out) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, "cdff.Detections", j));
  return fromJson(j, out);
}

}  // namespace cdff::codec
