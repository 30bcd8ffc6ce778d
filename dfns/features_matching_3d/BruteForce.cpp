#include <opencv2/features2d.hpp>

#include "matching3d_common.hpp"

namespace cdff::dfn {

class FeaturesMatching3DBruteForce final
    : public matching3d::Matcher<FeaturesMatching3DBruteForceBase> {
 protected:
  Result<matching3d::Neighbours> nearest(const cv::Mat& queries, const cv::Mat& searched,
                                         int k) override {
    std::vector<std::vector<cv::DMatch>> knn;
    try {
      cv::BFMatcher(cv::NORM_L2).knnMatch(queries, searched, knn, k);
    } catch (const cv::Exception& e) {
      return numericalFailure("brute-force matching failed: {}", e.what());
    }
    matching3d::Neighbours neighbours(knn.size());
    for (std::size_t q = 0; q < knn.size(); ++q)
      for (const cv::DMatch& m : knn[q]) neighbours[q].push_back({m.trainIdx, m.distance});
    return neighbours;
  }
};

CDFF_REGISTER_DFI(FeaturesMatching3DBruteForce);

}  // namespace cdff::dfn
