#pragma once
// A narrow, ViSP-free interface to ViSP's vpMbGenericTracker, for the VispMbt DFI.
//
// ViSP 3.5's headers do not compile as C++20 (constructors spelt with template arguments), so
// visp_mbt_bridge.cpp is the one translation unit that includes them, compiled as C++17; this
// header uses only the standard library, so the DFI (C++20) never sees a ViSP type.

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace cdff::visp_bridge {

using Matrix4 = std::array<double, 16>;  // row-major homogeneous transform

struct Intrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

/// A camera of the rig: its intrinsics and camera_T_reference.
struct Camera {
  Intrinsics intrinsics;
  Matrix4 camera_T_reference{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
};

struct Settings {
  bool edges = true, klt = false;
  int me_mask_size = 5, me_mask_number = 180, me_range = 8;
  double me_threshold = 10000, me_mu1 = 0.5, me_mu2 = 0.5, me_sample_step = 5;
  int klt_max_features = 10000, klt_window_size = 5, klt_block_size = 3, klt_pyramid_levels = 3;
  int klt_mask_border = 5;
  double klt_quality = 0.01, klt_min_distance = 5, klt_harris = 0.02;
  int depth_dense_step = 4;
  double angle_appear = 1.4835298641951802, angle_disappear = 1.5533430342749532;  // rad
  double near_clipping = 0.01, far_clipping = 100;                                 // m
  bool fov_clipping = true, scanline_visibility = false;
  bool covariance = true;
};

struct GreyImage {
  const unsigned char* data = nullptr;
  int width = 0, height = 0;
  std::size_t stride = 0;  // bytes per row
};

/// Depth in metres per pixel (0 or NaN: no measurement), row-major, of the depth camera.
struct DepthImage {
  const float* metres = nullptr;
  int width = 0, height = 0;
};

struct TrackOutput {
  Matrix4 reference_T_model{};
  std::array<double, 36> covariance{};  // ViSP's, over its twist (v, omega) of the reference camera
  double inlier_ratio = 0;              // robust weights above 0.5
  int feature_count = 0;
};

class MbtTracker {
 public:
  MbtTracker();
  ~MbtTracker();
  MbtTracker(const MbtTracker&) = delete;
  MbtTracker& operator=(const MbtTracker&) = delete;

  /// Creates the tracker: one edge/KLT camera per entry of `cameras` (the first is the reference),
  /// plus a dense-depth camera when `depth` is set, and loads the .cao model. Returns "" on
  /// success, else the reason.
  std::string configure(const Settings& settings, const std::vector<Camera>& cameras,
                        const Camera* depth, const std::string& model_path);
  bool hasPose() const;
  /// Seeds the tracker with reference_T_model (first call: initialisation).
  std::string setPose(const std::vector<GreyImage>& images, const Matrix4& reference_T_model);
  /// Tracks one frame from the current pose.
  std::string track(const std::vector<GreyImage>& images, const DepthImage* depth,
                    TrackOutput& output);
  Matrix4 pose() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdff::visp_bridge
