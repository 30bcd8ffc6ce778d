// MCAP codecs of point clouds and triangle meshes.
#include <array>
#include <cstring>
#include <map>

#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory
using F = pb::FieldType;

namespace {

enum NumericType : std::int32_t {
  kUint8 = 1,
  kInt8 = 2,
  kUint16 = 3,
  kInt16 = 4,
  kUint32 = 5,
  kInt32 = 6,
  kFloat32 = 7,
  kFloat64 = 8
};

int numericSize(std::int64_t t) {
  switch (t) {
    case kUint8:
    case kInt8:
      return 1;
    case kUint16:
    case kInt16:
      return 2;
    case kUint32:
    case kInt32:
    case kFloat32:
      return 4;
    case kFloat64:
      return 8;
    default:
      return 0;
  }
}

void putPackedField(pb::Writer& w, std::string_view name, std::uint32_t offset, NumericType type) {
  const std::size_t s = w.begin(5);
  w.string(1, name);
  w.fixed32(2, offset);
  w.int32(3, type);
  w.end(s);
}

}  // namespace

Status encode(const PointCloud& v, Timestamp, Encoded& out) {
  out.clear();
  const std::size_t n = v.points.size();
  auto check = [&](std::size_t size, const char* what) -> Status {
    if (size != 0 && size != n)
      return invalidInput(
          "point cloud has {} points but {} {} values; expected one per point or "
          "none",
          n, size, what);
    return Status::ok();
  };
  CDFF_RETURN_IF_ERROR(check(v.normals.size(), "normal"));
  CDFF_RETURN_IF_ERROR(check(v.intensity.size(), "intensity"));
  CDFF_RETURN_IF_ERROR(check(v.ring.size(), "ring"));
  CDFF_RETURN_IF_ERROR(check(v.time_offset_us.size(), "time offset"));
  if (v.stamp < 0) return negativeStamp("point cloud", v.stamp);

  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  putPose(w, 3, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  const bool plain =
      v.normals.empty() && v.intensity.empty() && v.ring.empty() && v.time_offset_us.empty();
  if (plain) {
    // The points as they are in memory: x y z and the (undeclared) homogeneous padding.
    w.fixed32(4, sizeof(Point4f));
    putPackedField(w, "x", 0, kFloat32);
    putPackedField(w, "y", 4, kFloat32);
    putPackedField(w, "z", 8, kFloat32);
    w.lengthPrefix(6, n * sizeof(Point4f));
    out.reference(
        Bytes(reinterpret_cast<const std::uint8_t*>(v.points.data()), n * sizeof(Point4f)));
    return Status::ok();
  }
  std::uint32_t stride = 12;
  const std::uint32_t normal_at = stride;
  if (!v.normals.empty()) stride += 12;
  const std::uint32_t intensity_at = stride;
  if (!v.intensity.empty()) stride += 4;
  const std::uint32_t time_at = stride;
  if (!v.time_offset_us.empty()) stride += 4;
  const std::uint32_t ring_at = stride;
  if (!v.ring.empty()) stride += 2;
  stride = (stride + 3) / 4 * 4;
  w.fixed32(4, stride);
  putPackedField(w, "x", 0, kFloat32);
  putPackedField(w, "y", 4, kFloat32);
  putPackedField(w, "z", 8, kFloat32);
  if (!v.normals.empty()) {
    putPackedField(w, "normal_x", normal_at, kFloat32);
    putPackedField(w, "normal_y", normal_at + 4, kFloat32);
    putPackedField(w, "normal_z", normal_at + 8, kFloat32);
  }
  if (!v.intensity.empty()) putPackedField(w, "intensity", intensity_at, kFloat32);
  if (!v.time_offset_us.empty()) putPackedField(w, "time_offset_us", time_at, kInt32);
  if (!v.ring.empty()) putPackedField(w, "ring", ring_at, kUint16);
  w.lengthPrefix(6, n * stride);
  const std::size_t at = out.bytes.size();
  out.bytes.resize(at + n * stride, 0);
  std::uint8_t* p = out.bytes.data() + at;
  for (std::size_t i = 0; i < n; ++i, p += stride) {
    std::memcpy(p, &v.points[i], 12);
    if (!v.normals.empty()) std::memcpy(p + normal_at, &v.normals[i], 12);
    if (!v.intensity.empty()) std::memcpy(p + intensity_at, &v.intensity[i], 4);
    if (!v.time_offset_us.empty()) std::memcpy(p + time_at, &v.time_offset_us[i], 4);
    if (!v.ring.empty()) std::memcpy(p + ring_at, &v.ring[i], 2);
  }
  return Status::ok();
}

Status encode(const TriangleMesh& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("mesh", v.stamp);
  if (!v.vertex_normals.empty() && v.vertex_normals.size() != v.vertices.size())
    return invalidInput("mesh has {} vertices but {} normals; expected one per vertex or none",
                        v.vertices.size(), v.vertex_normals.size());
  pb::Writer w(out.bytes);
  const std::size_t entity = w.begin(2);
  putTimestamp(w, 1, v.stamp);
  w.string(2, v.frame_id);
  w.string(3, "mesh");
  w.boolean(5, true);
  const std::size_t list = w.begin(12);
  putPose(w, 1, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  for (const Eigen::Vector3f& p : v.vertices) {
    w.lengthPrefix(2, 27);  // three tagged doubles
    w.float64(1, p.x());
    w.float64(2, p.y());
    w.float64(3, p.z());
  }
  {
    const std::size_t c = w.begin(3);
    w.float64(1, 0.75);
    w.float64(2, 0.75);
    w.float64(3, 0.78);
    w.float64(4, 1.0);
    w.end(c);
  }
  w.packed<std::uint32_t>(
      5, std::span<const std::uint32_t>(reinterpret_cast<const std::uint32_t*>(v.triangles.data()),
                                        v.triangles.size() * 3));
  if (!v.vertex_normals.empty())
    w.packed<float>(1000,
                    std::span<const float>(reinterpret_cast<const float*>(v.vertex_normals.data()),
                                           v.vertex_normals.size() * 3));
  w.end(list);
  w.end(entity);
  return Status::ok();
}

namespace {

float readAsFloat(const std::uint8_t* p, std::int64_t type) {
  switch (type) {
    case kUint8:
      return *p;
    case kInt8:
      return static_cast<float>(static_cast<std::int8_t>(*p));
    case kUint16: {
      std::uint16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case kInt16: {
      std::int16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case kUint32: {
      std::uint32_t v;
      std::memcpy(&v, p, 4);
      return static_cast<float>(v);
    }
    case kInt32: {
      std::int32_t v;
      std::memcpy(&v, p, 4);
      return static_cast<float>(v);
    }
    case kFloat32: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case kFloat64: {
      double v;
      std::memcpy(&v, p, 8);
      return static_cast<float>(v);
    }
    default:
      return 0;
  }
}

double readAsDouble(const std::uint8_t* p, std::int64_t type) {
  if (type == kFloat64) {
    double v;
    std::memcpy(&v, p, 8);
    return v;
  }
  if (type == kInt32) {
    std::int32_t v;
    std::memcpy(&v, p, 4);
    return v;
  }
  if (type == kUint32) {
    std::uint32_t v;
    std::memcpy(&v, p, 4);
    return v;
  }
  return readAsFloat(p, type);
}

struct PackedField {
  std::uint32_t offset = 0;
  std::int64_t type = 0;
};

// A foxglove.PointCloud as read: the header, the pose of the points' frame and the packed points
// with the layout of their fields.
struct PackedCloud {
  Timestamp stamp = 0;
  std::string frame_id;
  std::map<std::string, PackedField> fields;
  std::uint32_t stride = 0;
  Bytes points;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

Result<PackedCloud> readPackedCloud(Bytes data) {
  PackedCloud c;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.PointCloud", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r)) inner = readTimestamp(r.bytes(), c.stamp);
        break;
      case 2:
        if (isLen(r)) c.frame_id = r.string();
        break;
      case 3:
        if (isLen(r)) inner = readPose(r.bytes(), c.origin, c.orientation);
        break;
      case 4:
        c.stride = static_cast<std::uint32_t>(r.u64());
        break;
      case 5:
        if (isLen(r)) {
          std::string name;
          PackedField f;
          inner = forFields(r.bytes(), "foxglove.PackedElementField", [&](pb::Reader& fr) {
            if (fr.field() == 1 && isLen(fr)) name = fr.string();
            if (fr.field() == 2) f.offset = static_cast<std::uint32_t>(fr.u64());
            if (fr.field() == 3) f.type = fr.i64();
            return true;
          });
          c.fields[name] = f;
        }
        break;
      case 6:
        if (isLen(r)) c.points = r.bytes();
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  return c;
}

// The layout must be readable before any point is: x, y and z present, every field of a known
// type inside the stride, and whole points only (a field past the stride would read the next
// point, or past the data).
Status checkLayout(const PackedCloud& c) {
  const char* schema = "foxglove.PointCloud";
  for (const char* axis : {"x", "y", "z"})
    if (!c.fields.count(axis))
      return corruptMessage(schema, fmt::format("has no '{}' field; expected x, y and z", axis));
  for (const auto& [name, f] : c.fields) {
    const int size = numericSize(f.type);
    if (size == 0)
      return corruptMessage(schema,
                            fmt::format("field '{}' has unknown numeric type {}", name, f.type));
    if (static_cast<std::uint64_t>(f.offset) + size > c.stride)
      return corruptMessage(schema, fmt::format("field '{}' at offset {} ({} bytes) overruns the "
                                                "point stride {}",
                                                name, f.offset, size, c.stride));
  }
  if (c.points.size() % c.stride != 0)
    return corruptMessage(schema, fmt::format("data holds {} bytes, not a multiple of the point "
                                              "stride {}",
                                              c.points.size(), c.stride));
  return Status::ok();
}

// Points stored exactly as PointCloud holds them (x, y, z, 1 as floats, nothing else, in the
// points' own frame) are shared with the message instead of copied, when `owner` keeps the
// message alive and the data is aligned for Point4f.
bool sharesPoints(const PackedCloud& c, std::size_t n, bool identity_pose,
                  const std::shared_ptr<const void>& owner) {
  const PackedField& fx = c.fields.at("x");
  const PackedField& fy = c.fields.at("y");
  const PackedField& fz = c.fields.at("z");
  const bool plain = c.stride == sizeof(Point4f) && c.fields.size() == 3 && fx.offset == 0 &&
                     fy.offset == 4 && fz.offset == 8 && fx.type == kFloat32 &&
                     fy.type == kFloat32 && fz.type == kFloat32 && identity_pose;
  if (!plain) return false;
  bool padded_with_one = true;
  for (std::size_t i = 0; i < n && padded_with_one; ++i) {
    float pad;
    std::memcpy(&pad, c.points.data() + i * 16 + 12, 4);
    padded_with_one = pad == 1.0f;
  }
  const bool aligned = reinterpret_cast<std::uintptr_t>(c.points.data()) % alignof(Point4f) == 0;
  return owner && aligned && padded_with_one;
}

// The vectors of fields (x, y, z) of every point, rotated into the message's frame, and moved
// by `origin` when given (positions; directions are only rotated).
std::vector<Point4f> readVectors(const PackedCloud& c, std::size_t n,
                                 const std::array<const char*, 3>& names, bool identity_pose,
                                 const Eigen::Matrix3d& rotation, const Eigen::Vector3d* origin) {
  const PackedField& fx = c.fields.at(names[0]);
  const PackedField& fy = c.fields.at(names[1]);
  const PackedField& fz = c.fields.at(names[2]);
  std::vector<Point4f> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* p = c.points.data() + i * c.stride;
    Eigen::Vector3d v(readAsDouble(p + fx.offset, fx.type), readAsDouble(p + fy.offset, fy.type),
                      readAsDouble(p + fz.offset, fz.type));
    if (!identity_pose) {
      if (origin)
        v = rotation * v + *origin;
      else
        v = rotation * v;
    }
    out[i] =
        Point4f(static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
  }
  return out;
}

// One scalar per point from `field`, read with `read` (the raw bytes and the numeric type).
template <typename T, typename Read>
Buffer<T> readScalars(const PackedCloud& c, std::size_t n, const PackedField& field, Read read) {
  std::vector<T> values(n);
  for (std::size_t i = 0; i < n; ++i)
    values[i] = read(c.points.data() + i * c.stride + field.offset, field.type);
  return Buffer<T>::fromVector(std::move(values));
}

}  // namespace

Status decode(Bytes data, const std::shared_ptr<const void>& owner, PointCloud& out) {
  out = PointCloud{};
  Result<PackedCloud> read = readPackedCloud(data);
  if (!read) return read.status();
  const PackedCloud& c = *read;
  out.stamp = c.stamp;
  out.frame_id = c.frame_id;
  CDFF_RETURN_IF_ERROR(checkLayout(c));
  const std::size_t n = c.points.size() / c.stride;
  const bool identity_pose =
      c.origin.isZero() && c.orientation.coeffs() == Eigen::Quaterniond::Identity().coeffs();
  if (sharesPoints(c, n, identity_pose, owner)) {
    out.points = Buffer<Point4f>::view(owner, reinterpret_cast<const Point4f*>(c.points.data()), n);
    return Status::ok();
  }
  const Eigen::Matrix3d rotation = c.orientation.normalized().toRotationMatrix();
  out.points = Buffer<Point4f>::fromVector(
      readVectors(c, n, {"x", "y", "z"}, identity_pose, rotation, &c.origin));
  if (c.fields.count("normal_x") && c.fields.count("normal_y") && c.fields.count("normal_z"))
    out.normals = Buffer<Point4f>::fromVector(
        readVectors(c, n, {"normal_x", "normal_y", "normal_z"}, identity_pose, rotation, nullptr));
  if (auto it = c.fields.find("intensity"); it != c.fields.end())
    out.intensity = readScalars<float>(c, n, it->second, readAsFloat);
  if (auto it = c.fields.find("ring"); it != c.fields.end())
    out.ring = readScalars<std::uint16_t>(c, n, it->second, [](const std::uint8_t* p, auto type) {
      return static_cast<std::uint16_t>(readAsDouble(p, type));
    });
  if (auto it = c.fields.find("time_offset_us"); it != c.fields.end())
    out.time_offset_us =
        readScalars<std::int32_t>(c, n, it->second, [](const std::uint8_t* p, auto type) {
          return static_cast<std::int32_t>(readAsDouble(p, type));
        });
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, TriangleMesh& out) {
  out = TriangleMesh{};
  std::vector<Eigen::Vector3f> vertices, normals;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  bool have_entity = false;
  Status inner;
  auto read_list = [&](Bytes list) -> Status {
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();
    Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
    std::vector<Eigen::Vector3d> points;
    std::vector<std::uint32_t> indices;
    std::vector<float> list_normals;
    Status s;
    CDFF_RETURN_IF_ERROR(forFields(list, "foxglove.TriangleListPrimitive", [&](pb::Reader& r) {
      if (r.field() == 1 && isLen(r)) s = readPose(r.bytes(), origin, orientation);
      if (r.field() == 2 && isLen(r)) {
        Eigen::Vector3d p = Eigen::Vector3d::Zero();
        s = forFields(r.bytes(), "foxglove.Point3", [&](pb::Reader& pr) {
          if (pr.field() >= 1 && pr.field() <= 3) p[pr.field() - 1] = fixed64Double(pr);
          return true;
        });
        points.push_back(p);
      }
      if (r.field() == 5) return appendRepeated(r, indices);
      if (r.field() == 1000) return appendRepeated(r, list_normals);
      return s.isOk();
    }));
    CDFF_RETURN_IF_ERROR(s);
    const auto base = static_cast<std::uint32_t>(vertices.size());
    const Eigen::Matrix3d rotation = orientation.normalized().toRotationMatrix();
    for (const Eigen::Vector3d& p : points)
      vertices.push_back((rotation * p + origin).cast<float>());
    if (list_normals.size() == points.size() * 3) {
      for (std::size_t i = 0; i < points.size(); ++i)
        normals.push_back((rotation * Eigen::Vector3d(list_normals[3 * i], list_normals[3 * i + 1],
                                                      list_normals[3 * i + 2]))
                              .cast<float>());
    }
    if (indices.empty())
      for (std::uint32_t i = 0; i < points.size(); ++i) indices.push_back(i);
    if (indices.size() % 3 != 0)
      return corruptMessage("foxglove.TriangleListPrimitive",
                            fmt::format("{} indices, not a multiple of 3", indices.size()));
    for (std::size_t i = 0; i < indices.size(); i += 3) {
      for (int k = 0; k < 3; ++k)
        if (indices[i + k] >= points.size())
          return corruptMessage(
              "foxglove.TriangleListPrimitive",
              fmt::format("index {} is out of range ({} points)", indices[i + k], points.size()));
      triangles.push_back({base + indices[i], base + indices[i + 1], base + indices[i + 2]});
    }
    return Status::ok();
  };
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.SceneUpdate", [&](pb::Reader& r) {
    if (r.field() != 2 || !isLen(r) || have_entity) return true;
    have_entity = true;  // the first entity is the mesh
    inner = forFields(r.bytes(), "foxglove.SceneEntity", [&](pb::Reader& er) {
      Status s;
      if (er.field() == 1 && isLen(er)) s = readTimestamp(er.bytes(), out.stamp);
      if (er.field() == 2 && isLen(er)) out.frame_id = er.string();
      if (er.field() == 12 && isLen(er)) s = read_list(er.bytes());
      if (!s.isOk()) inner = s;
      return s.isOk();
    });
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  if (!normals.empty() && normals.size() != vertices.size()) normals.clear();
  out.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  out.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(normals));
  out.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
  return Status::ok();
}

}  // namespace cdff::codec
