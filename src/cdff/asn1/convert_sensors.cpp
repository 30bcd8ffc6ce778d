// CalibrationMatrix, Image8UC1 / Image8UC3 / Image32FC1 and PointCloud.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "cdff/asn1/convert.hpp"

namespace cdff::asn1 {

namespace detail {

// ---- CalibrationMatrix -------------------------------------------------------------------------

namespace {

Status checkSide(int v, std::string_view field) {
  if (v >= 1 && v <= kMaxImageSide) return Status::ok();
  return invalidInput("{} is {}; ImageDimension holds 1..{}", field, v, kMaxImageSide);
}

Status fillCalibration(CalibrationMatrix_t& out, const CameraModel& v, std::string_view field) {
  CDFF_RETURN_IF_ERROR(checkSide(v.width, fmt::format("{}.width", field)));
  CDFF_RETURN_IF_ERROR(checkSide(v.height, fmt::format("{}.height", field)));
  out.width = v.width;
  out.height = v.height;
  for (auto [name, value, slot] : {std::tuple{"fx", v.fx, &out.fx},
                                   {"fy", v.fy, &out.fy},
                                   {"cx", v.cx, &out.cx},
                                   {"cy", v.cy, &out.cy}}) {
    CDFF_RETURN_IF_ERROR(checkFinite(value, fmt::format("{}.{}", field, name)));
    *slot = value;
  }
  switch (v.distortion_model) {
    case DistortionModel::kNone:
      out.distortion_model = DistortionModel_none;
      break;
    case DistortionModel::kRadialTangential:
      out.distortion_model = DistortionModel_radial_tangential;
      break;
    case DistortionModel::kEquidistant:
      out.distortion_model = DistortionModel_equidistant;
      break;
  }
  if (v.distortion.size() > kMaxDistortionCoefficients)
    return invalidInput("{}.distortion has {} coefficients; the bound is {}", field,
                        v.distortion.size(), kMaxDistortionCoefficients);
  return setDoubles(anonymous(out.distortion.list), v.distortion,
                    fmt::format("{}.distortion", field));
}

Result<CameraModel> readCalibration(const CalibrationMatrix_t& in, std::string_view field) {
  CameraModel v;
  v.width = static_cast<int>(in.width);
  v.height = static_cast<int>(in.height);
  v.fx = in.fx;
  v.fy = in.fy;
  v.cx = in.cx;
  v.cy = in.cy;
  switch (in.distortion_model) {
    case DistortionModel_none:
      v.distortion_model = DistortionModel::kNone;
      break;
    case DistortionModel_radial_tangential:
      v.distortion_model = DistortionModel::kRadialTangential;
      break;
    case DistortionModel_equidistant:
      v.distortion_model = DistortionModel::kEquidistant;
      break;
    default:
      return corruptData("{}.distortion-model is {}; expected 0, 1 or 2", field,
                         in.distortion_model);
  }
  const auto& list = anonymous(in.distortion.list);
  if (list.count < 0 || static_cast<std::size_t>(list.count) > kMaxDistortionCoefficients)
    return corruptData("{}.distortion has {} coefficients; the bound is {}", field, list.count,
                       kMaxDistortionCoefficients);
  v.distortion.resize(static_cast<std::size_t>(list.count));
  CDFF_RETURN_IF_ERROR(getDoubles(list, v.distortion, fmt::format("{}.distortion", field)));
  if (Status s = v.validate(); !s) return corruptData("uPER {}: {}", field, s.message());
  return v;
}

}  // namespace

Status encodeCameraModel(const CameraModel& v, std::vector<std::uint8_t>& out) {
  Filled<CalibrationMatrix_t> c(asn_DEF_CalibrationMatrix);
  CDFF_RETURN_IF_ERROR(fillCalibration(c.value, v, "CalibrationMatrix"));
  return encodeStruct(asn_DEF_CalibrationMatrix, &c.value, out);
}

Result<CameraModel> decodeCameraModel(std::span<const std::uint8_t> data) {
  Result<Decoded<CalibrationMatrix_t>> c =
      decodeAs<CalibrationMatrix_t>(asn_DEF_CalibrationMatrix, data);
  if (!c) return c.status();
  return readCalibration(**c, "CalibrationMatrix");
}

// ---- Images ------------------------------------------------------------------------------------

namespace {

struct ImageKind {
  asn_TYPE_descriptor_t* def;
  const char* name;
  PixelFormat format;
  std::size_t max_bytes;
  const char* max_pixels;
};

ImageKind imageKind(Asn1Type type) {
  switch (type) {
    case Asn1Type::kImage8UC3:
      return {&asn_DEF_Image8UC3, "Image8UC3", PixelFormat::kBgr8, kMaxImage8UC3Bytes,
              "2048 x 2048 x 3"};
    case Asn1Type::kImage32FC1:
      return {&asn_DEF_Image32FC1, "Image32FC1", PixelFormat::kFloat32, kMaxImage32FC1Bytes,
              "2048 x 2048 x 4"};
    default:
      return {&asn_DEF_Image8UC1, "Image8UC1", PixelFormat::kGray8, kMaxImage8UC1Bytes,
              "2048 x 2048"};
  }
}

// Image32FC1's floats are little-endian: a big-endian host swaps each one.
constexpr bool kSwapFloats = std::endian::native == std::endian::big;

void swapFloats(std::uint8_t* p, std::size_t bytes) {
  for (std::size_t i = 0; i + 3 < bytes; i += 4) {
    std::swap(p[i], p[i + 3]);
    std::swap(p[i + 1], p[i + 2]);
  }
}

// The three image types have the same fields: one filler and one reader for the three.
template <typename T>
Status fillImage(Filled<T>& out, const Image& v, const ImageKind& kind) {
  const std::string field = kind.name;
  CDFF_RETURN_IF_ERROR(v.validate(kind.name));
  CDFF_RETURN_IF_ERROR(checkSide(v.width, field + ".width"));
  CDFF_RETURN_IF_ERROR(checkSide(v.height, field + ".height"));
  const std::size_t row = static_cast<std::size_t>(v.width) * bytesPerPixel(v.format);
  const std::size_t bytes = row * static_cast<std::size_t>(v.height);
  if (bytes > kind.max_bytes)
    return invalidInput(
        "{}.data: a {}x{} {} image has {} bytes of pixels; the bound of {} is {} "
        "bytes ({})",
        kind.name, v.width, v.height, toString(v.format), bytes, kind.name, kind.max_bytes,
        kind.max_pixels);
  T& s = out.value;
  s.time.microseconds = v.stamp;
  CDFF_RETURN_IF_ERROR(setString(s.frame_id, v.frame_id, field + ".frame-id"));
  s.width = v.width;
  s.height = v.height;
  if (v.stride_bytes == row && !(kSwapFloats && v.format == PixelFormat::kFloat32)) {
    out.borrow(s.data, v.pixels.data(), bytes);  // packed rows: no copy
  } else {
    if (OCTET_STRING_fromBuf(&s.data, nullptr, 0) != 0 ||
        !(s.data.buf = static_cast<std::uint8_t*>(std::malloc(bytes))))
      return Status(StatusCode::kInternal, fmt::format("{}.data: out of memory", kind.name));
    s.data.size = static_cast<int>(bytes);
    for (int y = 0; y < v.height; ++y) std::memcpy(s.data.buf + y * row, v.row(y), row);
    if (kSwapFloats && v.format == PixelFormat::kFloat32) swapFloats(s.data.buf, bytes);
  }
  if (v.camera) {
    s.calibration = static_cast<CalibrationMatrix_t*>(std::calloc(1, sizeof(CalibrationMatrix_t)));
    if (!s.calibration)
      return Status(StatusCode::kInternal, fmt::format("{}.calibration: out of memory", kind.name));
    CDFF_RETURN_IF_ERROR(fillCalibration(*s.calibration, *v.camera, field + ".calibration"));
  }
  return Status::ok();
}

template <typename T>
Result<Image> readImage(T& s, const ImageKind& kind) {
  const std::string field = kind.name;
  Image v;
  v.stamp = s.time.microseconds;
  Result<std::string> frame = getString(s.frame_id, field + ".frame-id");
  if (!frame) return frame.status();
  v.frame_id = std::move(frame).value();
  v.width = static_cast<int>(s.width);
  v.height = static_cast<int>(s.height);
  v.format = kind.format;
  v.stride_bytes = static_cast<std::size_t>(v.width) * bytesPerPixel(kind.format);
  const std::size_t expected = v.stride_bytes * static_cast<std::size_t>(v.height);
  if (s.data.size < 0 || static_cast<std::size_t>(s.data.size) != expected)
    return corruptData("{}.data has {} bytes; expected width * height * {} = {} * {} * {} = {}",
                       kind.name, s.data.size, bytesPerPixel(kind.format), v.width, v.height,
                       bytesPerPixel(kind.format), expected);
  // The pixels stay where asn1c decoded them: the image owns them from here on.
  std::shared_ptr<std::uint8_t> owner(s.data.buf, [](std::uint8_t* p) { std::free(p); });
  s.data.buf = nullptr;
  s.data.size = 0;
  if (kSwapFloats && kind.format == PixelFormat::kFloat32) swapFloats(owner.get(), expected);
  v.pixels = Buffer<std::uint8_t>::view(owner, owner.get(), expected);
  if (s.calibration) {
    Result<CameraModel> camera = readCalibration(*s.calibration, field + ".calibration");
    if (!camera) return camera.status();
    v.camera = std::move(camera).value();
  }
  if (Status valid = v.validate(kind.name); !valid)
    return corruptData("uPER {}: {}", kind.name, valid.message());
  return v;
}

template <typename T>
Status encodeImageAs(const Image& v, const ImageKind& kind, std::vector<std::uint8_t>& out) {
  Filled<T> s(*kind.def);
  CDFF_RETURN_IF_ERROR(fillImage(s, v, kind));
  return encodeStruct(*kind.def, &s.value, out);
}

template <typename T>
Result<Image> decodeImageAs(const ImageKind& kind, std::span<const std::uint8_t> data) {
  Result<Decoded<T>> s = decodeAs<T>(*kind.def, data);
  if (!s) return s.status();
  return readImage(**s, kind);
}

}  // namespace

Status encodeImage(const Image& v, std::vector<std::uint8_t>& out) {
  switch (v.format) {
    case PixelFormat::kGray8:
      return encodeImageAs<Image8UC1_t>(v, imageKind(Asn1Type::kImage8UC1), out);
    case PixelFormat::kBgr8:
      return encodeImageAs<Image8UC3_t>(v, imageKind(Asn1Type::kImage8UC3), out);
    case PixelFormat::kFloat32:
      return encodeImageAs<Image32FC1_t>(v, imageKind(Asn1Type::kImage32FC1), out);
    default:
      return invalidInput("an image of format {} has no ASN.1 type; expected mono8, bgr8 or 32FC1",
                          toString(v.format));
  }
}

Result<Image> decodeImage(Asn1Type type, std::span<const std::uint8_t> data) {
  switch (type) {
    case Asn1Type::kImage8UC3:
      return decodeImageAs<Image8UC3_t>(imageKind(type), data);
    case Asn1Type::kImage32FC1:
      return decodeImageAs<Image32FC1_t>(imageKind(type), data);
    default:
      return decodeImageAs<Image8UC1_t>(imageKind(Asn1Type::kImage8UC1), data);
  }
}

}  // namespace detail

}  // namespace cdff::asn1
