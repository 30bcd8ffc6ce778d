#pragma once
// Object detections in one camera image or scene cloud: the poses at which known objects were found
// (TemplateDetection, CorrespondenceGrouping), with how well each matched and, in an image, where.

#include <limits>
#include <string>
#include <vector>

#include "cdff/types/geometry.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

/// One detection of a known object: its pose and how well it matched.
struct Detection {
  /// sensor_T_object: parent = the image's optical frame or the scene cloud's frame.
  Transform pose;
  double similarity = 0;  // 0..1, the share of the template's features (3D: the matches) agreeing
  /// 0..1, the fraction of the model's visible points whose depth a measured depth confirms;
  /// NaN when no depth was checked.
  double depth_agreement = std::numeric_limits<double>::quiet_NaN();
  std::string template_id;  // which template matched (e.g. "range_3/1234"), or which cluster
  int x = 0, y = 0, width = 0, height = 0;  // the matched template's box in the image; 0 in 3D
};

/// The detections in one image or scene cloud, best first; empty when nothing was found.
struct Detections {
  Timestamp stamp = 0;
  std::string frame_id;  // the image's optical frame, or the scene cloud's frame
  std::vector<Detection> detections;

  /// Ok when every pose is valid (finite, unit quaternion), similarities are finite in [0, 1] and
  /// boxes have non-negative sizes; the error names the detection index, the field and the value.
  Status validate() const;
};

}  // namespace cdff
