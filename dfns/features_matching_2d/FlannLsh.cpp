#include <opencv2/flann.hpp>

#include "matching_common.hpp"

namespace cdff::dfn {

class FeaturesMatching2DFlannLsh final : public matching::Matcher<FeaturesMatching2DFlannLshBase> {
 protected:
  Status supports(const DescriptorMatrix& descriptors) const override {
    if (descriptors.distance == DescriptorMatrix::Distance::kHamming2)
      return invalidInput(
          "inputs have Hamming-2 descriptors (ORB with wta_k 3 or 4); expected "
          "plain binary descriptors: FLANN's LSH index only hashes single bits, "
          "use BruteForceHamming");
    return Status::ok();
  }

  // The LSH index is built over `indexed` on every call: a tracker's train set changes with each
  // keyframe, and building costs about as much as one query pass.
  std::vector<std::vector<cv::DMatch>> nearest(const cv::Mat& queries, const cv::Mat& indexed,
                                               int /*norm: LSH is Hamming by construction*/,
                                               int k) override {
    cv::FlannBasedMatcher matcher(cv::makePtr<cv::flann::LshIndexParams>(
                                      params_.tables, params_.key_bits, params_.multi_probe_level),
                                  cv::makePtr<cv::flann::SearchParams>());
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(queries, indexed, knn, k);
    return knn;
  }
};

CDFF_REGISTER_DFI(FeaturesMatching2DFlannLsh);

}  // namespace cdff::dfn
