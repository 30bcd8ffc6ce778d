#pragma once
// Visual features with descriptors, matches and 2D/3D correspondences.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/buffer.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

/// A row-major matrix of descriptors, one row per feature.
struct DescriptorMatrix {
  enum class Element : std::uint8_t { kUint8, kFloat32 };  // binary (ORB) or real (SIFT, SHOT)
  /// How two descriptors compare: bit count (binary), 2-bit groups (ORB with WTA_K 3 or 4), L2.
  enum class Distance : std::uint8_t { kHamming, kHamming2, kL2 };
  Element element = Element::kUint8;
  Distance distance = Distance::kHamming;
  int rows = 0;
  int cols = 0;  // elements per descriptor
  Buffer<std::uint8_t> data;  // rows * cols * elementSize bytes

  int elementSize() const { return element == Element::kUint8 ? 1 : 4; }
  bool empty() const { return rows == 0; }
  const std::uint8_t* row(int r) const {
    return data.data() + static_cast<std::size_t>(r) * cols * elementSize();
  }
  Status validate(const char* what = "descriptors") const;
};

struct Keypoint2D {
  Eigen::Vector2f position = Eigen::Vector2f::Zero();  // pixels
  float size = 0;       // diameter of the meaningful neighbourhood, pixels
  float angle = -1;     // orientation in degrees [0, 360), -1 if not applicable (OpenCV's)
  float response = 0;   // detector strength
  int octave = 0;       // pyramid level
};

struct Features2D {
  Timestamp stamp = 0;
  std::string frame_id;
  std::vector<Keypoint2D> keypoints;
  DescriptorMatrix descriptors;  // empty or one row per keypoint

  std::size_t size() const { return keypoints.size(); }
  Status validate(const char* what = "features") const;
};

struct Keypoint3D {
  Eigen::Vector3f position = Eigen::Vector3f::Zero();  // m
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();    // unit, or zero if unknown
};

struct Features3D {
  Timestamp stamp = 0;
  std::string frame_id;
  std::vector<Keypoint3D> keypoints;
  DescriptorMatrix descriptors;

  std::size_t size() const { return keypoints.size(); }
  Status validate(const char* what = "features") const;
};

/// A pairing of feature `query` of the first set with feature `train` of the second.
struct Match {
  int query = -1;
  int train = -1;
  float distance = 0;  // descriptor distance (Hamming for binary, L2 for real)
};

struct Matches {
  std::vector<Match> matches;
  std::size_t size() const { return matches.size(); }
};

/// Point pairs, e.g. matched pixels in two images.
struct Correspondences2D {
  std::vector<Eigen::Vector2d> first;   // pixels
  std::vector<Eigen::Vector2d> second;  // pixels
  std::size_t size() const { return first.size(); }
  Status validate(const char* what = "correspondences") const;
};

struct Correspondences3D {
  std::vector<Eigen::Vector3d> first;  // m
  std::vector<Eigen::Vector3d> second;
  std::size_t size() const { return first.size(); }
  Status validate(const char* what = "correspondences") const;
};

/// 3D model points and the pixels they were observed at (input of PnP).
struct Correspondences2D3D {
  std::vector<Eigen::Vector3d> points;  // m, model or world frame
  std::vector<Eigen::Vector2d> pixels;
  std::size_t size() const { return points.size(); }
  Status validate(const char* what = "correspondences") const;
};

}  // namespace cdff
