#pragma once
// Edge matching: a 1D search along the normal of each contour sample for image edges that run
// parallel to the contour.
//
// The grey levels are read along 2 h + 1 parallel lines across the contour (bilinear
// interpolation); their mean derivative along the normal is the edge response. Its local maxima
// above `min_gradient` whose gradient direction is within `angular_threshold` of the contour
// normal are candidates, located to a fraction of a pixel by a parabola through the three
// responses around the peak. Up to `max_candidates` per sample are kept, strongest first: the
// pose estimator picks among them, so a texture edge next to the true contour does not capture
// the sample.

#include "cdff/types/contours.hpp"
#include "cdff/types/image.hpp"

namespace cdff::tracking {

struct EdgeSearchOptions {
  int search_distance = 8;                         // px each side of the sample
  double angular_threshold = 30.0 * M_PI / 180.0;  // rad between gradient and contour normal
  double min_gradient = 8.0;                       // grey levels per pixel along the normal
  int max_candidates = 3;
  int half_width = 1;  // h: lines on each side of the sample's own line (mask 2 h + 1 wide)
  /// Contrast adaptation (0: off). A dim image (back-lit target, a veil of stray light over a
  /// saturated one) has weak edges everywhere; then the threshold becomes this fraction of the
  /// 75th percentile of the samples' strongest responses, when that is below min_gradient, but
  /// never below noise_sigmas times the noise of the response (from the median absolute
  /// response along all the search lines, which mostly cross flat image) nor below
  /// min_gradient_floor.
  double relative_gradient = 0.0;
  double noise_sigmas = 4.0;
  double min_gradient_floor = 0.5;  // grey levels per pixel
};

/// Fills the candidates of `samples` from the grey image `image` (8UC1, the size of the
/// samples' camera model). The samples keep their order. `applied_threshold`, when given,
/// receives the gradient threshold the search used (min_gradient, or its contrast adaptation).
Result<ContourSamples> searchEdges(const Image& image, const ContourSamples& samples,
                                   const EdgeSearchOptions& options,
                                   double* applied_threshold = nullptr);

}  // namespace cdff::tracking
