// MCAP codecs of the image types: Image, DepthMap, StereoImagePair, CompressedImage and
// CameraModel.
#include <algorithm>

#include "cdff/types/codec/support.hpp"

namespace cdff::codec {

using namespace detail;  // NOLINT: the shared helpers of this directory
using F = pb::FieldType;

namespace {

const char* distortionName(const CameraModel& c) {
  switch (c.distortion_model) {
    case DistortionModel::kNone:
      return "";
    case DistortionModel::kRadialTangential:
      return c.distortion.size() == 8 ? "rational_polynomial" : "plumb_bob";
    case DistortionModel::kEquidistant:
      return "kannala_brandt";
  }
  return "";
}

// The body of a foxglove.CameraCalibration.
void putCalibrationBody(pb::Writer& w, const CameraModel& c, Timestamp stamp,
                        std::string_view frame_id) {
  putTimestamp(w, 1, stamp);
  w.string(9, frame_id);
  w.fixed32(2, static_cast<std::uint32_t>(std::max(c.width, 0)));
  w.fixed32(3, static_cast<std::uint32_t>(std::max(c.height, 0)));
  w.string(4, distortionName(c));
  w.packed<double>(5, c.distortion);
  const double k[9] = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  const double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double p[12] = {c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0};
  w.packed<double>(6, k);
  w.packed<double>(7, r);
  w.packed<double>(8, p);
}

const char* imageEncoding(PixelFormat f) {
  switch (f) {
    case PixelFormat::kGray8:
      return "mono8";
    case PixelFormat::kBgr8:
      return "bgr8";
    case PixelFormat::kGray16:
      return "mono16";
    case PixelFormat::kFloat32:
      return "32FC1";
  }
  return "";
}

Status checkImageBuffer(const Image& im, std::string_view what) {
  if (im.width < 0 || im.height < 0)
    return invalidInput("{} is {}x{}; expected non-negative dimensions", what, im.width, im.height);
  const std::size_t row = static_cast<std::size_t>(im.width) * bytesPerPixel(im.format);
  if (im.height > 0 && im.stride_bytes < row)
    return invalidInput("{} stride is {} bytes; expected at least width x bytes per pixel = {}",
                        what, im.stride_bytes, row);
  const std::size_t need = static_cast<std::size_t>(im.height) * im.stride_bytes;
  if (im.pixels.size() < need)
    return invalidInput("{} holds {} bytes of pixels; expected height x stride = {}", what,
                        im.pixels.size(), need);
  if (im.stamp < 0) return negativeStamp(what, im.stamp);
  return Status::ok();
}

// The fields of a foxglove.RawImage except `data`, which the caller appends last.
void putRawImageHead(pb::Writer& w, const Image& im, const double* meters_per_unit) {
  putTimestamp(w, 1, im.stamp);
  w.string(7, im.frame_id);
  w.fixed32(2, static_cast<std::uint32_t>(im.width));
  w.fixed32(3, static_cast<std::uint32_t>(im.height));
  w.string(4, imageEncoding(im.format));
  w.fixed32(5, static_cast<std::uint32_t>(im.stride_bytes));
  if (im.camera) {
    const std::size_t s = w.begin(1000);
    putCalibrationBody(w, *im.camera, im.stamp, im.frame_id);
    w.end(s);
  }
  if (meters_per_unit) w.float64(1001, *meters_per_unit);
}

// Appends a whole RawImage with its pixels referenced, as the value of field `f` (0: as the
// top-level message).
void putRawImage(Encoded& out, std::uint32_t f, const Image& im, const double* meters_per_unit) {
  const std::size_t n = static_cast<std::size_t>(im.height) * im.stride_bytes;
  if (f == 0) {
    pb::Writer w(out.bytes);
    putRawImageHead(w, im, meters_per_unit);
    w.lengthPrefix(6, n);
  } else {
    std::vector<std::uint8_t> head;
    pb::Writer h(head);
    putRawImageHead(h, im, meters_per_unit);
    h.lengthPrefix(6, n);
    pb::Writer w(out.bytes);
    w.lengthPrefix(f, head.size() + n);
    w.raw(head.data(), head.size());
  }
  out.reference(Bytes(im.pixels.data(), n));
}

Status readCalibration(Bytes data, CameraModel& c, Timestamp* stamp, std::string* frame_id) {
  c = CameraModel{};
  std::string model;
  std::vector<double> k;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.CameraCalibration", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r) && stamp) inner = readTimestamp(r.bytes(), *stamp);
        break;
      case 9:
        if (isLen(r) && frame_id) *frame_id = r.string();
        break;
      case 2:
        c.width = static_cast<int>(r.u64());
        break;
      case 3:
        c.height = static_cast<int>(r.u64());
        break;
      case 4:
        if (isLen(r)) model = r.string();
        break;
      case 5:
        return appendRepeated(r, c.distortion);
      case 6:
        return appendRepeated(r, k);
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  if (k.size() != 9 && !k.empty())
    return corruptMessage("foxglove.CameraCalibration",
                          fmt::format("K has {} entries; expected 9", k.size()));
  if (k.size() == 9) {
    c.fx = k[0];
    c.cx = k[2];
    c.fy = k[4];
    c.cy = k[5];
  }
  if (model.empty() || model == "none") {
    c.distortion_model = DistortionModel::kNone;
  } else if (model == "plumb_bob" || model == "rational_polynomial" ||
             model == "radial_tangential") {
    c.distortion_model = DistortionModel::kRadialTangential;
  } else if (model == "kannala_brandt" || model == "equidistant" || model == "fisheye") {
    c.distortion_model = DistortionModel::kEquidistant;
  } else {
    return corruptMessage("foxglove.CameraCalibration",
                          fmt::format("distortion model '{}' is not supported; expected "
                                      "plumb_bob, rational_polynomial or kannala_brandt",
                                      model));
  }
  return Status::ok();
}

// The pixel format of a RawImage encoding (ROS names and OpenCV types). RGB has no format of
// its own: it is stored as BGR with the outer channels swapped.
struct RawEncoding {
  PixelFormat format = PixelFormat::kGray8;
  bool swap_rgb = false;
};

Result<RawEncoding> rawEncoding(const std::string& encoding) {
  if (encoding == "mono8" || encoding == "8UC1") return RawEncoding{PixelFormat::kGray8};
  if (encoding == "bgr8" || encoding == "8UC3") return RawEncoding{PixelFormat::kBgr8};
  if (encoding == "rgb8") return RawEncoding{PixelFormat::kBgr8, true};
  if (encoding == "mono16" || encoding == "16UC1") return RawEncoding{PixelFormat::kGray16};
  if (encoding == "32FC1") return RawEncoding{PixelFormat::kFloat32};
  return corruptMessage("foxglove.RawImage",
                        fmt::format("encoding '{}' is not supported; expected mono8, bgr8, "
                                    "rgb8, mono16 or 32FC1",
                                    encoding));
}

// A copy of 3-channel pixels with the first and third channels swapped (RGB to BGR).
Buffer<std::uint8_t> rgbToBgr(Bytes pixels, std::uint32_t width, std::uint32_t height,
                              std::uint32_t step) {
  std::vector<std::uint8_t> bgr(pixels.begin(), pixels.end());
  for (std::uint32_t y = 0; y < height; ++y)
    for (std::uint32_t x = 0; x < width; ++x)
      std::swap(bgr[y * step + 3 * x], bgr[y * step + 3 * x + 2]);
  return Buffer<std::uint8_t>::fromVector(std::move(bgr));
}

Status readRawImage(Bytes data, const std::shared_ptr<const void>& owner, Image& im,
                    double* meters_per_unit) {
  im = Image{};
  std::string encoding;
  Bytes pixels;
  std::uint32_t width = 0, height = 0, step = 0;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.RawImage", [&](pb::Reader& r) {
    switch (r.field()) {
      case 1:
        if (isLen(r)) inner = readTimestamp(r.bytes(), im.stamp);
        break;
      case 7:
        if (isLen(r)) im.frame_id = r.string();
        break;
      case 2:
        width = static_cast<std::uint32_t>(r.u64());
        break;
      case 3:
        height = static_cast<std::uint32_t>(r.u64());
        break;
      case 4:
        if (isLen(r)) encoding = r.string();
        break;
      case 5:
        step = static_cast<std::uint32_t>(r.u64());
        break;
      case 6:
        if (isLen(r)) pixels = r.bytes();
        break;
      case 1000:
        if (isLen(r)) {
          CameraModel camera;
          inner = readCalibration(r.bytes(), camera, nullptr, nullptr);
          im.camera = std::move(camera);
        }
        break;
      case 1001:
        if (meters_per_unit && r.type() == WireType::kFixed64) *meters_per_unit = r.f64();
        break;
      default:
        break;
    }
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  Result<RawEncoding> format = rawEncoding(encoding);
  if (!format) return format.status();
  im.format = format->format;
  const std::uint64_t row = static_cast<std::uint64_t>(width) * bytesPerPixel(im.format);
  if (height > 0 && step < row)
    return corruptMessage("foxglove.RawImage",
                          fmt::format("step {} is shorter than a {}-pixel {} row ({} bytes)", step,
                                      width, encoding, row));
  const std::uint64_t need = static_cast<std::uint64_t>(height) * step;
  if (pixels.size() < need)
    return corruptMessage("foxglove.RawImage",
                          fmt::format("data holds {} bytes; expected height {} x step {} = {}",
                                      pixels.size(), height, step, need));
  im.width = static_cast<int>(width);
  im.height = static_cast<int>(height);
  im.stride_bytes = step;
  pixels = pixels.first(static_cast<std::size_t>(need));
  if (format->swap_rgb)
    im.pixels = rgbToBgr(pixels, width, height, step);
  else
    im.pixels = shareBytes(
        pixels, owner,
        static_cast<std::size_t>(bytesPerPixel(im.format) == 3 ? 1 : bytesPerPixel(im.format)));
  return Status::ok();
}

}  // namespace

Status encode(const Image& v, Timestamp, Encoded& out) {
  out.clear();
  CDFF_RETURN_IF_ERROR(checkImageBuffer(v, "image"));
  putRawImage(out, 0, v, nullptr);
  return Status::ok();
}

Status encode(const DepthMap& v, Timestamp, Encoded& out) {
  out.clear();
  CDFF_RETURN_IF_ERROR(checkImageBuffer(v.image, "depth map"));
  putRawImage(out, 0, v.image, &v.meters_per_unit);
  return Status::ok();
}

Status encode(const StereoImagePair& v, Timestamp, Encoded& out) {
  out.clear();
  CDFF_RETURN_IF_ERROR(checkImageBuffer(v.left, "stereo pair left image"));
  CDFF_RETURN_IF_ERROR(checkImageBuffer(v.right, "stereo pair right image"));
  putRawImage(out, 1, v.left, nullptr);
  putRawImage(out, 2, v.right, nullptr);
  pb::Writer w(out.bytes);
  const std::size_t s = w.begin(3);  // no reference() inside: begin/end may move bytes
  const Transform& t = v.right_T_left;
  putTimestamp(w, 1, t.stamp);
  w.string(2, t.parent_frame);
  w.string(3, t.child_frame);
  putXyz(w, 4, t.translation.x(), t.translation.y(), t.translation.z());
  putQuaternion(w, 5, t.rotation);
  w.end(s);
  return Status::ok();
}

Status encode(const CompressedImage& v, Timestamp, Encoded& out) {
  out.clear();
  if (v.stamp < 0) return negativeStamp("compressed image", v.stamp);
  pb::Writer w(out.bytes);
  putTimestamp(w, 1, v.stamp);
  w.string(4, v.frame_id);
  w.string(3, v.format);
  w.lengthPrefix(2, v.data.size());
  out.reference(v.data.span());
  return Status::ok();
}

Status encodeCalibration(const CameraModel& v, Timestamp stamp, std::string_view frame_id,
                         Encoded& out) {
  out.clear();
  if (stamp < 0) return negativeStamp("camera model", stamp);
  pb::Writer w(out.bytes);
  putCalibrationBody(w, v, stamp, frame_id);
  return Status::ok();
}

Status encode(const CameraModel& v, Timestamp stamp, Encoded& out) {
  return encodeCalibration(v, stamp, "", out);
}

Status decode(Bytes data, const std::shared_ptr<const void>& owner, Image& out) {
  return readRawImage(data, owner, out, nullptr);
}

Status decode(Bytes data, const std::shared_ptr<const void>& owner, DepthMap& out) {
  out = DepthMap{};
  return readRawImage(data, owner, out.image, &out.meters_per_unit);
}

Status decode(Bytes data, const std::shared_ptr<const void>& owner, StereoImagePair& out) {
  out = StereoImagePair{};
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "cdff.StereoImagePair", [&](pb::Reader& r) {
    if (!isLen(r)) return true;
    if (r.field() == 1) inner = readRawImage(r.bytes(), owner, out.left, nullptr);
    if (r.field() == 2) inner = readRawImage(r.bytes(), owner, out.right, nullptr);
    if (r.field() == 3) inner = decode(r.bytes(), owner, out.right_T_left);
    return inner.isOk();
  }));
  return inner;
}

Status decode(Bytes data, const std::shared_ptr<const void>& owner, CompressedImage& out) {
  out = CompressedImage{};
  Bytes bytes;
  Status inner;
  CDFF_RETURN_IF_ERROR(forFields(data, "foxglove.CompressedImage", [&](pb::Reader& r) {
    if (!isLen(r)) return true;
    if (r.field() == 1) inner = readTimestamp(r.bytes(), out.stamp);
    if (r.field() == 4) out.frame_id = r.string();
    if (r.field() == 3) out.format = r.string();
    if (r.field() == 2) bytes = r.bytes();
    return inner.isOk();
  }));
  CDFF_RETURN_IF_ERROR(inner);
  out.data = shareBytes(bytes, owner, 1);
  return Status::ok();
}

Status decode(Bytes data, const std::shared_ptr<const void>&, CameraModel& out) {
  return readCalibration(data, out, nullptr, nullptr);
}

}  // namespace cdff::codec
