#include "cdff/types/contours.hpp"

namespace cdff {

const char* toString(ContourKind kind) {
  switch (kind) {
    case ContourKind::kCrease:
      return "crease";
    case ContourKind::kSilhouette:
      return "silhouette";
    case ContourKind::kBoundary:
      return "boundary";
    case ContourKind::kLine:
      return "line";
  }
  return "unknown";
}

const char* toString(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::kTracking:
      return "tracking";
    case TrackingStatus::kDegraded:
      return "degraded";
    case TrackingStatus::kLost:
      return "lost";
  }
  return "unknown";
}

Status ModelContours::validate(const char* what) const {
  if (Status s = camera.validate(); !s) return s.withContext(fmt::format("{} camera", what));
  if (Status s = camera_T_model.validate(); !s)
    return s.withContext(fmt::format("{} camera_T_model", what));
  if (Status s = camera_T_reference.validate(); !s)
    return s.withContext(fmt::format("{} camera_T_reference", what));
  for (std::size_t i = 0; i < segments.size(); ++i)
    if (!segments[i].a.allFinite() || !segments[i].b.allFinite())
      return invalidInput("{} segment {} has a non-finite end point; expected finite points", what,
                          i);
  for (std::size_t i = 0; i < faces.size(); ++i)
    if (!faces[i].normal.allFinite() || !std::isfinite(faces[i].offset) ||
        faces[i].outline.size() < 3)
      return invalidInput(
          "{} face {} is malformed ({} outline points); expected a finite plane "
          "and at least 3 points",
          what, i, faces[i].outline.size());
  return Status::ok();
}

std::size_t ContourSamples::matchedCount() const {
  std::size_t n = 0;
  for (const ContourSample& s : samples) n += s.candidate_count > 0 ? 1 : 0;
  return n;
}

Status ContourSamples::validate(const char* what) const {
  if (!contours)
    return invalidInput("{} carry no contours; expected the output of ContourSampling", what);
  CDFF_RETURN_IF_ERROR(contours->validate(what));
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const ContourSample& s = samples[i];
    if (s.segment >= contours->segments.size())
      return invalidInput("{} sample {} refers to segment {}; expected an index below {}", what, i,
                          s.segment, contours->segments.size());
    if (static_cast<std::size_t>(s.first_candidate) + s.candidate_count > candidates.size())
      return invalidInput("{} sample {} refers to candidates [{}, {}); only {} exist", what, i,
                          s.first_candidate, s.first_candidate + s.candidate_count,
                          candidates.size());
    if (!s.point.allFinite() || !s.pixel.allFinite() || !s.normal.allFinite())
      return invalidInput("{} sample {} has non-finite coordinates; expected finite values", what,
                          i);
  }
  return Status::ok();
}

}  // namespace cdff
