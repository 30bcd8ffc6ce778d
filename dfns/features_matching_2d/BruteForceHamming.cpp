#include "matching_common.hpp"

namespace cdff::dfn {

class FeaturesMatching2DBruteForceHamming final : public FeaturesMatching2DBruteForceHammingBase {
 protected:
  Status onProcess() override {
    const Features2D& query = *in.query;
    const Features2D& train = *in.train;
    Result<bool> matchable = matching::validate(query, train);
    if (!matchable) return matchable.status();
    if (!*matchable) {
      warn(fmt::format("nothing to match: {} query and {} train features", query.size(),
                       train.size()));
      matching::publish({}, query, train, out);
      return Status::ok();
    }
    cv::BFMatcher matcher(matching::cvNorm(query.descriptors));
    const cv::Mat q = toMat(query.descriptors), t = toMat(train.descriptors);
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(q, t, knn, 2);
    std::vector<cv::DMatch> kept = matching::filter(knn, {params_.ratio, params_.max_distance});
    if (params_.cross_check) {
      std::vector<cv::DMatch> reverse;
      matcher.match(t, q, reverse);
      std::vector<int> train_best(train.size(), -1);
      for (const cv::DMatch& m : reverse) train_best[m.queryIdx] = m.trainIdx;
      kept = matching::mutual(kept, train_best);
    }
    matching::publish(std::move(kept), query, train, out);
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(FeaturesMatching2DBruteForceHamming);

}  // namespace cdff::dfn
