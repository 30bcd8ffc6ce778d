#include "extraction_common.hpp"

namespace cdff::dfn {

class FeaturesExtraction2DOrb final : public extraction::Extractor<FeaturesExtraction2DOrbBase> {
 protected:
  Status onConfigure() override {
    if (params_.edge_threshold < params_.patch_size / 2)
      return invalidParameter(
          "{}: edge_threshold ({} px) is below half the patch_size ({} px); expected "
          "edge_threshold >= patch_size / 2, or descriptors near the border would read outside "
          "the image",
          name(), params_.edge_threshold, params_.patch_size);
    // Detect up to twice the budget: ORB spreads features over levels and the strongest across
    // all levels are kept by publish().
    orb_ = cv::ORB::create(2 * params_.max_features, static_cast<float>(params_.scale_factor),
                           params_.levels, params_.edge_threshold, 0, params_.wta_k,
                           params_.score == "harris" ? cv::ORB::HARRIS_SCORE : cv::ORB::FAST_SCORE,
                           params_.patch_size, params_.fast_threshold);
    return Status::ok();
  }

  Detection detect(const extraction::PreparedInput& input) override {
    Detection d;
    orb_->detectAndCompute(input.gray, input.mask, d.keypoints, d.descriptors);
    d.distance = params_.wta_k == 2 ? DescriptorMatrix::Distance::kHamming
                                    : DescriptorMatrix::Distance::kHamming2;
    return d;
  }

  std::string sensitivity() const override {
    return fmt::format("fast_threshold {}", params_.fast_threshold);
  }

 private:
  cv::Ptr<cv::ORB> orb_;
};

CDFF_REGISTER_DFI(FeaturesExtraction2DOrb);

}  // namespace cdff::dfn
