// MCAP codecs of features, matches and correspondences.
#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory
using F = pb::FieldType;

namespace {

void putDescriptors(pb::Writer& w, std::uint32_t f, const DescriptorMatrix& d) {
  const std::size_t s = w.begin(f);
  w.int32(1, d.element == DescriptorMatrix::Element::kUint8 ? 0 : 1);
  w.int32(2, static_cast<std::int32_t>(d.distance));
  w.uint64(3, static_cast<std::uint64_t>(std::max(d.rows, 0)));
  w.uint64(4, static_cast<std::uint64_t>(std::max(d.cols, 0)));
  w.bytes(5, d.data.span());
  w.end(s);
}

Status checkDescriptors(const DescriptorMatrix& d, std::size_t features) {
  if (d.rows < 0 || d.cols < 0)
    return invalidInput("descriptors are {}x{}; expected non-negative dimensions", d.rows, d.cols);
  const std::size_t need = static_cast<std::size_t>(d.rows) * d.cols * d.elementSize();
  if (d.data.size() != need)
    return invalidInput("descriptors hold {} bytes; expected rows x cols x element size = {}",
                        d.data.size(), need);
  if (d.rows != 0 && static_cast<std::size_t>(d.rows) != features)
    return invalidInput("{} descriptors for {} features; expected one per feature or none", d.rows,
                        features);
  return Status::ok();
}

template <typename T, typename Get>
void putPackedFloats(pb::Writer& w, std::uint32_t f, const std::vector<T>& items, Get get) {
  std::vector<float> values;
  values.reserve(items.size());
  for (const T& item : items) values.push_back(get(item));
  w.packed<float>(f, values);
}

template <typename Vec>
void putPackedVectors(pb::Writer& w, std::uint32_t f, const std::vector<Vec>& items) {
  using Scalar = typename Vec::Scalar;
  std::vector<Scalar> values;
  values.reserve(items.size() * Vec::RowsAtCompileTime);
  for (const Vec& v : items)
    for (int i = 0; i < Vec::RowsAtCompileTime; ++i) values.push_back(v[i]);
  w.packed<Scalar>(f, values);
}

}  // namespace

Status encode(const Features2D& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("features", v.stamp);
  CDFF_RETURN_IF_ERROR(checkDescriptors(v.descriptors, v.keypoints.size()));
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  const auto& k = v.keypoints;
  putPackedFloats(w, 3, k, [](const Keypoint2D& p) { return p.position.x(); });
  putPackedFloats(w, 4, k, [](const Keypoint2D& p) { return p.position.y(); });
  putPackedFloats(w, 5, k, [](const Keypoint2D& p) { return p.size; });
  putPackedFloats(w, 6, k, [](const Keypoint2D& p) { return p.angle; });
  putPackedFloats(w, 7, k, [](const Keypoint2D& p) { return p.response; });
  std::vector<std::int32_t> octaves;
  for (const Keypoint2D& p : k) octaves.push_back(p.octave);
  w.packedInt32(8, octaves);
  putDescriptors(w, 9, v.descriptors);
  return Status::ok();
}

Status encode(const Features3D& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("features", v.stamp);
  CDFF_RETURN_IF_ERROR(checkDescriptors(v.descriptors, v.keypoints.size()));
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  std::vector<Eigen::Vector3f> positions, normals;
  for (const Keypoint3D& p : v.keypoints) {
    positions.push_back(p.position);
    normals.push_back(p.normal);
  }
  putPackedVectors(w, 3, positions);
  putPackedVectors(w, 4, normals);
  putDescriptors(w, 5, v.descriptors);
  return Status::ok();
}

Status encode(const Matches& v, Timestamp stamp, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp("matches", stamp);
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, stamp);
  std::vector<std::int32_t> query, train;
  std::vector<float> distance;
  for (const Match& m : v.matches) {
    query.push_back(m.query);
    train.push_back(m.train);
    distance.push_back(m.distance);
  }
  w.packedInt32(2, query);
  w.packedInt32(3, train);
  w.packed<float>(4, distance);
  return Status::ok();
}

namespace {

template <typename A, typename B>
Status encodePairs(const std::vector<A>& a, const std::vector<B>& b, Timestamp stamp,
                   std::string_view what, Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp(what, stamp);
  if (a.size() != b.size())
    return invalidInput("{} have {} and {} entries; expected as many of each", what, a.size(),
                        b.size());
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, stamp);
  putPackedVectors(w, 2, a);
  putPackedVectors(w, 3, b);
  return Status::ok();
}

}  // namespace

Status encode(const Correspondences2D& v, Timestamp stamp, Encoded& out) {
  return encodePairs(v.first, v.second, stamp, "2D correspondences", out);
}
Status encode(const Correspondences3D& v, Timestamp stamp, Encoded& out) {
  return encodePairs(v.first, v.second, stamp, "3D correspondences", out);
}
Status encode(const Correspondences2D3D& v, Timestamp stamp, Encoded& out) {
  return encodePairs(v.points, v.pixels, stamp, "2D-3D correspondences", out);
}

namespace {

Status readDescriptors(Bytes data, DescriptorMatrix& d) {
  d = DescriptorMatrix{};
  Bytes bytes;
  std::uint64_t rows = 0, cols = 0;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.DescriptorMatrix", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        d.element =
            r.u64() == 1 ? DescriptorMatrix::Element::kFloat32 : DescriptorMatrix::Element::kUint8;
        break;
      case 2:
        d.distance = static_cast<DescriptorMatrix::Distance>(std::min<std::uint64_t>(r.u64(), 2));
        break;
      case 3:
        rows = r.u64();
        break;
      case 4:
        cols = r.u64();
        break;
      case 5:
        if (isLen(r)) bytes = r.bytes();
        break;
      default:
        break;
    }
    return true;
  }));
  if (rows > (1u << 30) || cols > (1u << 20) || rows * cols * d.elementSize() != bytes.size())
    return corruptMessage(
        "cdff.DescriptorMatrix",
        fmt::format("{} x {} descriptors of {} bytes need {} bytes; the data "
                    "holds {}",
                    rows, cols, d.elementSize(), rows * cols * d.elementSize(), bytes.size()));
  d.rows = static_cast<int>(rows);
  d.cols = static_cast<int>(cols);
  d.data = Buffer<std::uint8_t>::copyOf(bytes);
  return Status::ok();
}

Status sameSizes(std::string_view schema, std::initializer_list<std::size_t> sizes,
                 std::size_t expected) {
  for (std::size_t s : sizes)
    if (s != expected)
      return corruptMessage(schema, fmt::format("per-feature arrays have {} and {} entries; "
                                                "expected the same count",
                                                s, expected));
  return Status::ok();
}

template <typename Vec>
Status toVectors(std::string_view schema, const std::vector<typename Vec::Scalar>& values,
                 std::vector<Vec>& out) {
  constexpr int n = Vec::RowsAtCompileTime;
  if (values.size() % n != 0)
    return corruptMessage(schema,
                          fmt::format("{} coordinates, not a multiple of {}", values.size(), n));
  out.resize(values.size() / n);
  for (std::size_t i = 0; i < out.size(); ++i)
    for (int k = 0; k < n; ++k) out[i][k] = values[i * n + k];
  return Status::ok();
}

}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>&, Features2D& out) {
  out = Features2D{};
  std::vector<float> x, y, size, angle, response;
  std::vector<std::int64_t> octave;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.Features2D", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r)) inner = readTimestamp(r.bytes(), out.stamp);
        break;
      case 2:
        if (isLen(r)) out.frame_id = r.string();
        break;
      case 3:
        return appendRepeated(r, x);
      case 4:
        return appendRepeated(r, y);
      case 5:
        return appendRepeated(r, size);
      case 6:
        return appendRepeated(r, angle);
      case 7:
        return appendRepeated(r, response);
      case 8:
        return r.appendVarint(octave);
      case 9:
        if (isLen(r)) inner = readDescriptors(r.bytes(), out.descriptors);
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  CDFF_RETURN_IF_ERROR(
      sameSizes("cdff.Features2D",
                {y.size(), size.size(), angle.size(), response.size(), octave.size()}, x.size()));
  out.keypoints.resize(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    Keypoint2D& k = out.keypoints[i];
    k.position = {x[i], y[i]};
    k.size = size[i];
    k.angle = angle[i];
    k.response = response[i];
    k.octave = static_cast<int>(octave[i]);
  }
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, Features3D& out) {
  out = Features3D{};
  std::vector<float> positions, normals;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.Features3D", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r)) inner = readTimestamp(r.bytes(), out.stamp);
        break;
      case 2:
        if (isLen(r)) out.frame_id = r.string();
        break;
      case 3:
        return appendRepeated(r, positions);
      case 4:
        return appendRepeated(r, normals);
      case 5:
        if (isLen(r)) inner = readDescriptors(r.bytes(), out.descriptors);
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  std::vector<Eigen::Vector3f> p, n;
  CDFF_RETURN_IF_ERROR(toVectors("cdff.Features3D", positions, p));
  CDFF_RETURN_IF_ERROR(toVectors("cdff.Features3D", normals, n));
  if (!n.empty()) CDFF_RETURN_IF_ERROR(sameSizes("cdff.Features3D", {n.size()}, p.size()));
  out.keypoints.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    out.keypoints[i].position = p[i];
    if (!n.empty()) out.keypoints[i].normal = n[i];
  }
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, Matches& out) {
  out = Matches{};
  std::vector<std::int64_t> query, train;
  std::vector<float> distance;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.Matches", [&](pb::Reader& r) {
    if (r.field() == 2) return r.appendVarint(query);
    if (r.field() == 3) return r.appendVarint(train);
    if (r.field() == 4) return appendRepeated(r, distance);
    return true;
  }));
  CDFF_RETURN_IF_ERROR(sameSizes("cdff.Matches", {train.size(), distance.size()}, query.size()));
  out.matches.resize(query.size());
  for (std::size_t i = 0; i < query.size(); ++i)
    out.matches[i] = {static_cast<int>(query[i]), static_cast<int>(train[i]), distance[i]};
  return Status::ok();
}

namespace {

template <typename A, typename B>
Status decodePairs(Bytes data, std::string_view schema, std::vector<A>& a, std::vector<B>& b) {
  std::vector<double> first, second;
  CDFF_RETURN_IF_ERROR(forFields(data, schema, [&](pb::Reader& r) {
    if (r.field() == 2) return appendRepeated(r, first);
    if (r.field() == 3) return appendRepeated(r, second);
    return true;
  }));
  CDFF_RETURN_IF_ERROR(toVectors(schema, first, a));
  CDFF_RETURN_IF_ERROR(toVectors(schema, second, b));
  return sameSizes(schema, {b.size()}, a.size());
}

}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>&, Correspondences2D& out) {
  out = Correspondences2D{};
  return decodePairs(data, "cdff.Correspondences2D", out.first, out.second);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, Correspondences3D& out) {
  out = Correspondences3D{};
  return decodePairs(data, "cdff.Correspondences3D", out.first, out.second);
}
Status decode(Bytes data, const std::shared_ptr<const void>&, Correspondences2D3D& out) {
  out = Correspondences2D3D{};
  return decodePairs(data, "cdff.Correspondences2D3D", out.points, out.pixels);
}

}  // namespace cdff::codec
