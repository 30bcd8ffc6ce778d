#include <opencv2/flann.hpp>

#include "matching_common.hpp"

namespace cdff::dfn {

class FeaturesMatching2DFlannLsh final : public FeaturesMatching2DFlannLshBase {
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
    if (query.descriptors.distance == DescriptorMatrix::Distance::kHamming2)
      return invalidInput(
          "inputs have Hamming-2 descriptors (ORB with wta_k 3 or 4); expected "
          "plain binary descriptors: FLANN's LSH index only hashes single bits, "
          "use BruteForceHamming");
    const cv::Mat q = toMat(query.descriptors), t = toMat(train.descriptors);
    std::vector<std::vector<cv::DMatch>> knn = search(q, t);
    std::vector<cv::DMatch> kept = matching::filter(knn, {params_.ratio, params_.max_distance});
    if (params_.cross_check) {
      std::vector<int> train_best(train.size(), -1);
      for (const auto& candidates : search(t, q))
        if (!candidates.empty()) train_best[candidates[0].queryIdx] = candidates[0].trainIdx;
      kept = matching::mutual(kept, train_best);
    }
    matching::publish(std::move(kept), query, train, out);
    return Status::ok();
  }

 private:
  // The LSH index is built over `indexed` for every call: the train set of a tracker changes with
  // each keyframe, and building costs about as much as one query pass.
  std::vector<std::vector<cv::DMatch>> search(const cv::Mat& queries, const cv::Mat& indexed) {
    cv::FlannBasedMatcher matcher(cv::makePtr<cv::flann::LshIndexParams>(
                                      params_.tables, params_.key_bits, params_.multi_probe_level),
                                  cv::makePtr<cv::flann::SearchParams>());
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(queries, indexed, knn, 2);
    return knn;
  }
};

CDFF_REGISTER_DFI(FeaturesMatching2DFlannLsh);

}  // namespace cdff::dfn
