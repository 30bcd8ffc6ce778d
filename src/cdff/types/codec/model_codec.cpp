// Codecs of the model-based tracking types: polygon models, the contours a camera sees of one
// and the samples along them. JSON messages (schemas cdff.PolygonModel, cdff.ModelContours,
// cdff.ContourSamples); the numbers are written with full precision, so values round-trip.
#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory

namespace {

template <typename Vec>
json array(const Vec& v) {
  json a = json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(number(static_cast<double>(v[i])));
  return a;
}

template <typename Vec>
Vec readArray(const json& j) {
  Vec v;
  if (!j.is_array() || j.size() != static_cast<std::size_t>(v.size()))
    throw std::runtime_error(fmt::format("expected {} numbers, got {}", v.size(), j.dump()));
  for (Eigen::Index i = 0; i < v.size(); ++i)
    v[i] = static_cast<typename Vec::Scalar>(jsonNumber(j[static_cast<std::size_t>(i)]));
  return v;
}

json cameraJson(const CameraModel& c) {
  return {{"width", c.width},
          {"height", c.height},
          {"fx", c.fx},
          {"fy", c.fy},
          {"cx", c.cx},
          {"cy", c.cy},
          {"distortion_model", static_cast<int>(c.distortion_model)},
          {"distortion", numbers(c.distortion)}};
}

CameraModel readCamera(const json& j) {
  CameraModel c;
  c.width = j.at("width").get<int>();
  c.height = j.at("height").get<int>();
  c.fx = jsonNumber(j.at("fx"));
  c.fy = jsonNumber(j.at("fy"));
  c.cx = jsonNumber(j.at("cx"));
  c.cy = jsonNumber(j.at("cy"));
  c.distortion_model = static_cast<DistortionModel>(j.at("distortion_model").get<int>());
  c.distortion = jsonNumbers(j.at("distortion"));
  return c;
}

json modelJson(const PolygonModel& m) {
  json points = json::array(), faces = json::array(), lines = json::array(),
       cylinders = json::array(), circles = json::array();
  for (const Eigen::Vector3d& p : m.points) points.push_back(array(p));
  for (const auto& f : m.faces) faces.push_back({{"points", f.points}, {"name", f.name}});
  for (const auto& l : m.lines) lines.push_back({{"a", l.a}, {"b", l.b}, {"name", l.name}});
  for (const auto& c : m.cylinders)
    cylinders.push_back({{"a", c.a}, {"b", c.b}, {"radius", number(c.radius)}, {"name", c.name}});
  for (const auto& c : m.circles)
    circles.push_back({{"centre", c.centre},
                       {"first", c.first},
                       {"second", c.second},
                       {"radius", number(c.radius)},
                       {"name", c.name}});
  return {{"frame_id", m.frame_id}, {"points", points},       {"faces", faces},
          {"lines", lines},         {"cylinders", cylinders}, {"circles", circles}};
}

PolygonModel readModel(const json& j) {
  PolygonModel m;
  m.frame_id = j.at("frame_id").get<std::string>();
  for (const json& p : j.at("points")) m.points.push_back(readArray<Eigen::Vector3d>(p));
  for (const json& f : j.at("faces"))
    m.faces.push_back({f.at("points").get<std::vector<std::uint32_t>>(), f.at("name")});
  for (const json& l : j.at("lines"))
    m.lines.push_back({l.at("a").get<std::uint32_t>(), l.at("b").get<std::uint32_t>(),
                       l.at("name").get<std::string>()});
  for (const json& c : j.at("cylinders"))
    m.cylinders.push_back({c.at("a").get<std::uint32_t>(), c.at("b").get<std::uint32_t>(),
                           jsonNumber(c.at("radius")), c.at("name").get<std::string>()});
  for (const json& c : j.at("circles"))
    m.circles.push_back({c.at("centre").get<std::uint32_t>(), c.at("first").get<std::uint32_t>(),
                         c.at("second").get<std::uint32_t>(), jsonNumber(c.at("radius")),
                         c.at("name").get<std::string>()});
  return m;
}

json contoursJson(const ModelContours& c) {
  json segments = json::array(), faces = json::array();
  for (const ContourSegment& s : c.segments)
    segments.push_back({{"a", array(s.a)},
                        {"b", array(s.b)},
                        {"edge", s.edge},
                        {"kind", static_cast<int>(s.kind)}});
  for (const VisibleFace& f : c.faces) {
    json outline = json::array();
    for (const Eigen::Vector3d& p : f.outline) outline.push_back(array(p));
    faces.push_back({{"face", f.face},
                     {"normal", array(f.normal)},
                     {"offset", number(f.offset)},
                     {"outline", outline}});
  }
  return {{"stamp_us", c.stamp},
          {"camera", cameraJson(c.camera)},
          {"camera_T_model", toJson(c.camera_T_model)},
          {"camera_T_reference", toJson(c.camera_T_reference)},
          {"segments", segments},
          {"faces", faces}};
}

Status readContours(const json& j, ModelContours& c) {
  CDFF_RETURN_IF_ERROR(fromJson(j.at("camera_T_model"), c.camera_T_model));
  CDFF_RETURN_IF_ERROR(fromJson(j.at("camera_T_reference"), c.camera_T_reference));
  return readJsonValue("cdff.ModelContours", [&] {
    c.stamp = j.at("stamp_us").get<Timestamp>();
    c.camera = readCamera(j.at("camera"));
    for (const json& s : j.at("segments"))
      c.segments.push_back(
          {readArray<Eigen::Vector3d>(s.at("a")), readArray<Eigen::Vector3d>(s.at("b")),
           s.at("edge").get<std::uint32_t>(), static_cast<ContourKind>(s.at("kind").get<int>())});
    for (const json& f : j.at("faces")) {
      VisibleFace face;
      face.face = f.at("face").get<std::uint32_t>();
      face.normal = readArray<Eigen::Vector3d>(f.at("normal"));
      face.offset = jsonNumber(f.at("offset"));
      for (const json& p : f.at("outline")) face.outline.push_back(readArray<Eigen::Vector3d>(p));
      c.faces.push_back(std::move(face));
    }
  });
}

json samplesJson(const ContourSamples& s) {
  json samples = json::array(), candidates = json::array();
  for (const ContourSample& q : s.samples)
    samples.push_back({{"point", array(q.point)},
                       {"pixel", array(q.pixel)},
                       {"normal", array(q.normal)},
                       {"segment", q.segment},
                       {"first_candidate", q.first_candidate},
                       {"candidate_count", q.candidate_count}});
  for (const EdgeCandidate& c : s.candidates)
    candidates.push_back({number(c.offset), number(c.strength)});
  return {{"contours", s.contours ? contoursJson(*s.contours) : json(nullptr)},
          {"samples", samples},
          {"candidates", candidates},
          {"matched", s.matched}};
}

Status readSamples(const json& j, ContourSamples& s) {
  if (!j.at("contours").is_null()) {
    auto contours = std::make_shared<ModelContours>();
    CDFF_RETURN_IF_ERROR(readContours(j.at("contours"), *contours));
    s.contours = std::move(contours);
  }
  return readJsonValue("cdff.ContourSamples", [&] {
    for (const json& q : j.at("samples"))
      s.samples.push_back(
          {readArray<Eigen::Vector3d>(q.at("point")), readArray<Eigen::Vector2d>(q.at("pixel")),
           readArray<Eigen::Vector2d>(q.at("normal")), q.at("segment").get<std::uint32_t>(),
           q.at("first_candidate").get<std::uint32_t>(),
           q.at("candidate_count").get<std::uint32_t>()});
    for (const json& c : j.at("candidates"))
      s.candidates.push_back(
          {static_cast<float>(jsonNumber(c.at(0))), static_cast<float>(jsonNumber(c.at(1)))});
    s.matched = j.at("matched").get<bool>();
  });
}

/// A message: the object with "timestamp" {sec, nsec}.
Status encodeStamped(json j, Timestamp stamp, std::string_view what, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp(what, stamp);
  j["timestamp"] = timeJson(stamp);
  dumpTo(j, out);
  return Status::ok();
}

}  // namespace

Status encode(const PolygonModel& v, Timestamp stamp, Encoded& out) {
  return encodeStamped(modelJson(v), stamp, "polygon model", out);
}
Status encode(const ModelContours& v, Timestamp, Encoded& out) {
  return encodeStamped(contoursJson(v), v.stamp, "model contours", out);
}
Status encode(const ContourSamples& v, Timestamp stamp, Encoded& out) {
  return encodeStamped(samplesJson(v), stamp, "contour samples", out);
}

Status decode(Bytes data, const std::shared_ptr<const void>&, PolygonModel& out) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, "cdff.PolygonModel", j));
  return readJsonValue("cdff.PolygonModel message", [&] { out = readModel(j); });
}
Status decode(Bytes data, const std::shared_ptr<const void>&, ModelContours& out) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, "cdff.ModelContours", j));
  out = ModelContours{};
  return readContours(j, out);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, ContourSamples& out) {
  json j;
  CDFF_RETURN_IF_ERROR(parseJson(data, "cdff.ContourSamples", j));
  out = ContourSamples{};
  return readSamples(j, out);
}

}  // namespace cdff::codec
