// Features with descriptors, matches, correspondences and detections. Descriptors are a shared
// (rows, cols) uint8 or float32 array (no copy either way when C-contiguous); keypoints and
// matches are small structs, listed, with their positions also as (N, 2) / (N, 3) arrays.

#include <optional>

#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "cdff/types/bearing.hpp"
#include "cdff/types/detection.hpp"
#include "cdff/types/features.hpp"
#include "cdff/types/image_region.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

using RowsX2d = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;
using RowsX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

template <typename Rows, typename Vec>
Rows rowsOf(const std::vector<Vec>& v) {
  Rows out(static_cast<Eigen::Index>(v.size()), Rows::ColsAtCompileTime);
  for (std::size_t i = 0; i < v.size(); ++i) out.row(i) = v[i].transpose();
  return out;
}

template <typename Vec, typename Rows>
std::vector<Vec> vectorsOf(const Rows& rows) {
  std::vector<Vec> out(static_cast<std::size_t>(rows.rows()));
  for (Eigen::Index i = 0; i < rows.rows(); ++i) out[i] = rows.row(i).transpose();
  return out;
}

DescriptorMatrix descriptorsFromArray(const py::array& a, DescriptorMatrix::Distance distance,
                                      std::optional<bool> copy) {
  DescriptorMatrix d;
  d.distance = distance;
  if (a.dtype().is(py::dtype::of<std::uint8_t>()))
    d.element = DescriptorMatrix::Element::kUint8;
  else if (a.dtype().is(py::dtype::of<float>()))
    d.element = DescriptorMatrix::Element::kFloat32;
  else
    throw py::type_error(
        fmt::format("DescriptorMatrix: a {}; expected uint8 (binary) or float32 (real) descriptors",
                    describeArray(a)));
  if (a.ndim() != 2)
    throw py::value_error(
        fmt::format("DescriptorMatrix: a {}; expected shape (rows, cols)", describeArray(a)));
  d.rows = static_cast<int>(a.shape(0));
  d.cols = static_cast<int>(a.shape(1));
  const std::size_t bytes = static_cast<std::size_t>(a.nbytes());
  if (copy != true && (a.flags() & py::array::c_style)) {
    d.data = viewOf<std::uint8_t>(a, a.data(), bytes);
  } else {
    if (copy == false)
      throw py::value_error(
          fmt::format("DescriptorMatrix: the {} is not C-contiguous and cannot "
                      "be shared; pass copy=True",
                      describeArray(a)));
    if (!copy.has_value())
      warnCopy(fmt::format("DescriptorMatrix: the {} was copied: it is not C-contiguous",
                           describeArray(a)));
    py::array packed = py::module_::import("numpy").attr("ascontiguousarray")(a);
    d.data = Buffer<std::uint8_t>::copyOf({static_cast<const std::uint8_t*>(packed.data()), bytes});
  }
  check(d.validate("DescriptorMatrix"));
  return d;
}

py::array descriptorsArray(const DescriptorMatrix& d) {
  const auto rows = static_cast<py::ssize_t>(d.rows), cols = static_cast<py::ssize_t>(d.cols);
  if (d.element == DescriptorMatrix::Element::kUint8)
    return readOnlyView(d.data.owner(), d.data.data(), {rows, cols}, {cols, 1});
  return readOnlyView(d.data.owner(), reinterpret_cast<const float*>(d.data.data()), {rows, cols},
                      {cols * 4, 4});
}

void bindDescriptors(py::module_& m) {
  py::class_<DescriptorMatrix> d(m, "DescriptorMatrix",
                                 "One descriptor per row: uint8 (binary) or float32 (real).");
  py::enum_<DescriptorMatrix::Distance>(d, "Distance")
      .value("HAMMING", DescriptorMatrix::Distance::kHamming)
      .value("HAMMING2", DescriptorMatrix::Distance::kHamming2)
      .value("L2", DescriptorMatrix::Distance::kL2);
  d.def(py::init<>())
      .def(py::init(&descriptorsFromArray), py::arg("array"),
           py::arg("distance") = DescriptorMatrix::Distance::kHamming, py::arg("copy") = py::none())
      .def_readwrite("distance", &DescriptorMatrix::distance)
      .def_readonly("rows", &DescriptorMatrix::rows)
      .def_readonly("cols", &DescriptorMatrix::cols)
      .def_property_readonly("array", &descriptorsArray, "A read-only view (no copy).");
}

void bindFeatureSets(py::module_& m) {
  py::class_<Keypoint2D>(m, "Keypoint2D")
      .def(py::init<>())
      .def_readwrite("position", &Keypoint2D::position, "pixels")
      .def_readwrite("size", &Keypoint2D::size)
      .def_readwrite("angle", &Keypoint2D::angle, "degrees, -1 when not applicable")
      .def_readwrite("response", &Keypoint2D::response)
      .def_readwrite("octave", &Keypoint2D::octave);
  py::class_<Features2D, std::shared_ptr<Features2D>>(m, "Features2D",
                                                      "Image keypoints with descriptors.")
      .def(py::init<>())
      .def_readwrite("stamp", &Features2D::stamp)
      .def_readwrite("frame_id", &Features2D::frame_id)
      .def_readwrite("keypoints", &Features2D::keypoints, "A list (copied).")
      .def_readwrite("descriptors", &Features2D::descriptors)
      .def_property_readonly(
          "positions",
          [](const Features2D& f) {
            std::vector<Eigen::Vector2d> p;
            for (const Keypoint2D& k : f.keypoints) p.push_back(k.position.cast<double>());
            return rowsOf<RowsX2d>(p);
          },
          "(N, 2) pixel positions (copied).")
      .def("__len__", &Features2D::size)
      .def("validate", [](const Features2D& f) { check(f.validate()); });
  addClassConverter<Features2D>("cdff.Features2D");
  py::class_<Keypoint3D>(m, "Keypoint3D")
      .def(py::init<>())
      .def_readwrite("position", &Keypoint3D::position, "m")
      .def_readwrite("normal", &Keypoint3D::normal, "unit, or zero when unknown");
  py::class_<Features3D, std::shared_ptr<Features3D>>(m, "Features3D",
                                                      "3D keypoints with descriptors.")
      .def(py::init<>())
      .def_readwrite("stamp", &Features3D::stamp)
      .def_readwrite("frame_id", &Features3D::frame_id)
      .def_readwrite("keypoints", &Features3D::keypoints, "A list (copied).")
      .def_readwrite("descriptors", &Features3D::descriptors)
      .def_property_readonly(
          "positions",
          [](const Features3D& f) {
            std::vector<Eigen::Vector3d> p;
            for (const Keypoint3D& k : f.keypoints) p.push_back(k.position.cast<double>());
            return rowsOf<RowsX3d>(p);
          },
          "(N, 3) positions in m (copied).")
      .def("__len__", &Features3D::size)
      .def("validate", [](const Features3D& f) { check(f.validate()); });
  addClassConverter<Features3D>("cdff.Features3D");
}

/// A correspondences class whose two point lists are (N, k) arrays.
template <typename T, typename RowsA, typename VecA, typename RowsB, typename VecB>
void bindPairs(py::module_& m, const char* name, const char* doc, std::vector<VecA> T::*a,
               const char* a_name, std::vector<VecB> T::*b, const char* b_name) {
  py::class_<T, std::shared_ptr<T>>(m, name, doc)
      .def(py::init<>())
      .def(py::init([a, b](const RowsA& ra, const RowsB& rb) {
             T t;
             t.*a = vectorsOf<VecA>(ra);
             t.*b = vectorsOf<VecB>(rb);
             check(t.validate(TypeTraits<T>::name.data()));
             return t;
           }),
           py::arg(a_name), py::arg(b_name))
      .def_property(
          a_name, [a](const T& t) { return rowsOf<RowsA>(t.*a); },
          [a](T& t, const RowsA& r) { t.*a = vectorsOf<VecA>(r); })
      .def_property(
          b_name, [b](const T& t) { return rowsOf<RowsB>(t.*b); },
          [b](T& t, const RowsB& r) { t.*b = vectorsOf<VecB>(r); })
      .def("__len__", &T::size)
      .def("validate", [](const T& t) { check(t.validate(TypeTraits<T>::name.data())); });
  addClassConverter<T>(std::string("cdff.") + name);
}

void bindMatches(py::module_& m) {
  py::class_<Match>(m, "Match", "Feature `query` of the first set paired with `train`.")
      .def(py::init<>())
      .def(py::init([](int q, int t, float d) {
             return Match{q, t, d};
           }),
           py::arg("query"), py::arg("train"), py::arg("distance") = 0.0f)
      .def_readwrite("query", &Match::query)
      .def_readwrite("train", &Match::train)
      .def_readwrite("distance", &Match::distance);
  py::class_<Matches, std::shared_ptr<Matches>>(m, "Matches", "Descriptor matches.")
      .def(py::init<>())
      .def_readwrite("matches", &Matches::matches, "A list (copied).")
      .def("__len__", &Matches::size);
  addClassConverter<Matches>("cdff.Matches");
  bindPairs<Correspondences2D, RowsX2d, Eigen::Vector2d, RowsX2d, Eigen::Vector2d>(
      m, "Correspondences2D", "Matched pixels: (N, 2) first and second.", &Correspondences2D::first,
      "first", &Correspondences2D::second, "second");
  bindPairs<Correspondences3D, RowsX3d, Eigen::Vector3d, RowsX3d, Eigen::Vector3d>(
      m, "Correspondences3D", "Matched points (m): (N, 3) first and second.",
      &Correspondences3D::first, "first", &Correspondences3D::second, "second");
  bindPairs<Correspondences2D3D, RowsX3d, Eigen::Vector3d, RowsX2d, Eigen::Vector2d>(
      m, "Correspondences2D3D", "Model points (N, 3, m) and the pixels (N, 2) they were seen at.",
      &Correspondences2D3D::points, "points", &Correspondences2D3D::pixels, "pixels");
}

void bindDetections(py::module_& m) {
  py::class_<Detection>(m, "Detection", "One detection of a known object: pose and match quality.")
      .def(py::init<>())
      .def_readwrite("pose", &Detection::pose, "sensor_T_object")
      .def_readwrite("similarity", &Detection::similarity, "0..1")
      .def_readwrite("depth_agreement", &Detection::depth_agreement, "0..1, NaN when unchecked")
      .def_readwrite("template_id", &Detection::template_id)
      .def_readwrite("x", &Detection::x)
      .def_readwrite("y", &Detection::y)
      .def_readwrite("width", &Detection::width)
      .def_readwrite("height", &Detection::height);
  py::class_<Detections, std::shared_ptr<Detections>>(m, "Detections", "Detections, best first.")
      .def(py::init<>())
      .def_readwrite("stamp", &Detections::stamp)
      .def_readwrite("frame_id", &Detections::frame_id)
      .def_readwrite("detections", &Detections::detections, "A list (copied).")
      .def("__len__", [](const Detections& d) { return d.detections.size(); })
      .def("validate", [](const Detections& d) { check(d.validate()); });
  addClassConverter<Detections>("cdff.Detections");
}

/// Far-range tracking's region of a template in an image, and the bearing it gives.
void bindFarRange(py::module_& m) {
  py::class_<ImageRegion, std::shared_ptr<ImageRegion>>(
      m, "ImageRegion", "Where a template lies in an image: template pixels -> image pixels.")
      .def(py::init<>())
      .def_static("box", &ImageRegion::box, py::arg("x"), py::arg("y"), py::arg("width"),
                  py::arg("height"), "A designation of the box [x, x + width) x [y, y + height).")
      .def_readwrite("stamp", &ImageRegion::stamp)
      .def_readwrite("frame_id", &ImageRegion::frame_id)
      .def_readwrite("homography", &ImageRegion::homography, "3x3, template -> image pixels")
      .def_readwrite("width", &ImageRegion::width)
      .def_readwrite("height", &ImageRegion::height)
      .def_readwrite("score", &ImageRegion::score, "ZNCC, NaN for a designation or a prediction")
      .def_readwrite("covariance", &ImageRegion::covariance, "2x2, px^2, of the centre")
      .def_readwrite("source", &ImageRegion::source, "user, automatic, prediction or match")
      .def("centre", &ImageRegion::centre, "The image position of the template's centre.")
      .def("scale", &ImageRegion::scale)
      .def("validate", [](const ImageRegion& r) { check(r.validate()); });
  addClassConverter<ImageRegion>("cdff.ImageRegion");
  py::class_<Bearing, std::shared_ptr<Bearing>>(
      m, "Bearing", "The direction to the target (servicer frame), with range where measured.")
      .def(py::init<>())
      .def_readwrite("stamp", &Bearing::stamp)
      .def_readwrite("frame_id", &Bearing::frame_id)
      .def_readwrite("direction", &Bearing::direction, "unit vector")
      .def_readwrite("covariance", &Bearing::covariance, "3x3, rad^2")
      .def_readwrite("range", &Bearing::range, "m, NaN when unknown")
      .def_readwrite("range_variance", &Bearing::range_variance)
      .def_readwrite("range_rate", &Bearing::range_rate, "m/s, NaN when unknown")
      .def_readwrite("range_rate_variance", &Bearing::range_rate_variance)
      .def_readwrite("designation", &Bearing::designation, "user or automatic")
      .def("azimuth", &Bearing::azimuth, "rad, atan2(y, x)")
      .def("elevation", &Bearing::elevation, "rad, atan2(z, hypot(x, y))")
      .def("validate", [](const Bearing& b) { check(b.validate()); });
  addClassConverter<Bearing>("cdff.Bearing");
}

}  // namespace

void bindFeatures(py::module_& m) {
  bindDescriptors(m);
  bindFeatureSets(m);
  bindMatches(m);
  bindDetections(m);
  bindFarRange(m);
}

}  // namespace cdff::python
