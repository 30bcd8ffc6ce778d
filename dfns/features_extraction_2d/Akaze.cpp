#include "extraction_common.hpp"

namespace cdff::dfn {

class FeaturesExtraction2DAkaze final
    : public extraction::Extractor<FeaturesExtraction2DAkazeBase> {
 protected:
  Status onConfigure() override {
    akaze_ =
        cv::AKAZE::create(cv::AKAZE::DESCRIPTOR_MLDB, 0, 3, static_cast<float>(params_.threshold),
                          params_.octaves, params_.octave_layers, cv::KAZE::DIFF_PM_G2);
    return Status::ok();
  }

  Detection detect(const extraction::PreparedInput& input) override {
    Detection d;
    akaze_->detectAndCompute(input.gray, input.mask, d.keypoints, d.descriptors);
    return d;
  }

  std::string sensitivity() const override {
    return fmt::format("threshold {}", params_.threshold);
  }

 private:
  cv::Ptr<cv::AKAZE> akaze_;
};

CDFF_REGISTER_DFI(FeaturesExtraction2DAkaze);

}  // namespace cdff::dfn
