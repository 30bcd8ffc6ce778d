#include "EdgeMatching.gen.hpp"
#include "cdff/tracking/edge_search.hpp"
#include "cdff/tracking/edge_tracker.hpp"

namespace cdff::dfn {

class EdgeMatchingNormalSearch final : public EdgeMatchingNormalSearchBase {
 protected:
  Status onProcess() override {
    Result<Image> grey = tracking::toGray8(*in.image, "input 'image'");
    if (!grey) return grey.status();
    tracking::EdgeSearchOptions options;
    options.search_distance = params_.search_distance;
    options.angular_threshold = params_.angular_threshold;
    options.min_gradient = params_.min_gradient;
    options.max_candidates = params_.max_candidates;
    options.half_width = params_.mask_half_width;
    Result<ContourSamples> matches = tracking::searchEdges(*grey, *in.samples, options);
    if (!matches) return matches.status().withContext("inputs 'image' and 'samples'");
    const double ratio = matches->samples.empty()
                             ? 0.0
                             : static_cast<double>(matches->matchedCount()) /
                                   static_cast<double>(matches->samples.size());
    if (!matches->samples.empty() && ratio == 0.0)
      warn(
          "no sample found an image edge (dark, saturated or blurred image, or the model far "
          "from the prediction)");
    out.matched_ratio.set(ratio);
    out.matches.set(std::move(matches).value());
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(EdgeMatchingNormalSearch);

}  // namespace cdff::dfn
