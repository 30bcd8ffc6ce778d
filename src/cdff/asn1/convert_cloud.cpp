// PointCloud: points, and the optional normals, intensity, ring and time offsets.
#include <cmath>
#include <limits>

#include "cdff/asn1/convert.hpp"

namespace cdff::asn1::detail {

namespace {

Status outOfMemory(std::string_view field) {
  return Status(StatusCode::kInternal, fmt::format("{}: out of memory", field));
}

// Appends a freshly allocated element to an asn1c list.
template <typename E>
Result<E*> append(asn_anonymous_sequence_& list, std::string_view field) {
  auto* e = static_cast<E*>(std::calloc(1, sizeof(E)));
  if (!e) return outOfMemory(field);
  if (ASN_SEQUENCE_ADD(&list, e) != 0) {
    std::free(e);
    return outOfMemory(field);
  }
  return e;
}

Status setPoints(asn_anonymous_sequence_& list, const Buffer<Point4f>& points,
                 std::string_view field) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point4f& p = points[i];
    for (float c : {p.x, p.y, p.z})
      if (!std::isfinite(c))
        return invalidInput("{}[{}] is ({}, {}, {}); T-Double holds finite numbers only", field, i,
                            p.x, p.y, p.z);
    Result<Vector3d_t*> v = append<Vector3d_t>(list, field);
    if (!v) return v.status();
    CDFF_RETURN_IF_ERROR(setVector(**v, p.vec().cast<double>(), field));
  }
  return Status::ok();
}

// The optional per-point arrays: absent when empty, else one entry per point.
template <typename Opt>
Result<asn_anonymous_sequence_*> optional(Opt*& member, std::size_t n, std::size_t points,
                                          std::string_view field) {
  if (n == 0) return static_cast<asn_anonymous_sequence_*>(nullptr);
  if (n != points)
    return invalidInput("{} has {} entries for {} points; expected one per point", field, n,
                        points);
  member = static_cast<Opt*>(std::calloc(1, sizeof(Opt)));
  if (!member) return outOfMemory(field);
  return &anonymous(member->list);
}

template <typename E, typename T>
Status setScalars(asn_anonymous_sequence_& list, const Buffer<T>& values, std::string_view field) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if constexpr (std::is_floating_point_v<T>)
      if (!std::isfinite(values[i]))
        return invalidInput("{}[{}] is {}; T-Double holds finite numbers only", field, i,
                            values[i]);
    Result<E*> e = append<E>(list, field);
    if (!e) return e.status();
    **e = static_cast<E>(values[i]);
  }
  return Status::ok();
}

Status fillCloud(PointCloud_t& s, const PointCloud& v) {
  if (v.size() > kMaxCloudPoints)
    return invalidInput("PointCloud.points has {} points; the bound of PointCloud is {} points",
                        v.size(), kMaxCloudPoints);
  s.time.microseconds = v.stamp;
  CDFF_RETURN_IF_ERROR(setString(s.frame_id, v.frame_id, "PointCloud.frame-id"));
  CDFF_RETURN_IF_ERROR(setPoints(anonymous(s.points.list), v.points, "PointCloud.points"));
  const std::size_t n = v.size();
  Result<asn_anonymous_sequence_*> normals =
      optional(s.normals, v.normals.size(), n, "PointCloud.normals");
  if (!normals) return normals.status();
  if (*normals) CDFF_RETURN_IF_ERROR(setPoints(**normals, v.normals, "PointCloud.normals"));
  Result<asn_anonymous_sequence_*> intensity =
      optional(s.intensity, v.intensity.size(), n, "PointCloud.intensity");
  if (!intensity) return intensity.status();
  if (*intensity)
    CDFF_RETURN_IF_ERROR(setScalars<T_Double_t>(**intensity, v.intensity, "PointCloud.intensity"));
  Result<asn_anonymous_sequence_*> ring = optional(s.ring, v.ring.size(), n, "PointCloud.ring");
  if (!ring) return ring.status();
  if (*ring) CDFF_RETURN_IF_ERROR(setScalars<T_UInt16_t>(**ring, v.ring, "PointCloud.ring"));
  Result<asn_anonymous_sequence_*> offsets =
      optional(s.time_offset, v.time_offset_us.size(), n, "PointCloud.time-offset");
  if (!offsets) return offsets.status();
  if (*offsets)
    CDFF_RETURN_IF_ERROR(
        setScalars<T_Int32_t>(**offsets, v.time_offset_us, "PointCloud.time-offset"));
  return Status::ok();
}

// A list read back: its count (one per point for the optional arrays).
Status checkCount(const asn_anonymous_sequence_& list, std::size_t expected,
                  std::string_view field) {
  if (list.count >= 0 && static_cast<std::size_t>(list.count) == expected) return Status::ok();
  return corruptData("{} has {} entries; expected {}, one per point", field, list.count, expected);
}

Result<Buffer<Point4f>> getPoints(const asn_anonymous_sequence_& list, std::string_view field) {
  std::vector<Point4f> points(static_cast<std::size_t>(std::max(list.count, 0)));
  for (std::size_t i = 0; i < points.size(); ++i) {
    Result<Eigen::Vector3d> p = getVector(*static_cast<const Vector3d_t*>(list.array[i]), field);
    if (!p) return p.status();
    if (p->cwiseAbs().maxCoeff() > std::numeric_limits<float>::max())
      return corruptData(
          "{}[{}] is ({}, {}, {}); expected coordinates within float range (the "
          "CDFF's points are floats)",
          field, i, p->x(), p->y(), p->z());
    // Doubles the CDFF wrote are floats: exact; another writer's are rounded to float.
    points[i] =
        Point4f(static_cast<float>(p->x()), static_cast<float>(p->y()), static_cast<float>(p->z()));
  }
  return Buffer<Point4f>::fromVector(std::move(points));
}

template <typename T, typename E>
Result<Buffer<T>> getScalars(const asn_anonymous_sequence_& list, std::size_t points,
                             std::string_view field) {
  CDFF_RETURN_IF_ERROR(checkCount(list, points, field));
  std::vector<T> values(points);
  for (std::size_t i = 0; i < points; ++i) {
    const E e = *static_cast<const E*>(list.array[i]);
    if constexpr (std::is_floating_point_v<E>) {
      if (!std::isfinite(e))
        return corruptData("{}[{}] is {}; T-Double holds finite numbers only", field, i, e);
      if (std::abs(e) > std::numeric_limits<T>::max())
        return corruptData("{}[{}] is {}; expected a value within float range", field, i, e);
    }
    values[i] = static_cast<T>(e);
  }
  return Buffer<T>::fromVector(std::move(values));
}

Status readOptionals(const PointCloud_t& s, PointCloud& v) {
  const std::size_t n = v.size();
  if (s.normals) {
    CDFF_RETURN_IF_ERROR(checkCount(anonymous(s.normals->list), n, "PointCloud.normals"));
    Result<Buffer<Point4f>> normals = getPoints(anonymous(s.normals->list), "PointCloud.normals");
    if (!normals) return normals.status();
    v.normals = std::move(normals).value();
  }
  if (s.intensity) {
    auto r = getScalars<float, double>(anonymous(s.intensity->list), n, "PointCloud.intensity");
    if (!r) return r.status();
    v.intensity = std::move(r).value();
  }
  if (s.ring) {
    auto r = getScalars<std::uint16_t, long>(anonymous(s.ring->list), n, "PointCloud.ring");
    if (!r) return r.status();
    v.ring = std::move(r).value();
  }
  if (s.time_offset) {
    auto r =
        getScalars<std::int32_t, long>(anonymous(s.time_offset->list), n, "PointCloud.time-offset");
    if (!r) return r.status();
    v.time_offset_us = std::move(r).value();
  }
  return Status::ok();
}

}  // namespace

Status encodePointCloud(const PointCloud& v, std::vector<std::uint8_t>& out) {
  Filled<PointCloud_t> s(asn_DEF_PointCloud);
  CDFF_RETURN_IF_ERROR(fillCloud(s.value, v));
  return encodeStruct(asn_DEF_PointCloud, &s.value, out);
}

Result<PointCloud> decodePointCloud(std::span<const std::uint8_t> data) {
  Result<Decoded<PointCloud_t>> s = decodeAs<PointCloud_t>(asn_DEF_PointCloud, data);
  if (!s) return s.status();
  PointCloud v;
  v.stamp = (*s)->time.microseconds;
  Result<std::string> frame = getString((*s)->frame_id, "PointCloud.frame-id");
  if (!frame) return frame.status();
  v.frame_id = std::move(frame).value();
  Result<Buffer<Point4f>> points = getPoints(anonymous((*s)->points.list), "PointCloud.points");
  if (!points) return points.status();
  v.points = std::move(points).value();
  CDFF_RETURN_IF_ERROR(readOptionals(**s, v));
  return v;
}

}  // namespace cdff::asn1::detail
