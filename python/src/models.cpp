// Polygon models (ViSP .cao primitives) and what the model-based edge trackers pass between
// their steps: the contours seen from a pose and the points sampled along them.

#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "cdff/types/contours.hpp"
#include "cdff/types/polygon_model.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

using RowsX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

void bindPolygonModel(py::module_& m) {
  py::class_<PolygonModel, std::shared_ptr<PolygonModel>> model(
      m, "PolygonModel",
      "A polygonal model (m, model frame): points, faces counter-clockwise from outside, lines, "
      "cylinders and circles, as in ViSP's .cao format.");
  py::class_<PolygonModel::Face>(model, "Face")
      .def(py::init<>())
      .def_readwrite("points", &PolygonModel::Face::points)
      .def_readwrite("name", &PolygonModel::Face::name);
  py::class_<PolygonModel::Line>(model, "Line")
      .def(py::init<>())
      .def_readwrite("a", &PolygonModel::Line::a)
      .def_readwrite("b", &PolygonModel::Line::b)
      .def_readwrite("name", &PolygonModel::Line::name);
  py::class_<PolygonModel::Cylinder>(model, "Cylinder")
      .def(py::init<>())
      .def_readwrite("a", &PolygonModel::Cylinder::a)
      .def_readwrite("b", &PolygonModel::Cylinder::b)
      .def_readwrite("radius", &PolygonModel::Cylinder::radius)
      .def_readwrite("name", &PolygonModel::Cylinder::name);
  py::class_<PolygonModel::Circle>(model, "Circle")
      .def(py::init<>())
      .def_readwrite("centre", &PolygonModel::Circle::centre)
      .def_readwrite("first", &PolygonModel::Circle::first)
      .def_readwrite("second", &PolygonModel::Circle::second)
      .def_readwrite("radius", &PolygonModel::Circle::radius)
      .def_readwrite("name", &PolygonModel::Circle::name);
  model.def(py::init<>())
      .def_static(
          "load_cao", [](const std::string& path) { return take(loadCao(path)); }, py::arg("path"),
          "Reads a ViSP .cao file.")
      .def_static(
          "parse_cao",
          [](const std::string& text, const std::string& source) {
            return take(parseCao(text, source));
          },
          py::arg("text"), py::arg("source") = "<string>")
      .def("to_cao", &toCao, "The model as .cao text.")
      .def_readwrite("frame_id", &PolygonModel::frame_id)
      .def_property(
          "points",
          [](const PolygonModel& p) {
            RowsX3d out(static_cast<Eigen::Index>(p.points.size()), 3);
            for (std::size_t i = 0; i < p.points.size(); ++i) out.row(i) = p.points[i];
            return out;
          },
          [](PolygonModel& p, const RowsX3d& rows) {
            p.points.assign(rows.rows(), Eigen::Vector3d::Zero());
            for (Eigen::Index i = 0; i < rows.rows(); ++i) p.points[i] = rows.row(i);
          },
          "(N, 3) points in m (copied).")
      .def_readwrite("faces", &PolygonModel::faces)
      .def_readwrite("lines", &PolygonModel::lines)
      .def_readwrite("cylinders", &PolygonModel::cylinders)
      .def_readwrite("circles", &PolygonModel::circles)
      .def("validate", [](const PolygonModel& p) { check(p.validate("PolygonModel")); });
  addClassConverter<PolygonModel>("cdff.PolygonModel");
}

void bindContours(py::module_& m) {
  py::enum_<ContourKind>(m, "ContourKind")
      .value("CREASE", ContourKind::kCrease)
      .value("SILHOUETTE", ContourKind::kSilhouette)
      .value("BOUNDARY", ContourKind::kBoundary)
      .value("LINE", ContourKind::kLine);
  py::class_<ContourSegment>(m, "ContourSegment")
      .def(py::init<>())
      .def_readwrite("a", &ContourSegment::a)
      .def_readwrite("b", &ContourSegment::b)
      .def_readwrite("edge", &ContourSegment::edge)
      .def_readwrite("kind", &ContourSegment::kind);
  py::class_<VisibleFace>(m, "VisibleFace")
      .def(py::init<>())
      .def_readwrite("face", &VisibleFace::face)
      .def_readwrite("normal", &VisibleFace::normal)
      .def_readwrite("offset", &VisibleFace::offset)
      .def_readwrite("outline", &VisibleFace::outline);
  py::class_<ModelContours, std::shared_ptr<ModelContours>>(
      m, "ModelContours", "The contours of a polygon model one camera sees from a pose.")
      .def(py::init<>())
      .def_readwrite("stamp", &ModelContours::stamp)
      .def_readwrite("camera", &ModelContours::camera)
      .def_readwrite("camera_T_model", &ModelContours::camera_T_model)
      .def_readwrite("camera_T_reference", &ModelContours::camera_T_reference)
      .def_readwrite("segments", &ModelContours::segments, "A list (copied).")
      .def_readwrite("faces", &ModelContours::faces, "A list (copied).")
      .def("validate", [](const ModelContours& c) { check(c.validate("ModelContours")); });
  addClassConverter<ModelContours>("cdff.ModelContours");
}

void bindSamples(py::module_& m) {
  py::class_<EdgeCandidate>(m, "EdgeCandidate")
      .def(py::init<>())
      .def_readwrite("offset", &EdgeCandidate::offset, "px along the contour normal")
      .def_readwrite("strength", &EdgeCandidate::strength);
  py::class_<ContourSample>(m, "ContourSample")
      .def(py::init<>())
      .def_readwrite("point", &ContourSample::point)
      .def_readwrite("pixel", &ContourSample::pixel)
      .def_readwrite("normal", &ContourSample::normal)
      .def_readwrite("segment", &ContourSample::segment)
      .def_readwrite("first_candidate", &ContourSample::first_candidate)
      .def_readwrite("candidate_count", &ContourSample::candidate_count);
  py::class_<ContourSamples, std::shared_ptr<ContourSamples>>(
      m, "ContourSamples", "Points sampled along contours, with their candidate image edges.")
      .def(py::init<>())
      .def_property(
          "contours",
          [](const ContourSamples& s) -> std::shared_ptr<ModelContours> {
            return s.contours ? std::make_shared<ModelContours>(*s.contours) : nullptr;
          },
          [](ContourSamples& s, const ModelContours& c) {
            s.contours = std::make_shared<const ModelContours>(c);
          },
          "The contours sampled (copied).")
      .def_readwrite("samples", &ContourSamples::samples, "A list (copied).")
      .def_readwrite("candidates", &ContourSamples::candidates, "A list (copied).")
      .def_readwrite("matched", &ContourSamples::matched)
      .def("matched_count", &ContourSamples::matchedCount)
      .def("validate", [](const ContourSamples& s) { check(s.validate("ContourSamples")); });
  addClassConverter<ContourSamples>("cdff.ContourSamples");
}

}  // namespace

void bindModels(py::module_& m) {
  bindPolygonModel(m);
  bindContours(m);
  bindSamples(m);
}

}  // namespace cdff::python
