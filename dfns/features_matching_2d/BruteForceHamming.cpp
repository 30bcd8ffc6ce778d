#include "matching_common.hpp"

namespace cdff::dfn {

class FeaturesMatching2DBruteForceHamming final
    : public matching::Matcher<FeaturesMatching2DBruteForceHammingBase> {
 protected:
  std::vector<std::vector<cv::DMatch>> nearest(const cv::Mat& queries, const cv::Mat& indexed,
                                               int norm, int k) override {
    std::vector<std::vector<cv::DMatch>> knn;
    cv::BFMatcher(norm).knnMatch(queries, indexed, knn, k);
    return knn;
  }
};

CDFF_REGISTER_DFI(FeaturesMatching2DBruteForceHamming);

}  // namespace cdff::dfn
