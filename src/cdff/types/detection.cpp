#include "cdff/types/detection.hpp"

#include <cmath>

#include <fmt/format.h>

namespace cdff {

Status Detections::validate() const {
  for (std::size_t i = 0; i < detections.size(); ++i) {
    const Detection& d = detections[i];
    const std::string what = fmt::format("detections in '{}': detection {}", frame_id, i);
    if (Status s = d.pose.validate(); !s) return s.withContext(what + " pose");
    if (!std::isfinite(d.similarity) || d.similarity < 0 || d.similarity > 1)
      return invalidInput("{} similarity is {}; expected a finite value in [0, 1]", what,
                          d.similarity);
    if (!std::isnan(d.depth_agreement) && (d.depth_agreement < 0 || d.depth_agreement > 1))
      return invalidInput("{} depth agreement is {}; expected a value in [0, 1] or NaN (unchecked)",
                          what, d.depth_agreement);
    if (d.width < 0 || d.height < 0)
      return invalidInput("{} box is {}x{} pixels at ({}, {}); expected a non-negative size", what,
                          d.width, d.height, d.x, d.y);
  }
  return Status::ok();
}

}  // namespace cdff
