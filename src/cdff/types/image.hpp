#pragma once
// Images, camera models, stereo pairs and depth maps.
//
// Pixels live in a shared immutable Buffer: copying an Image copies a header, never pixels.
// Rows may be padded (stride_bytes >= width * bytesPerPixel), which keeps cv::Mat ROIs and
// externally allocated frames viewable without a copy.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/buffer.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

enum class PixelFormat : std::uint8_t {
  kGray8,    // 8UC1
  kBgr8,     // 8UC3, blue-green-red as in OpenCV
  kGray16,   // 16UC1 (e.g. raw depth in millimetres)
  kFloat32,  // 32FC1 (e.g. depth in metres, disparity)
};

const char* toString(PixelFormat format);
std::optional<PixelFormat> pixelFormatFromString(const std::string& name);
int bytesPerPixel(PixelFormat format);
int channels(PixelFormat format);

enum class DistortionModel : std::uint8_t {
  kNone,
  kRadialTangential,  // OpenCV / plumb_bob: k1, k2, p1, p2[, k3[, k4, k5, k6]]
  kEquidistant,       // fisheye: k1, k2, k3, k4
};

const char* toString(DistortionModel model);

/// Pinhole camera intrinsics with lens distortion, for images of width x height pixels.
struct CameraModel {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels
  DistortionModel distortion_model = DistortionModel::kNone;
  std::vector<double> distortion;  // coefficients in the model's order

  /// The 3x3 matrix K = [fx 0 cx; 0 fy cy; 0 0 1].
  Eigen::Matrix3d matrix() const;
  /// Projects a point in the camera frame (z forward) to pixel coordinates, without distortion.
  Eigen::Vector2d project(const Eigen::Vector3d& p_camera) const;
  bool hasDistortion() const;
  Status validate() const;
};

struct Image {
  Timestamp stamp = 0;
  std::string frame_id;  // the optical frame (z forward, x right, y down)
  int width = 0;
  int height = 0;
  PixelFormat format = PixelFormat::kGray8;
  std::size_t stride_bytes = 0;       // bytes from one row to the next
  Buffer<std::uint8_t> pixels;        // height * stride_bytes bytes
  std::optional<CameraModel> camera;  // intrinsics when the image comes from a calibrated camera

  /// Wraps `bytes` (moved, not copied) as a width x height image of `format`; stride defaults to
  /// tightly packed rows.
  static Result<Image> fromBytes(std::vector<std::uint8_t>&& bytes, int width, int height,
                                 PixelFormat format, std::size_t stride_bytes = 0);

  bool empty() const { return width <= 0 || height <= 0 || pixels.empty(); }
  const std::uint8_t* row(int y) const {
    return pixels.data() + static_cast<std::size_t>(y) * stride_bytes;
  }
  template <typename T>
  const T& at(int x, int y) const {
    return reinterpret_cast<const T*>(row(y))[x];
  }

  /// Ok when the image is non-empty, its buffer holds height * stride bytes, the stride fits a
  /// row, and its camera model (if any) matches its size. `what` names it in the message.
  Status validate(const char* what = "image") const;
  /// validate() and a check that the format is one of `allowed`.
  Status validate(const char* what, std::initializer_list<PixelFormat> allowed) const;
};

/// Two synchronised images from a calibrated stereo rig.
struct StereoImagePair {
  Image left;
  Image right;
  Transform right_T_left;  // extrinsics: maps points in the left optical frame to the right one

  Status validate() const;
};

/// A depth image: metres per pixel along the optical axis (Float32), or integer units (Gray16)
/// scaled by meters_per_unit. Zero or NaN means "no measurement".
struct DepthMap {
  Image image;
  double meters_per_unit = 1.0;

  Status validate() const;
};

/// A compressed image (JPEG, PNG, WebP) as it was produced; CDFF stores it without decoding it.
struct CompressedImage {
  Timestamp stamp = 0;
  std::string frame_id;
  std::string format;  // "jpeg", "png", "webp"
  Buffer<std::uint8_t> data;
};

}  // namespace cdff
