// Images, depth maps, stereo pairs, compressed images and camera models. Pixels cross between
// NumPy and CDFF without a copy whenever the array's layout is one an Image can describe (rows
// of packed pixels, any row stride); otherwise they are copied, and the copy says so.

#include <optional>

#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "cdff/types/image.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

/// The pixel format an array's dtype and shape describe, or none.
std::optional<PixelFormat> formatOf(const py::array& a) {
  const bool two_d = a.ndim() == 2;
  if (a.dtype().is(py::dtype::of<std::uint8_t>())) {
    if (two_d) return PixelFormat::kGray8;
    if (a.ndim() == 3 && a.shape(2) == 3) return PixelFormat::kBgr8;
  }
  if (two_d && a.dtype().is(py::dtype::of<std::uint16_t>())) return PixelFormat::kGray16;
  if (two_d && a.dtype().is(py::dtype::of<float>())) return PixelFormat::kFloat32;
  return std::nullopt;
}

/// Whether an Image can view the array: packed pixels in rows, a non-negative row stride that
/// holds a row, aligned elements.
bool shareable(const py::array& a, PixelFormat format) {
  const py::ssize_t bpp = bytesPerPixel(format);
  const py::ssize_t element = a.itemsize();
  if (!(a.flags() & py::detail::npy_api::NPY_ARRAY_ALIGNED_)) return false;
  if (a.strides(1) != bpp) return false;
  if (a.ndim() == 3 && a.strides(2) != element) return false;
  return a.shape(0) <= 1 || (a.strides(0) >= a.shape(1) * bpp && a.strides(0) % element == 0);
}

Image imageFromArray(const py::array& array, std::optional<bool> copy, const char* what) {
  const std::optional<PixelFormat> format = formatOf(array);
  if (!format)
    throw py::type_error(fmt::format(
        "{}: a {}; expected uint8 (H, W) grey, uint8 (H, W, 3) BGR, uint16 (H, W) or float32 "
        "(H, W)",
        what, describeArray(array)));
  Image image;
  image.format = *format;
  image.height = static_cast<int>(array.shape(0));
  image.width = static_cast<int>(array.shape(1));
  const std::size_t row_bytes = static_cast<std::size_t>(image.width) * bytesPerPixel(*format);
  const bool can_share = shareable(array, *format);
  if (copy == false && !can_share)
    throw py::value_error(fmt::format(
        "{}: the {} (strides {}, {}) cannot be shared without a copy; expected packed pixels in "
        "rows (np.ascontiguousarray), or pass copy=True",
        what, describeArray(array), array.strides(0), array.strides(1)));
  if (can_share && copy != true) {
    image.stride_bytes = image.height <= 1 ? row_bytes : static_cast<std::size_t>(array.strides(0));
    const std::size_t bytes =
        image.height == 0 ? 0 : image.stride_bytes * (image.height - 1) + row_bytes;
    image.pixels = viewOf<std::uint8_t>(array, array.data(), bytes);
  } else {
    if (!can_share && !copy.has_value() && array.size() > 0)
      warnCopy(fmt::format("{}: the {} was copied: its rows are not packed pixels", what,
                           describeArray(array)));
    py::array packed = py::module_::import("numpy").attr("ascontiguousarray")(array);
    const auto* begin = static_cast<const std::uint8_t*>(packed.data());
    image.stride_bytes = row_bytes;
    image.pixels = Buffer<std::uint8_t>::copyOf({begin, row_bytes * image.height});
  }
  return image;
}

py::array arrayOf(const Image& image) {
  const auto h = static_cast<py::ssize_t>(image.height), w = static_cast<py::ssize_t>(image.width);
  const auto stride = static_cast<py::ssize_t>(image.stride_bytes);
  const std::shared_ptr<const void> owner = image.pixels.owner();
  const std::uint8_t* data = image.pixels.data();
  if (image.empty()) return py::array(py::dtype::of<std::uint8_t>(), {0, 0}, {});
  switch (image.format) {
    case PixelFormat::kGray8:
      return readOnlyView(owner, data, {h, w}, {stride, 1});
    case PixelFormat::kBgr8:
      return readOnlyView(owner, data, {h, w, 3}, {stride, 3, 1});
    case PixelFormat::kGray16:
      return readOnlyView(owner, reinterpret_cast<const std::uint16_t*>(data), {h, w}, {stride, 2});
    case PixelFormat::kFloat32:
      return readOnlyView(owner, reinterpret_cast<const float*>(data), {h, w}, {stride, 4});
  }
  return py::none();
}

constexpr const char* kImageDoc =
    "An image: pixels in a shared, immutable buffer, a stamp (int, µs), the optical frame and, "
    "for a calibrated camera, its CameraModel.\n\n"
    "Image(array, stamp=0, frame_id='', camera=None, copy=None) views a NumPy array without a "
    "copy when its rows hold packed pixels (any row stride): uint8 (H, W) grey, uint8 (H, W, 3) "
    "BGR, uint16 (H, W) or float32 (H, W). The array must not change while CDFF holds the "
    "image. Another layout is copied with a cdff.CopyWarning (copy=True: copied silently; "
    "copy=False: a ValueError instead). `array` is a read-only view of the pixels.";

void bindCamera(py::module_& m) {
  py::enum_<PixelFormat>(m, "PixelFormat")
      .value("GRAY8", PixelFormat::kGray8)
      .value("BGR8", PixelFormat::kBgr8)
      .value("GRAY16", PixelFormat::kGray16)
      .value("FLOAT32", PixelFormat::kFloat32);
  py::enum_<DistortionModel>(m, "DistortionModel")
      .value("NONE", DistortionModel::kNone)
      .value("RADIAL_TANGENTIAL", DistortionModel::kRadialTangential)
      .value("EQUIDISTANT", DistortionModel::kEquidistant);
  py::class_<CameraModel, std::shared_ptr<CameraModel>>(
      m, "CameraModel", "Pinhole intrinsics (pixels) with lens distortion.")
      .def(py::init<>())
      .def(py::init([](int width, int height, double fx, double fy, double cx, double cy,
                       DistortionModel model, std::vector<double> distortion) {
             return CameraModel{width, height, fx, fy, cx, cy, model, std::move(distortion)};
           }),
           py::arg("width"), py::arg("height"), py::arg("fx"), py::arg("fy"), py::arg("cx"),
           py::arg("cy"), py::arg("distortion_model") = DistortionModel::kNone,
           py::arg("distortion") = std::vector<double>{})
      .def_readwrite("width", &CameraModel::width)
      .def_readwrite("height", &CameraModel::height)
      .def_readwrite("fx", &CameraModel::fx)
      .def_readwrite("fy", &CameraModel::fy)
      .def_readwrite("cx", &CameraModel::cx)
      .def_readwrite("cy", &CameraModel::cy)
      .def_readwrite("distortion_model", &CameraModel::distortion_model)
      .def_readwrite("distortion", &CameraModel::distortion)
      .def("matrix", &CameraModel::matrix, "K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]")
      .def("project", &CameraModel::project, py::arg("p_camera"),
           "Pixel of a point in the camera frame (z forward), without distortion.")
      .def("validate", [](const CameraModel& c) { check(c.validate()); });
  addClassConverter<CameraModel>("cdff.CameraModel");
}

void bindImage(py::module_& m) {
  py::class_<Image, std::shared_ptr<Image>>(m, "Image", kImageDoc)
      .def(py::init<>())
      .def(py::init([](const py::array& array, Timestamp stamp, std::string frame_id,
                       std::optional<CameraModel> camera, std::optional<bool> copy) {
             Image image = imageFromArray(array, copy, "Image");
             image.stamp = stamp;
             image.frame_id = std::move(frame_id);
             image.camera = std::move(camera);
             return image;
           }),
           py::arg("array"), py::arg("stamp") = 0, py::arg("frame_id") = "",
           py::arg("camera") = py::none(), py::arg("copy") = py::none())
      .def_readwrite("stamp", &Image::stamp)
      .def_readwrite("frame_id", &Image::frame_id)
      .def_readonly("width", &Image::width)
      .def_readonly("height", &Image::height)
      .def_readonly("format", &Image::format)
      .def_readonly("stride_bytes", &Image::stride_bytes)
      .def_readwrite("camera", &Image::camera)
      .def_property_readonly("array", &arrayOf, "The pixels, a read-only view (no copy).")
      .def("validate", [](const Image& i) { check(i.validate()); })
      .def("__repr__", [](const Image& i) {
        return fmt::format("<cdff.Image {}x{} {} stamp={} frame_id='{}'>", i.width, i.height,
                           toString(i.format), i.stamp, i.frame_id);
      });
  addClassConverter<Image>("cdff.Image");
}

void bindDepthAndPairs(py::module_& m) {
  py::class_<DepthMap, std::shared_ptr<DepthMap>>(
      m, "DepthMap",
      "A depth image: float32 metres along the optical axis, or uint16 units of "
      "meters_per_unit; 0 or NaN is no measurement. DepthMap(array, meters_per_unit=1.0, "
      "stamp=0, frame_id='', camera=None, copy=None) shares the array as Image does.")
      .def(py::init<>())
      .def(py::init([](const py::array& array, double meters_per_unit, Timestamp stamp,
                       std::string frame_id, std::optional<CameraModel> camera,
                       std::optional<bool> copy) {
             DepthMap depth{imageFromArray(array, copy, "DepthMap"), meters_per_unit};
             depth.image.stamp = stamp;
             depth.image.frame_id = std::move(frame_id);
             depth.image.camera = std::move(camera);
             check(depth.validate());
             return depth;
           }),
           py::arg("array"), py::arg("meters_per_unit") = 1.0, py::arg("stamp") = 0,
           py::arg("frame_id") = "", py::arg("camera") = py::none(), py::arg("copy") = py::none())
      .def_readwrite("image", &DepthMap::image)
      .def_readwrite("meters_per_unit", &DepthMap::meters_per_unit)
      .def_property_readonly("array", [](const DepthMap& d) { return arrayOf(d.image); })
      .def("validate", [](const DepthMap& d) { check(d.validate()); });
  addClassConverter<DepthMap>("cdff.DepthMap");

  py::class_<StereoImagePair, std::shared_ptr<StereoImagePair>>(
      m, "StereoImagePair", "Two synchronised images of a calibrated stereo rig.")
      .def(py::init<>())
      .def(py::init([](Image left, Image right, Transform right_T_left) {
             return StereoImagePair{std::move(left), std::move(right), std::move(right_T_left)};
           }),
           py::arg("left"), py::arg("right"), py::arg("right_T_left"))
      .def_readwrite("left", &StereoImagePair::left)
      .def_readwrite("right", &StereoImagePair::right)
      .def_readwrite("right_T_left", &StereoImagePair::right_T_left)
      .def("validate", [](const StereoImagePair& p) { check(p.validate()); });
  addClassConverter<StereoImagePair>("cdff.StereoImagePair");

  py::class_<CompressedImage, std::shared_ptr<CompressedImage>>(
      m, "CompressedImage", "A JPEG, PNG or WebP image as produced, not decoded.")
      .def(py::init<>())
      .def(py::init([](py::bytes data, std::string format, Timestamp stamp, std::string frame_id) {
             char* bytes = nullptr;
             py::ssize_t size = 0;
             PyBytes_AsStringAndSize(data.ptr(), &bytes, &size);
             // Python bytes are immutable: the buffer views them.
             return CompressedImage{stamp, std::move(frame_id), std::move(format),
                                    viewOf<std::uint8_t>(data, bytes, size)};
           }),
           py::arg("data"), py::arg("format"), py::arg("stamp") = 0, py::arg("frame_id") = "")
      .def_readwrite("stamp", &CompressedImage::stamp)
      .def_readwrite("frame_id", &CompressedImage::frame_id)
      .def_readwrite("format", &CompressedImage::format)
      .def_property_readonly("data", [](const CompressedImage& c) {
        return readOnlyView(c.data.owner(), c.data.data(),
                            {static_cast<py::ssize_t>(c.data.size())}, {1});
      });
  addClassConverter<CompressedImage>("cdff.CompressedImage");
}

}  // namespace

void bindImages(py::module_& m) {
  bindCamera(m);
  bindImage(m);
  bindDepthAndPairs(m);
}

}  // namespace cdff::python
