#include "ContourSampling.gen.hpp"
#include "cdff/tracking/contours.hpp"

namespace cdff::dfn {

class ContourSamplingUniform final : public ContourSamplingUniformBase {
 protected:
  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(in.contours->validate("input 'contours'"));
    tracking::SamplingOptions options;
    options.step = params_.step;
    options.max_samples = params_.max_samples;
    options.image_margin = params_.image_margin;
    ContourSamples samples = tracking::sampleContours(in.contours.shared(), options);
    if (samples.samples.empty() && !in.contours->segments.empty())
      warn("the visible contours are too short or too close to the border for any sample");
    out.sample_count.set(static_cast<int>(samples.samples.size()));
    out.samples.set(std::move(samples));
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(ContourSamplingUniform);

}  // namespace cdff::dfn
