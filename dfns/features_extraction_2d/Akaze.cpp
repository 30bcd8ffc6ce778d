#include "extraction_common.hpp"

namespace cdff::dfn {

class FeaturesExtraction2DAkaze final : public FeaturesExtraction2DAkazeBase {
 protected:
  Status onConfigure() override {
    akaze_ =
        cv::AKAZE::create(cv::AKAZE::DESCRIPTOR_MLDB, 0, 3, static_cast<float>(params_.threshold),
                          params_.octaves, params_.octave_layers, cv::KAZE::DIFF_PM_G2);
    return Status::ok();
  }

  Status onProcess() override {
    Result<extraction::PreparedInput> input = extraction::prepare(in);
    if (!input) return input.status();
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    akaze_->detectAndCompute(input->gray, input->mask, keypoints, descriptors);
    if (keypoints.empty())
      warn(fmt::format("no AKAZE feature found in the {}x{} image (threshold {})", in.image->width,
                       in.image->height, params_.threshold));
    return extraction::publish(*in.image, keypoints, descriptors,
                               DescriptorMatrix::Distance::kHamming, params_.max_features,
                               out.features);
  }

 private:
  cv::Ptr<cv::AKAZE> akaze_;
};

CDFF_REGISTER_DFI(FeaturesExtraction2DAkaze);

}  // namespace cdff::dfn
