#pragma once
// Shared by the FeaturesMatching2D DFIs: input checks and the ratio / distance / mutual tests,
// which do not depend on how the nearest neighbours were found.

#include <algorithm>

#include <opencv2/features2d.hpp>

#include "FeaturesMatching2D.gen.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn::matching {

/// Checks both sets; returns false (and no error) when either is empty and there is nothing to
/// match.
inline Result<bool> validate(const Features2D& query, const Features2D& train) {
  CDFF_RETURN_IF_ERROR(query.validate("input 'query'"));
  CDFF_RETURN_IF_ERROR(train.validate("input 'train'"));
  if (query.size() == 0 || train.size() == 0) return false;
  using Named = std::pair<const char*, const Features2D*>;
  for (const auto& [what, f] : {Named{"query", &query}, Named{"train", &train}}) {
    if (f->descriptors.empty())
      return invalidInput(
          "input '{}' has {} keypoints but no descriptors; expected one binary "
          "descriptor per keypoint",
          what, f->size());
    if (f->descriptors.element != DescriptorMatrix::Element::kUint8)
      return invalidInput(
          "input '{}' has float32 descriptors; expected binary (uint8) "
          "descriptors, compared with the Hamming distance",
          what);
  }
  if (query.descriptors.cols != train.descriptors.cols ||
      query.descriptors.distance != train.descriptors.distance)
    return invalidInput(
        "inputs 'query' and 'train' have descriptors of {} and {} bytes ({} and "
        "{}); expected the same kind and length on both sides",
        query.descriptors.cols, train.descriptors.cols,
        query.descriptors.distance == DescriptorMatrix::Distance::kHamming2 ? "Hamming-2"
                                                                            : "Hamming",
        train.descriptors.distance == DescriptorMatrix::Distance::kHamming2 ? "Hamming-2"
                                                                            : "Hamming");
  return true;
}

inline int cvNorm(const DescriptorMatrix& d) {
  return d.distance == DescriptorMatrix::Distance::kHamming2 ? cv::NORM_HAMMING2 : cv::NORM_HAMMING;
}

struct Criteria {
  double ratio;
  double max_distance;
};

/// The best candidate of each query when it passes the ratio and distance tests (-1 otherwise).
inline std::vector<cv::DMatch> filter(const std::vector<std::vector<cv::DMatch>>& knn,
                                      const Criteria& criteria) {
  std::vector<cv::DMatch> kept;
  for (const auto& candidates : knn) {
    if (candidates.empty()) continue;
    const cv::DMatch& best = candidates[0];
    if (best.distance > criteria.max_distance) continue;
    // A lone candidate (a train set of one feature, or an LSH probe that found nothing else
    // nearby) has no rival within reach: it counts as distinctive.
    if (criteria.ratio < 1.0 && candidates.size() >= 2 &&
        best.distance >= criteria.ratio * candidates[1].distance)
      continue;
    kept.push_back(best);
  }
  return kept;
}

inline void publish(std::vector<cv::DMatch> matches, const Features2D& query,
                    const Features2D& train, FeaturesMatching2D::Outputs& out) {
  std::stable_sort(matches.begin(), matches.end(), [](const cv::DMatch& a, const cv::DMatch& b) {
    return a.distance < b.distance;
  });
  Matches pairs;
  Correspondences2D points;
  pairs.matches.reserve(matches.size());
  points.first.reserve(matches.size());
  points.second.reserve(matches.size());
  for (const cv::DMatch& m : matches) {
    pairs.matches.push_back({m.queryIdx, m.trainIdx, m.distance});
    points.first.push_back(query.keypoints[m.queryIdx].position.cast<double>());
    points.second.push_back(train.keypoints[m.trainIdx].position.cast<double>());
  }
  out.matches.set(std::move(pairs));
  out.correspondences.set(std::move(points));
}

/// The process() of every matcher DFI: checks, ratio and distance tests, cross-check and
/// publishing; a DFI only says how it finds nearest neighbours (Matcher::nearest).
template <typename GeneratedBase>
class Matcher : public GeneratedBase {
 protected:
  /// The k nearest rows of `indexed` for each row of `queries`, nearest first (fewer when the
  /// search finds fewer).
  virtual std::vector<std::vector<cv::DMatch>> nearest(const cv::Mat& queries,
                                                       const cv::Mat& indexed, int norm, int k) = 0;
  /// Ok when this DFI can compare such descriptors.
  virtual Status supports(const DescriptorMatrix&) const { return Status::ok(); }

  Status onProcess() override {
    const Features2D& query = *this->in.query;
    const Features2D& train = *this->in.train;
    Result<bool> matchable = validate(query, train);
    if (!matchable) return matchable.status();
    if (!*matchable) {
      this->warn(fmt::format("nothing to match: {} query and {} train features", query.size(),
                             train.size()));
      publish({}, query, train, this->out);
      return Status::ok();
    }
    CDFF_RETURN_IF_ERROR(supports(query.descriptors));
    const cv::Mat q = toMat(query.descriptors), t = toMat(train.descriptors);
    const int norm = cvNorm(query.descriptors);
    std::vector<cv::DMatch> kept =
        filter(nearest(q, t, norm, 2), {this->params_.ratio, this->params_.max_distance});
    if (this->params_.cross_check) {
      // A match survives when the query feature is also its train feature's nearest neighbour.
      std::vector<int> train_best(train.size(), -1);
      for (const auto& candidates : nearest(t, q, norm, 1))
        if (!candidates.empty()) train_best[candidates[0].queryIdx] = candidates[0].trainIdx;
      std::erase_if(kept,
                    [&](const cv::DMatch& m) { return train_best[m.trainIdx] != m.queryIdx; });
    }
    publish(std::move(kept), query, train, this->out);
    return Status::ok();
  }
};

}  // namespace cdff::dfn::matching
