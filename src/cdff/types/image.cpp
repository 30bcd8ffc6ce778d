#include "cdff/types/image.hpp"

#include <cmath>

namespace cdff {

const char* toString(PixelFormat format) {
  switch (format) {
    case PixelFormat::kGray8: return "8UC1";
    case PixelFormat::kBgr8: return "8UC3";
    case PixelFormat::kGray16: return "16UC1";
    case PixelFormat::kFloat32: return "32FC1";
  }
  return "unknown";
}

std::optional<PixelFormat> pixelFormatFromString(const std::string& name) {
  for (PixelFormat f : {PixelFormat::kGray8, PixelFormat::kBgr8, PixelFormat::kGray16,
                        PixelFormat::kFloat32}) {
    if (name == toString(f)) return f;
  }
  return std::nullopt;
}

int bytesPerPixel(PixelFormat format) {
  switch (format) {
    case PixelFormat::kGray8: return 1;
    case PixelFormat::kBgr8: return 3;
    case PixelFormat::kGray16: return 2;
    case PixelFormat::kFloat32: return 4;
  }
  return 0;
}

int channels(PixelFormat format) { return format == PixelFormat::kBgr8 ? 3 : 1; }

const char* toString(DistortionModel model) {
  switch (model) {
    case DistortionModel::kNone: return "none";
    case DistortionModel::kRadialTangential: return "radial_tangential";
    case DistortionModel::kEquidistant: return "equidistant";
  }
  return "unknown";
}

Eigen::Matrix3d CameraModel::matrix() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

Eigen::Vector2d CameraModel::project(const Eigen::Vector3d& p) const {
  return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy};
}

bool CameraModel::hasDistortion() const {
  if (distortion_model == DistortionModel::kNone) return false;
  for (double d : distortion)
    if (d != 0.0) return true;
  return false;
}

Status CameraModel::validate() const {
  if (width <= 0 || height <= 0)
    return invalidInput("camera model size is {}x{}; expected positive width and height", width,
                        height);
  for (auto [name, value] : {std::pair{"fx", fx}, {"fy", fy}, {"cx", cx}, {"cy", cy}}) {
    if (!std::isfinite(value))
      return invalidInput("camera model {} is {}; expected a finite value", name, value);
  }
  if (fx <= 0 || fy <= 0)
    return invalidInput("camera model focal lengths are fx={} fy={}; expected > 0 pixels", fx, fy);
  for (double d : distortion)
    if (!std::isfinite(d))
      return invalidInput("camera model distortion has a non-finite coefficient {}", d);
  std::size_t n = distortion.size();
  switch (distortion_model) {
    case DistortionModel::kNone:
      break;
    case DistortionModel::kRadialTangential:
      if (n != 4 && n != 5 && n != 8)
        return invalidInput(
            "camera model has {} radial_tangential coefficients; expected 4, 5 or 8", n);
      break;
    case DistortionModel::kEquidistant:
      if (n != 4)
        return invalidInput("camera model has {} equidistant coefficients; expected 4", n);
      break;
  }
  return Status::ok();
}

Result<Image> Image::fromBytes(std::vector<std::uint8_t>&& bytes, int width, int height,
                               PixelFormat format, std::size_t stride_bytes) {
  Image image;
  image.width = width;
  image.height = height;
  image.format = format;
  image.stride_bytes = stride_bytes != 0 ? stride_bytes
                                         : static_cast<std::size_t>(std::max(width, 0)) *
                                               bytesPerPixel(format);
  image.pixels = Buffer<std::uint8_t>::fromVector(std::move(bytes));
  CDFF_RETURN_IF_ERROR(image.validate());
  return image;
}

Status Image::validate(const char* what) const {
  if (width <= 0 || height <= 0 || pixels.empty())
    return invalidInput("{} is empty ({}x{}, {} bytes); expected a non-empty image", what, width,
                        height, pixels.size());
  const std::size_t row_bytes = static_cast<std::size_t>(width) * bytesPerPixel(format);
  if (stride_bytes < row_bytes)
    return invalidInput("{} stride is {} bytes; expected >= {} for {} pixels of {}", what,
                        stride_bytes, row_bytes, width, toString(format));
  const std::size_t needed = stride_bytes * static_cast<std::size_t>(height - 1) + row_bytes;
  if (pixels.size() < needed)
    return invalidInput("{} buffer holds {} bytes; expected >= {} for {}x{} {} with stride {}",
                        what, pixels.size(), needed, width, height, toString(format),
                        stride_bytes);
  if (camera) {
    Status s = camera->validate();
    if (!s) return s.withContext(what);
    if (camera->width != width || camera->height != height)
      return invalidInput("{} is {}x{} but its camera model is {}x{}; expected equal sizes", what,
                          width, height, camera->width, camera->height);
  }
  return Status::ok();
}

Status Image::validate(const char* what, std::initializer_list<PixelFormat> allowed) const {
  CDFF_RETURN_IF_ERROR(validate(what));
  std::string names;
  for (PixelFormat f : allowed) {
    if (f == format) return Status::ok();
    names += names.empty() ? "" : ", ";
    names += toString(f);
  }
  return invalidInput("{} has pixel format {}; expected one of [{}]", what, toString(format), names);
}

Status StereoImagePair::validate() const {
  CDFF_RETURN_IF_ERROR(left.validate("left image"));
  CDFF_RETURN_IF_ERROR(right.validate("right image"));
  if (left.width != right.width || left.height != right.height)
    return invalidInput("stereo images differ in size: left {}x{}, right {}x{}; expected equal",
                        left.width, left.height, right.width, right.height);
  if (!left.camera || !right.camera)
    return invalidInput("stereo pair lacks a camera model on the {} image; expected both calibrated",
                        left.camera ? "right" : "left");
  return right_T_left.validate();
}

Status DepthMap::validate() const {
  CDFF_RETURN_IF_ERROR(image.validate("depth map", {PixelFormat::kFloat32, PixelFormat::kGray16}));
  if (!(meters_per_unit > 0.0) || !std::isfinite(meters_per_unit))
    return invalidInput("depth map meters_per_unit is {}; expected a finite value > 0",
                        meters_per_unit);
  return Status::ok();
}

}  // namespace cdff
