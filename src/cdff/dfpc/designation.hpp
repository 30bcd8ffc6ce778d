#pragma once
// A user's designation of the target from the command line (far-range tracking, seed §4.1.1:
// "the user initialises the position of the target by selecting a ROI"): `X,Y,W,H@TIME`, the box
// [X, X + W) x [Y, Y + H) of the image at TIME seconds from the start of the run, delivered as an
// ImageRegion on a channel that a graph's designation input reads; and the stream that merges
// such messages into a recording's stream.

#include <memory>
#include <string>
#include <vector>

#include "cdff/dfpc/stream.hpp"
#include "cdff/types/image_region.hpp"

namespace cdff::dfpc {

/// The channel `cdff run --roi` publishes on, which dfpcs/far_range_tracking.yaml reads.
inline constexpr const char* kDesignationChannel = "/cdff/designation";

struct Designation {
  ImageRegion region;  // source "user"
  double time_s = 0;   // from the start of the run
};

/// Parses "X,Y,W,H@TIME" (pixels, seconds); the error says which part is wrong and what was
/// expected.
Result<Designation> parseDesignation(const std::string& text);

/// `input` with `extra` messages merged in by stamp (an extra message before an input message of
/// the same stamp); `input` must outlive the stream.
std::unique_ptr<InputStream> withMessages(InputStream& input, std::vector<Message> extra);

}  // namespace cdff::dfpc
