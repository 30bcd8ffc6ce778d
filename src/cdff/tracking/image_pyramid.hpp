#pragma once
// The image pyramid of the acquisition: each level halves the one above by 2x2 averaging, with the
// camera model of the smaller image. One frame's levels are built once, when first needed, and
// shared by the coarse alignment and both acquisition hypotheses.

#include <cstddef>
#include <deque>
#include <span>
#include <vector>

#include "cdff/tracking/edge_tracker.hpp"

namespace cdff::tracking {

/// The model's image must stay this wide (px) at a pyramid level for the level to fix the pose.
inline constexpr double kMinModelPx = 96;

/// Half the resolution by 2x2 averaging (rounded to nearest), with the same stamp and frame; a
/// last odd row or column is dropped.
Image halveImage(const Image& image);

/// The camera model of an image halved by halveImage(): half the focal lengths and size, the
/// principal point moved with the pixel centres.
CameraModel halveCamera(const CameraModel& camera);

/// `camera` halved `level` times.
CameraModel cameraAtLevel(CameraModel camera, int level);

/// The pyramids of one frame's camera images, each level built when first asked for.
class FramePyramids {
 public:
  /// The frames must outlive this object.
  explicit FramePyramids(std::span<const CameraFrame> frames);

  /// The image of camera `camera` (which must have one) at `level` (0 = full resolution). The
  /// reference stays valid while this object lives.
  const Image& image(std::size_t camera, int level);

  /// Camera `camera`'s frame at `level`: its camera model halved `level` times and, when it has
  /// an image, that level's image.
  CameraFrame frame(std::size_t camera, int level);

 private:
  std::span<const CameraFrame> frames_;
  std::vector<std::deque<Image>> levels_;  // per camera; a deque keeps references valid
};

}  // namespace cdff::tracking
