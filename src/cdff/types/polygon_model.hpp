#pragma once
// Polygonal target models for model-based trackers: 3D points, planar faces, explicit 3D lines,
// cylinders and circles (the primitives of ViSP's .cao format), in the model's own frame.
//
// Faces are planar polygons listed counter-clockwise seen from outside: the right-hand normal
// points out of the object, which is what decides whether a face is seen from its front.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/types/status.hpp"

namespace cdff {

struct PolygonModel {
  struct Face {
    std::vector<std::uint32_t> points;  // indices into `points`, counter-clockwise from outside
    std::string name;
  };
  /// A 3D segment tracked on its own (not a face boundary), e.g. an antenna or a painted line.
  struct Line {
    std::uint32_t a = 0, b = 0;
    std::string name;
  };
  /// A cylinder of `radius` around the axis from point a to point b (its limbs are contours).
  struct Cylinder {
    std::uint32_t a = 0, b = 0;
    double radius = 0;  // m
    std::string name;
  };
  /// A circle of `radius` around point `centre` in the plane through centre, first and second.
  struct Circle {
    std::uint32_t centre = 0, first = 0, second = 0;
    double radius = 0;  // m
    std::string name;
  };

  std::string frame_id;                 // the model (target body) frame
  std::vector<Eigen::Vector3d> points;  // m
  std::vector<Face> faces;
  std::vector<Line> lines;
  std::vector<Cylinder> cylinders;
  std::vector<Circle> circles;

  bool empty() const {
    return faces.empty() && lines.empty() && cylinders.empty() && circles.empty();
  }
  /// Ok when there is at least one primitive, points are finite, indices in range, faces have at
  /// least 3 distinct points and are planar (every point within 2 % of the face's diameter, at
  /// least 1e-6 m, of its best plane), lines and axes have distinct ends and radii are positive.
  /// The message names `what`, the primitive (index and name) and the offending value.
  Status validate(const char* what = "model") const;
  /// Adds every primitive of `other` with its points mapped by `transform` (this_T_other).
  void append(const PolygonModel& other,
              const Eigen::Isometry3d& transform = Eigen::Isometry3d::Identity());
  /// Axis-aligned bounds of the points.
  Eigen::AlignedBox3d bounds() const;
};

/// Reads a ViSP .cao model (version 1): points, 3D lines, faces from lines, faces from points,
/// cylinders, circles, `name=` and other `key=value` options, `#` comments and `load("file")`
/// includes (relative to the including file). Errors name the file and line, the record and the
/// value, and what was expected.
Result<PolygonModel> loadCao(const std::string& path);
/// Parses .cao text; `source` names it in messages and `directory` resolves `load()` includes.
Result<PolygonModel> parseCao(std::string_view text, const std::string& source,
                              const std::string& directory = ".");
/// Writes `model` as .cao version 1 (points, lines, faces from points, cylinders, circles).
Status writeCao(const PolygonModel& model, const std::string& path);
std::string toCao(const PolygonModel& model);

}  // namespace cdff
