#pragma once
// Reader of ViSP's "Castle-simu" model-based tracking sequence (Debian package visp-images-data,
// ViSP-images 3.5.0, mbt-depth/Castle-simu): 40 rendered 640x480 grey frames of a castle and a
// cube, depth maps, the CAD model and the true camera pose of every frame. Header-only so that the
// end-to-end tests and the benchmark read it the same way (no test framework needed).
//
// Formats, as checked by reprojecting the model onto the images and the depth maps:
//  - CameraPose/Camera_NNN.txt: the 4x4 matrix camera_T_model (ViSP's cMo), metres, row-major;
//  - Depth/Depth_NNNN.bin: uint32 height, uint32 width (little-endian), then height x width uint16
//    depths along the optical axis in units of 0.000030518 m (the scale ViSP's own test uses), 0
//    for no surface, seen by a depth camera 5 cm to the right of the grey camera (depth_T_camera is
//    a translation of -0.05 m along x) with the same intrinsics;
//  - Config/chateau.xml: intrinsics px = py = 700, u0 = 320, v0 = 240, no distortion;
//  - Models/chateau.cao (floor and tower, via load()) plus Models/cube.cao placed by the transform
//    ViSP's testGenericTracker.cpp applies (model_T_cube below).

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "cdff/types/image.hpp"
#include "cdff/types/polygon_model.hpp"

namespace cdff::testing::castle {

inline const char* kDirectory = "/usr/share/visp-images-data/ViSP-images/mbt-depth/Castle-simu";
constexpr int kFrames = 40;
constexpr double kDepthScale = 0.000030518;  // m per depth unit

inline bool available() {
  return std::filesystem::exists(std::string(kDirectory) + "/Models/chateau.cao");
}

inline CameraModel camera() {
  CameraModel c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 700;
  c.cx = 320;
  c.cy = 240;
  return c;
}

/// The depth camera in the grey camera's frame: depth_T_camera.
inline Eigen::Isometry3d depthTCamera() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() << -0.05, 0, 0;
  return t;
}

inline Eigen::Isometry3d modelTCube() {
  Eigen::Matrix4d m;
  m << -1, 0, 0, -0.2,  //
      0, 0, 1, 0.12,    //
      0, 1, 0, -0.15,   //
      0, 0, 0, 1;
  Eigen::Isometry3d t;
  t.matrix() = m;
  return t;
}

/// chateau.cao with the cube, in one model.
inline Result<PolygonModel> model() {
  const std::string dir = std::string(kDirectory) + "/Models/";
  Result<PolygonModel> castle = loadCao(dir + "chateau.cao");
  if (!castle) return castle;
  Result<PolygonModel> cube = loadCao(dir + "cube.cao");
  if (!cube) return cube;
  castle->append(*cube, modelTCube());
  castle->frame_id = "castle";
  return castle;
}

struct Frame {
  Image image;     // 8UC1 with its camera model
  DepthMap depth;  // 16UC1, kDepthScale m per unit, with its camera model
  Eigen::Isometry3d camera_T_model = Eigen::Isometry3d::Identity();  // ground truth
};

/// Frame `index` in [1, 40].
inline Result<Frame> frame(int index, bool with_depth = true) {
  char name[64];
  Frame f;
  const std::string dir = kDirectory;
  std::snprintf(name, sizeof(name), "/Images/Image_%04d.pgm", index);
  {
    std::ifstream in(dir + name, std::ios::binary);
    std::string magic;
    int w = 0, h = 0, maxval = 0;
    in >> magic >> w >> h >> maxval;
    in.get();
    if (!in || magic != "P5" || w <= 0 || h <= 0 || maxval != 255)
      return ioError("cannot read the PGM image '{}{}'", dir, name);
    std::vector<std::uint8_t> pixels(static_cast<std::size_t>(w) * h);
    in.read(reinterpret_cast<char*>(pixels.data()), static_cast<std::streamsize>(pixels.size()));
    if (!in) return ioError("'{}{}' is truncated", dir, name);
    Result<Image> image = Image::fromBytes(std::move(pixels), w, h, PixelFormat::kGray8);
    if (!image) return image.status();
    f.image = std::move(image).value();
    f.image.camera = camera();
    f.image.frame_id = "camera";
    f.image.stamp = static_cast<Timestamp>(index) * 33333;
  }
  if (with_depth) {
    std::snprintf(name, sizeof(name), "/Depth/Depth_%04d.bin", index);
    std::ifstream in(dir + name, std::ios::binary);
    std::uint32_t h = 0, w = 0;
    in.read(reinterpret_cast<char*>(&h), 4);
    in.read(reinterpret_cast<char*>(&w), 4);
    std::vector<std::uint8_t> raw(static_cast<std::size_t>(w) * h * 2);
    in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size()));
    if (!in || w == 0 || h == 0) return ioError("cannot read the depth map '{}{}'", dir, name);
    Result<Image> depth = Image::fromBytes(std::move(raw), static_cast<int>(w), static_cast<int>(h),
                                           PixelFormat::kGray16);
    if (!depth) return depth.status();
    f.depth.image = std::move(depth).value();
    f.depth.image.camera = camera();
    f.depth.image.frame_id = "depth";
    f.depth.image.stamp = f.image.stamp;
    f.depth.meters_per_unit = kDepthScale;
  }
  std::snprintf(name, sizeof(name), "/CameraPose/Camera_%03d.txt", index);
  std::ifstream in(dir + name);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) in >> m(r, c);
  if (!in) return ioError("cannot read the pose '{}{}'", dir, name);
  f.camera_T_model.matrix() = m;
  return f;
}

/// The errors ViSP's testGenericTracker.cpp reports: translation difference (m) and the norm of
/// the difference of the theta-u vectors (rad), besides the geodesic angle.
struct PoseError {
  double translation = 0;  // m
  double angle = 0;        // rad, geodesic
  double theta_u = 0;      // rad, |thetau(est) - thetau(truth)| as ViSP computes it
};

inline PoseError poseError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  PoseError e;
  e.translation = (estimate.translation() - truth.translation()).norm();
  e.angle = Eigen::AngleAxisd(estimate.linear().transpose() * truth.linear()).angle();
  const Eigen::AngleAxisd a(estimate.linear()), b(truth.linear());
  e.theta_u = (a.angle() * a.axis() - b.angle() * b.axis()).norm();
  return e;
}

}  // namespace cdff::testing::castle
