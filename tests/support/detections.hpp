#pragma once
// Detections of the target at known poses, the input of the refinement DFNs' tests.
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "cdff/types/detection.hpp"

namespace cdff::testing {

/// One detection per pose (camera_T_target in `frame`), each with `similarity`, all at `stamp`.
inline Detections detectionsAt(const std::vector<Eigen::Isometry3d>& poses, double similarity,
                               Timestamp stamp = 1000, const std::string& frame = "camera") {
  Detections d;
  d.stamp = stamp;
  d.frame_id = frame;
  for (const Eigen::Isometry3d& p : poses) {
    Detection one;
    one.pose = Transform::fromIsometry(p, frame, "target", stamp);
    one.similarity = similarity;
    d.detections.push_back(one);
  }
  return d;
}

}  // namespace cdff::testing
