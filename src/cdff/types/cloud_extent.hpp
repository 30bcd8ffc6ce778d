#pragma once
// How large a point cloud is, and the check that a model and the scene it is sought in are in
// the same units (implemented in point_cloud.cpp).

#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff {

/// The diagonal of the axis-aligned box of the cloud's finite points (m); 0 without any.
double boxDiagonal(const PointCloud& cloud);

/// A model may be at most this many times the extent of the scene it is sought in.
inline constexpr double kMostModelToSceneExtent = 100.0;

/// Ok unless a model `model_diameter` m across is more than kMostModelToSceneExtent times the
/// extent of the scene it is sought in: a model in millimetres against a scene in metres (1000
/// times), not a scene that shows a small part of a large target (a capture camera's 0.3 m of a
/// 7 m satellite is 23 times). The error names both inputs (`scene_port`, `model_port`), their
/// sizes and the ratio.
Status checkModelScale(const PointCloud& scene, double model_diameter, const char* scene_port,
                       const char* model_port);

}  // namespace cdff
