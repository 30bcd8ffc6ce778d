#pragma once
// Object detections in one camera image: the poses at which known objects were found (template
// matching, e.g. TemplateDetection), with how well each matched and where in the image.

#include <limits>
#include <string>
#include <vector>

#include "cdff/types/geometry.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

/// One detection of a known object in an image: its pose and how well its template matched.
struct Detection {
  /// camera_T_object: parent = the image's optical frame, child = the object's frame.
  Transform pose;
  double similarity = 0;  // 0..1, the fraction of the template's features that matched
  /// 0..1, the fraction of the model's visible points whose depth a measured depth confirms;
  /// NaN when no depth was checked.
  double depth_agreement = std::numeric_limits<double>::quiet_NaN();
  std::string template_id;                  // which template matched (e.g. "range_3/1234")
  int x = 0, y = 0, width = 0, height = 0;  // the matched template's box, pixels of the input image
};

/// The detections in one image, best first; empty when nothing was found.
struct Detections {
  Timestamp stamp = 0;
  std::string frame_id;  // the image's optical frame
  std::vector<Detection> detections;

  /// Ok when every pose is valid (finite, unit quaternion), similarities are finite in [0, 1] and
  /// boxes have non-negative sizes; the error names the detection index, the field and the value.
  Status validate() const;
};

}  // namespace cdff
