#pragma once
// One value of every recordable CDFF type, deterministic for a seed, with every optional field
// set (frame ids, stamps, covariances, per-point fields, camera models), and the channels that
// docs/recording.md names for them. Shared by the round-trip tests and the interoperability test.

#include <string>

#include <nlohmann/json.hpp>
#include "cdff/types/codec/codec.hpp"

#include "cdff/io/recorder.hpp"

namespace cdff::testing {

struct IoSamples {
  Image image_mono;    // 8UC1 with a camera model and padded rows
  Image image_bgr;     // 8UC3 without camera
  Image image_float;   // 32FC1
  CameraModel camera;  // also inside image_mono
  CompressedImage compressed;
  StereoImagePair stereo;
  DepthMap depth_m;      // 32FC1, metres
  DepthMap depth_mm;     // 16UC1, millimetres
  PointCloud cloud;      // normals, intensity, ring, time offsets
  PointCloud cloud_xyz;  // points only
  Transform transform;
  PoseWithCovariance pose;
  RigidBodyState state;
  PoseArray trajectory;
  TriangleMesh mesh;
  Features2D features2d;
  Features3D features3d;
  Matches matches;
  Correspondences2D corr2d;
  Correspondences3D corr3d;
  Correspondences2D3D corr2d3d;
  ImuSample imu;
  Wrench wrench;
  JointState joints;
  nlohmann::json record;  // a DFN timing record
};

/// Values for message `index` at time `stamp` (us); `small` keeps images and clouds tiny.
IoSamples makeIoSamples(int index, Timestamp stamp, bool small = true);

/// Writes every sample on its conventional channel.
Status writeIoSamples(io::Recorder& recorder, const IoSamples& s, Timestamp stamp);

}  // namespace cdff::testing
