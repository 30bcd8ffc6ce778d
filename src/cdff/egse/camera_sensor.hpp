#pragma once
// The camera model: what turns rendered radiance into the 8-bit image of a real camera.
//
//   render (pinhole canvas covering the distorted field of view, optionally supersampled)
//   -> partial occlusion fault -> background (Earth, stars, sun disc) -> stray light from a sun
//   near the field of view -> lens distortion (remap onto the camera's pixel grid)
//   -> optics and defocus blur -> exposure (electrons) -> shot + read noise -> full well, gain,
//   8-bit quantisation -> dark frame when the camera failed.
// Exposure: electrons = radiance x sensitivity x exposure_time, with radiance in the renderer's
// unit (1 = white Lambertian plate facing the sun); 8-bit value = electrons x gain x 255 /
// full_well, clipped. Over- and under-exposure follow from exposure_time and gain_db.

#include <cstdint>
#include <string>
#include <vector>

#include "cdff/egse/background.hpp"
#include "cdff/egse/render.hpp"
#include "cdff/egse/rng.hpp"
#include "cdff/types/image.hpp"

namespace cdff::egse {

struct CameraSpec {
  CameraModel model;                         // the real camera: intrinsics and distortion
  PixelFormat format = PixelFormat::kGray8;  // kGray8 or kBgr8
  double exposure_time = 0.004;              // s
  double gain_db = 0.0;
  double full_well = 20000.0;  // e-
  double read_noise = 12.0;    // e- rms
  double sensitivity = 7.0e6;  // e-/s for radiance 1 (a white plate facing the sun)
  bool noise = true;
  double psf_sigma = 0.5;       // px, optics
  double f_number = 0.0;        // 0: no defocus
  double focus_distance = 0.0;  // m (with f_number > 0)
  double focal_length = 6e-3;   // m (defocus)
  double pixel_pitch = 4.4e-6;  // m (defocus)
  int supersampling = 1;        // k x k samples per canvas pixel (far range: sub-pixel targets)
  int motion_blur_samples = 1;  // renders averaged over the exposure
  bool stars = true;
  double star_gain = 1.0;
  double glare_strength = 0.03;  // stray light of a sun at the edge of the field of view
  double glare_width = 0.07;     // rad, angular width of the glare halo
  double glare_decay = 0.09;     // rad, fall-off as the sun moves away from the field of view
  int shadow_map_size = 1024;

  Status validate(const std::string& name) const;
};

enum class OcclusionMode { kOccluder, kShadow };

/// Fault effects on one frame (from the fault schedule).
struct CameraFaults {
  bool dark = false;         // the camera failed: read noise only
  double glare_gain = 1.0;   // multiplies glare_strength (sun glare / saturation fault)
  double extra_glare = 0.0;  // a uniform veil added (radiance units)
  double occlusion = 0.0;    // fraction of the target's pixels hidden (0..1)
  OcclusionMode occlusion_mode = OcclusionMode::kOccluder;
};

struct CameraFrame {
  Image image;
  DepthMap depth;                    // truth depth (m along the optical axis) on the image grid
  std::vector<std::uint8_t> labels;  // 0 sky, 1 target, 2 servicer, 254 Earth, 255 occluder
  double occluded_fraction = 0.0;    // what the occlusion fault achieved
};

class CameraSensor {
 public:
  /// Precomputes the canvas and the distortion remap.
  static Result<CameraSensor> create(const CameraSpec& spec, const std::string& name);

  const CameraSpec& spec() const { return spec_; }
  /// The camera to render (the canvas, supersampled).
  const PinholeCamera& renderCamera() const { return render_camera_; }
  /// The canvas before supersampling (background and glare are drawn on it).
  const PinholeCamera& canvas() const { return canvas_; }

  /// Turns `renders` (motion-blur samples of renderCamera(), at least one; the middle one gives
  /// depth and labels) into a frame. `view` places the camera for the background; `rng` is
  /// this frame's noise stream. Not thread-safe (the sensor keeps its scratch buffers).
  Result<CameraFrame> expose(const std::vector<RenderOutput>& renders, const BackgroundView& view,
                             const CameraFaults& faults, Rng& rng) const;

 private:
  // The steps of expose(), in order.
  void averageSamples(const std::vector<RenderOutput>& renders, RenderOutput& canvas) const;
  double occludeTarget(const CameraFaults& faults, RenderOutput& canvas) const;  // the fraction
  // A halo around the sun's direction and two ghosts mirrored through the principal point.
  void addStrayLight(const BackgroundView& view, const CameraFaults& faults,
                     RenderOutput& canvas) const;
  double glareLevel(const BackgroundView& view, const CameraFaults& faults,
                    const Eigen::Vector3d& sun) const;
  void spectralResponse(const RenderOutput& canvas, int channels) const;  // to canvas_signal_
  // Resamples canvas_signal_ onto the camera's pixels (signal_), with depth_ and the labels.
  void distort(const RenderOutput& canvas, int channels, CameraFrame& frame) const;
  double blurSigma(const CameraFrame& frame) const;  // optics and defocus, pixels
  Status quantise(const CameraFaults& faults, Rng& rng, int channels, CameraFrame& frame) const;

  CameraSpec spec_;
  std::string name_;
  PinholeCamera canvas_, render_camera_;
  // Where each output pixel samples the canvas (the same on every frame, so found once): the
  // canvas index of the top-left of its 2x2 bilinear neighbourhood, the weights of the right and
  // lower neighbours, and the canvas index of its nearest canvas pixel.
  struct CanvasSample {
    std::uint32_t corner = 0, nearest = 0;
    float fu = 0, fv = 0;
  };
  std::vector<CanvasSample> samples_;
  // The samples of every pixel of `model` on `canvas`: through `remap` (per pixel: canvas u, v)
  // for a distorted camera, the pixel moved by the canvas's margin for an undistorted one (an
  // empty remap).
  static std::vector<CanvasSample> canvasSamples(const CameraModel& model,
                                                 const PinholeCamera& canvas,
                                                 const std::vector<float>& remap);
  mutable RenderOutput canvas_scratch_;
  mutable std::vector<float> canvas_signal_, signal_, depth_, blur_scratch_;
};

}  // namespace cdff::egse
