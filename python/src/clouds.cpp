// Point clouds, triangle meshes and LIDAR descriptions. A cloud's points are 4 floats (x, y, z,
// padding), so an (N, 4) float32 C-contiguous array is shared without a copy and `points` is an
// (N, 3) view of the same memory; an (N, 3) array needs a copy into that layout, and says so.

#include <array>
#include <cstring>
#include <optional>

#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "cdff/types/lidar_info.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/point_cloud.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

bool isNumeric(const py::array& a) {
  const char kind = a.dtype().kind();
  return kind == 'f' || kind == 'i' || kind == 'u';
}

bool aligned(const void* data, std::size_t alignment) {
  return reinterpret_cast<std::uintptr_t>(data) % alignment == 0;
}

/// Whether `a` is a C-contiguous array of `count` rows of `T` elements (`columns` per row, 0 for
/// a 1-D array) that a Buffer of `Element` can view where it lies.
template <typename T>
bool viewable(const py::array& a, py::ssize_t columns, std::size_t alignment) {
  if (!a.dtype().is(py::dtype::of<T>())) return false;
  if (!(a.flags() & py::array::c_style)) return false;
  if (columns == 0 ? a.ndim() != 1 : (a.ndim() != 2 || a.shape(1) != columns)) return false;
  return aligned(a.data(), alignment);
}

/// The element count an array of `columns` columns (0: 1-D) holds, or a ValueError.
py::ssize_t rowsOf(const py::array& a, std::initializer_list<py::ssize_t> columns,
                   const std::string& what) {
  if (!isNumeric(a))
    throw py::type_error(
        fmt::format("{}: a {}; expected a real or integer array", what, describeArray(a)));
  for (py::ssize_t c : columns)
    if ((c == 0 && a.ndim() == 1) || (c > 0 && a.ndim() == 2 && a.shape(1) == c)) return a.shape(0);
  std::string expected;
  for (py::ssize_t c : columns)
    expected += (expected.empty() ? "" : " or ") +
                (c == 0 ? std::string("(N,)") : fmt::format("(N, {})", c));
  throw py::value_error(
      fmt::format("{}: a {}; expected shape {}", what, describeArray(a), expected));
}

void refuseOrWarn(std::optional<bool> copy, const std::string& what, const py::array& a,
                  const char* shared_layout) {
  if (copy == false)
    throw py::value_error(
        fmt::format("{}: the {} cannot be shared without a copy; expected {}, "
                    "or pass copy=True",
                    what, describeArray(a), shared_layout));
  if (!copy.has_value())
    warnCopy(fmt::format("{}: the {} was copied; {} is shared without a copy", what,
                         describeArray(a), shared_layout));
}

/// Points or normals: shared when (N, 4) float32, else copied from (N, 3) or (N, 4).
Buffer<Point4f> pointsFromArray(const py::array& a, std::optional<bool> copy,
                                const std::string& what, float pad) {
  const py::ssize_t n = rowsOf(a, {3, 4}, what);
  if (copy != true && viewable<float>(a, 4, alignof(Point4f)))
    return viewOf<Point4f>(a, a.data(), static_cast<std::size_t>(n));
  refuseOrWarn(copy, what, a, "an (N, 4) float32 C-contiguous array");
  auto f = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
  std::vector<Point4f> points(static_cast<std::size_t>(n));
  const py::ssize_t cols = a.shape(1);
  for (py::ssize_t i = 0; i < n; ++i) {
    const float* row = f.data() + i * cols;
    points[i] = Point4f(row[0], row[1], row[2]);
    points[i].pad = pad;
  }
  return Buffer<Point4f>::fromVector(std::move(points));
}

/// A per-point field: shared when 1-D C-contiguous of T, else copied (converted) to T.
template <typename T>
Buffer<T> fieldFromArray(const py::array& a, std::optional<bool> copy, const std::string& what) {
  const py::ssize_t n = rowsOf(a, {0}, what);
  if (copy != true && viewable<T>(a, 0, alignof(T)))
    return viewOf<T>(a, a.data(), static_cast<std::size_t>(n));
  refuseOrWarn(
      copy, what, a,
      fmt::format("a 1-D C-contiguous {} array", py::str(py::dtype::of<T>()).cast<std::string>())
          .c_str());
  auto typed = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
  return Buffer<T>::copyOf({typed.data(), static_cast<std::size_t>(n)});
}

/// Rows of 3 elements (vertices, normals, triangles): shared when (N, 3) C-contiguous of T.
template <typename Row, typename T>
Buffer<Row> rowsFromArray(const py::array& a, std::optional<bool> copy, const std::string& what) {
  static_assert(sizeof(Row) == 3 * sizeof(T));
  const py::ssize_t n = rowsOf(a, {3}, what);
  if (copy != true && viewable<T>(a, 3, alignof(Row)))
    return viewOf<Row>(a, a.data(), static_cast<std::size_t>(n));
  refuseOrWarn(copy, what, a,
               fmt::format("an (N, 3) C-contiguous {} array",
                           py::str(py::dtype::of<T>()).cast<std::string>())
                   .c_str());
  auto typed = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
  std::vector<Row> rows(static_cast<std::size_t>(n));
  std::memcpy(rows.data(), typed.data(), rows.size() * sizeof(Row));
  return Buffer<Row>::fromVector(std::move(rows));
}

py::array pointsView(const Buffer<Point4f>& b, py::ssize_t columns) {
  return readOnlyView(b.owner(), reinterpret_cast<const float*>(b.data()),
                      {static_cast<py::ssize_t>(b.size()), columns}, {16, 4});
}

template <typename T>
py::array fieldView(const Buffer<T>& b) {
  return readOnlyView(b.owner(), b.data(), {static_cast<py::ssize_t>(b.size())},
                      {static_cast<py::ssize_t>(sizeof(T))});
}

template <typename T, typename Row>
py::array rowsView(const Buffer<Row>& b) {
  return readOnlyView(b.owner(), reinterpret_cast<const T*>(b.data()),
                      {static_cast<py::ssize_t>(b.size()), 3},
                      {static_cast<py::ssize_t>(sizeof(Row)), sizeof(T)});
}

PointCloud cloudFromArrays(const py::array& points, const std::optional<py::array>& normals,
                           const std::optional<py::array>& intensity,
                           const std::optional<py::array>& ring,
                           const std::optional<py::array>& time_offset_us, Timestamp stamp,
                           std::string frame_id, std::optional<bool> copy) {
  PointCloud cloud;
  cloud.stamp = stamp;
  cloud.frame_id = std::move(frame_id);
  cloud.points = pointsFromArray(points, copy, "PointCloud points", 1.0f);
  if (normals) cloud.normals = pointsFromArray(*normals, copy, "PointCloud normals", 0.0f);
  if (intensity) cloud.intensity = fieldFromArray<float>(*intensity, copy, "PointCloud intensity");
  if (ring) cloud.ring = fieldFromArray<std::uint16_t>(*ring, copy, "PointCloud ring");
  if (time_offset_us)
    cloud.time_offset_us =
        fieldFromArray<std::int32_t>(*time_offset_us, copy, "PointCloud time_offset_us");
  check(cloud.validate("PointCloud", false));
  return cloud;
}

void bindPointCloud(py::module_& m) {
  py::class_<PointCloud, std::shared_ptr<PointCloud>>(
      m, "PointCloud",
      "Points (m) with optional per-point normals, intensity, ring and time offset (µs).\n\n"
      "PointCloud(points, normals=None, intensity=None, ring=None, time_offset_us=None, stamp=0, "
      "frame_id='', copy=None): an (N, 4) float32 C-contiguous array (x, y, z, padding) is "
      "shared without a copy, as are 1-D float32 intensity, uint16 ring and int32 time offsets; "
      "(N, 3) points and other dtypes are copied with a cdff.CopyWarning (copy=True: silently; "
      "copy=False: a ValueError). Shared arrays must not change while CDFF holds the cloud. "
      "`points` is an (N, 3) read-only view, `points4` the (N, 4) one.")
      .def(py::init<>())
      .def(py::init(&cloudFromArrays), py::arg("points"), py::arg("normals") = py::none(),
           py::arg("intensity") = py::none(), py::arg("ring") = py::none(),
           py::arg("time_offset_us") = py::none(), py::arg("stamp") = 0, py::arg("frame_id") = "",
           py::arg("copy") = py::none())
      .def_readwrite("stamp", &PointCloud::stamp)
      .def_readwrite("frame_id", &PointCloud::frame_id)
      .def_property_readonly("points", [](const PointCloud& c) { return pointsView(c.points, 3); })
      .def_property_readonly("points4", [](const PointCloud& c) { return pointsView(c.points, 4); })
      .def_property_readonly("normals",
                             [](const PointCloud& c) { return pointsView(c.normals, 3); })
      .def_property_readonly("intensity",
                             [](const PointCloud& c) { return fieldView(c.intensity); })
      .def_property_readonly("ring", [](const PointCloud& c) { return fieldView(c.ring); })
      .def_property_readonly("time_offset_us",
                             [](const PointCloud& c) { return fieldView(c.time_offset_us); })
      .def("__len__", &PointCloud::size)
      .def("validate", [](const PointCloud& c) { check(c.validate("PointCloud")); })
      .def("__repr__", [](const PointCloud& c) {
        return fmt::format("<cdff.PointCloud {} points{} stamp={} frame_id='{}'>", c.size(),
                           c.hasNormals() ? " with normals" : "", c.stamp, c.frame_id);
      });
  addClassConverter<PointCloud>("cdff.PointCloud");
}

TriangleMesh meshFromArrays(const py::array& vertices, const py::array& triangles,
                            const std::optional<py::array>& vertex_normals, Timestamp stamp,
                            std::string frame_id, std::optional<bool> copy) {
  TriangleMesh mesh;
  mesh.stamp = stamp;
  mesh.frame_id = std::move(frame_id);
  mesh.vertices = rowsFromArray<Eigen::Vector3f, float>(vertices, copy, "TriangleMesh vertices");
  mesh.triangles = rowsFromArray<std::array<std::uint32_t, 3>, std::uint32_t>(
      triangles, copy, "TriangleMesh triangles");
  if (vertex_normals)
    mesh.vertex_normals =
        rowsFromArray<Eigen::Vector3f, float>(*vertex_normals, copy, "TriangleMesh vertex_normals");
  check(mesh.validate("TriangleMesh"));
  return mesh;
}

void bindMesh(py::module_& m) {
  py::class_<TriangleMesh, std::shared_ptr<TriangleMesh>>(
      m, "TriangleMesh",
      "A triangle mesh (m), triangles counter-clockwise seen from outside.\n\n"
      "TriangleMesh(vertices, triangles, vertex_normals=None, stamp=0, frame_id='', copy=None): "
      "(N, 3) float32 vertices and (M, 3) uint32 triangles, C-contiguous, are shared without a "
      "copy; other dtypes are copied with a cdff.CopyWarning.")
      .def(py::init<>())
      .def(py::init(&meshFromArrays), py::arg("vertices"), py::arg("triangles"),
           py::arg("vertex_normals") = py::none(), py::arg("stamp") = 0, py::arg("frame_id") = "",
           py::arg("copy") = py::none())
      .def_readwrite("stamp", &TriangleMesh::stamp)
      .def_readwrite("frame_id", &TriangleMesh::frame_id)
      .def_property_readonly("vertices",
                             [](const TriangleMesh& t) { return rowsView<float>(t.vertices); })
      .def_property_readonly(
          "vertex_normals", [](const TriangleMesh& t) { return rowsView<float>(t.vertex_normals); })
      .def_property_readonly(
          "triangles", [](const TriangleMesh& t) { return rowsView<std::uint32_t>(t.triangles); })
      .def("surface_area", &TriangleMesh::surfaceArea, "Total area of the triangles, m².")
      .def(
          "sample_surface",
          [](const TriangleMesh& t, std::size_t count, std::uint64_t seed) {
            return take(sampleSurface(t, count, seed));
          },
          py::arg("count"), py::arg("seed") = 0,
          "`count` points uniform by area on the surface, with unit normals.")
      .def("validate", [](const TriangleMesh& t) { check(t.validate("TriangleMesh")); });
  addClassConverter<TriangleMesh>("cdff.TriangleMesh");
}

void bindLidarInfo(py::module_& m) {
  py::class_<LidarInfo, std::shared_ptr<LidarInfo>>(
      m, "LidarInfo", "A spinning multi-beam LIDAR's geometry and noise.")
      .def(py::init<>())
      .def_readwrite("stamp", &LidarInfo::stamp)
      .def_readwrite("frame_id", &LidarInfo::frame_id)
      .def_readwrite("elevations", &LidarInfo::elevations, "rad, one per laser")
      .def_readwrite("rotation_rate", &LidarInfo::rotation_rate, "Hz")
      .def_readwrite("min_range", &LidarInfo::min_range, "m")
      .def_readwrite("max_range", &LidarInfo::max_range, "m")
      .def_readwrite("range_noise", &LidarInfo::range_noise, "m, 1 sigma")
      .def("validate", [](const LidarInfo& l) { check(l.validate()); });
  addClassConverter<LidarInfo>("cdff.LidarInfo");
}

}  // namespace

void bindClouds(py::module_& m) {
  bindPointCloud(m);
  bindMesh(m);
  bindLidarInfo(m);
}

}  // namespace cdff::python
