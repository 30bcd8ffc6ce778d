#include "cdff/tracking/image_pyramid.hpp"

#include <utility>

namespace cdff::tracking {

Image halveImage(const Image& image) {
  const int w = image.width / 2, h = image.height / 2;
  std::vector<std::uint8_t> out(static_cast<std::size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* r0 = image.row(2 * y);
    const std::uint8_t* r1 = image.row(2 * y + 1);
    for (int x = 0; x < w; ++x)
      out[static_cast<std::size_t>(y) * w + x] = static_cast<std::uint8_t>(
          (r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1] + 2) / 4);
  }
  Image half = Image::fromBytes(std::move(out), w, h, PixelFormat::kGray8).value();
  half.stamp = image.stamp;
  half.frame_id = image.frame_id;
  return half;
}

CameraModel halveCamera(const CameraModel& c) {
  CameraModel h = c;
  h.width = c.width / 2;
  h.height = c.height / 2;
  h.fx = c.fx / 2;
  h.fy = c.fy / 2;
  h.cx = (c.cx + 0.5) / 2 - 0.5;
  h.cy = (c.cy + 0.5) / 2 - 0.5;
  return h;
}

CameraModel cameraAtLevel(CameraModel camera, int level) {
  for (int l = 0; l < level; ++l) camera = halveCamera(camera);
  return camera;
}

FramePyramids::FramePyramids(std::span<const CameraFrame> frames) : frames_(frames) {}

const Image& FramePyramids::image(std::size_t camera, int level) {
  if (levels_.empty()) levels_.resize(frames_.size());  // nothing allocated until needed
  std::deque<Image>& levels = levels_[camera];
  if (levels.empty()) levels.push_back(*frames_[camera].image);
  while (static_cast<int>(levels.size()) <= level) levels.push_back(halveImage(levels.back()));
  return levels[static_cast<std::size_t>(level)];
}

CameraFrame FramePyramids::frame(std::size_t camera, int level) {
  CameraFrame frame = frames_[camera];
  frame.camera = cameraAtLevel(frame.camera, level);
  if (frames_[camera].image) frame.image = &image(camera, level);
  return frame;
}

}  // namespace cdff::tracking
