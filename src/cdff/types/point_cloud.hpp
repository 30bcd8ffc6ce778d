#pragma once
// Point clouds: xyz with optional per-point normals, intensity, ring and time.
//
// Points are stored as 4 floats (x, y, z, padding) so that the memory is laid out exactly like
// pcl::PointXYZ and like the columns of an Eigen 4xN float matrix: both can view it without a
// copy. Optional fields are separate shared arrays, empty when absent.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/buffer.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

struct alignas(16) Point4f {
  float x = 0, y = 0, z = 0, pad = 1.0f;  // pad keeps 16-byte alignment and homogeneous w = 1

  Point4f() = default;
  Point4f(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  Eigen::Vector3f vec() const { return {x, y, z}; }
};
static_assert(sizeof(Point4f) == 16);

struct PointCloud {
  Timestamp stamp = 0;
  std::string frame_id;
  Buffer<Point4f> points;              // m
  Buffer<Point4f> normals;             // unit vectors, or empty
  Buffer<float> intensity;             // sensor units, or empty
  Buffer<std::uint16_t> ring;          // laser channel index, or empty
  Buffer<std::int32_t> time_offset_us; // acquisition time of each point minus stamp, or empty

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool hasNormals() const { return !normals.empty(); }

  /// Builds a cloud from xyz triples (copied into the padded layout).
  static PointCloud fromXyz(const std::vector<Eigen::Vector3f>& xyz, std::string frame_id = {},
                            Timestamp stamp = 0);

  /// Zero-copy Eigen view: a 3xN matrix with a column stride of 4 floats.
  using ConstMap3Xf =
      Eigen::Map<const Eigen::Matrix3Xf, Eigen::Unaligned, Eigen::OuterStride<4>>;
  ConstMap3Xf xyzMatrix() const;
  /// Zero-copy Eigen view of the homogeneous points as a 4xN matrix (row 3 is the padding).
  Eigen::Map<const Eigen::Matrix4Xf, Eigen::Aligned16> homogeneousMatrix() const;

  /// Ok when it has points, every optional field is empty or has one entry per point, and (if
  /// `require_finite`) no coordinate is NaN or infinite.
  Status validate(const char* what = "point cloud", bool require_finite = true) const;
};

}  // namespace cdff
