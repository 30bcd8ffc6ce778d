#pragma once
// Shared by the FeaturesMatching3D DFIs: input checks and the ratio / distance / mutual tests,
// which do not depend on how the nearest neighbours were found.

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "FeaturesMatching3D.gen.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn::matching3d {

/// One candidate of a nearest-neighbour search: a row of the searched set and its L2 distance.
struct Candidate {
  int index = -1;
  float distance = 0;
};
/// The candidates of each query row, nearest first.
using Neighbours = std::vector<std::vector<Candidate>>;

/// Ok when every descriptor value of `f` is finite; the error names the port, row, column and
/// value (a NaN would make every distance NaN, and the search silently pick an arbitrary row).
inline Status checkFinite(const Features3D& f, const char* port) {
  const int cols = f.descriptors.cols;
  for (int r = 0; r < f.descriptors.rows; ++r) {
    const auto* row = reinterpret_cast<const float*>(f.descriptors.row(r));
    for (int c = 0; c < cols; ++c)
      if (!std::isfinite(row[c]))
        return invalidInput(
            "input '{}' descriptor row {} has value {} at column {}; expected finite values", port,
            r, row[c], c);
  }
  return Status::ok();
}

/// Checks both sets; returns false (and no error) when either is empty and there is nothing to
/// match.
inline Result<bool> validate(const Features3D& query, const Features3D& train) {
  CDFF_RETURN_IF_ERROR(query.validate("input 'query'"));
  CDFF_RETURN_IF_ERROR(train.validate("input 'train'"));
  if (query.size() == 0 || train.size() == 0) return false;
  using Named = std::pair<const char*, const Features3D*>;
  for (const auto& [port, f] : {Named{"query", &query}, Named{"train", &train}}) {
    if (f->descriptors.empty())
      return invalidInput(
          "input '{}' has {} keypoints but no descriptors; expected one float32 descriptor "
          "per keypoint",
          port, f->size());
    if (f->descriptors.element != DescriptorMatrix::Element::kFloat32)
      return invalidInput(
          "input '{}' has binary (uint8) descriptors; expected float32 descriptors compared "
          "with the L2 distance (SHOT, FPFH); binary ones are matched by FeaturesMatching2D",
          port);
  }
  if (query.descriptors.cols != train.descriptors.cols)
    return invalidInput(
        "inputs 'query' and 'train' have descriptors of {} and {} values; expected the same "
        "kind and length on both sides (SHOT: 352, FPFH: 33)",
        query.descriptors.cols, train.descriptors.cols);
  CDFF_RETURN_IF_ERROR(checkFinite(query, "query"));
  CDFF_RETURN_IF_ERROR(checkFinite(train, "train"));
  return true;
}

/// The best candidate of each query when it passes the ratio and distance tests.
inline std::vector<Match> filter(const Neighbours& knn, double ratio, double max_distance) {
  std::vector<Match> kept;
  for (std::size_t q = 0; q < knn.size(); ++q) {
    const std::vector<Candidate>& candidates = knn[q];
    if (candidates.empty()) continue;
    const Candidate& best = candidates[0];
    if (best.distance > max_distance) continue;
    // A lone candidate (a train set of one feature) has no rival: it counts as distinctive.
    if (ratio < 1.0 && candidates.size() >= 2 && best.distance >= ratio * candidates[1].distance)
      continue;
    kept.push_back({static_cast<int>(q), best.index, best.distance});
  }
  return kept;
}

inline void publish(std::vector<Match> matches, const Features3D& query, const Features3D& train,
                    FeaturesMatching3D::Outputs& out) {
  std::stable_sort(matches.begin(), matches.end(),
                   [](const Match& a, const Match& b) { return a.distance < b.distance; });
  Correspondences3D points;
  points.first.reserve(matches.size());
  points.second.reserve(matches.size());
  for (const Match& m : matches) {
    points.first.push_back(query.keypoints[m.query].position.cast<double>());
    points.second.push_back(train.keypoints[m.train].position.cast<double>());
  }
  Matches pairs;
  pairs.matches = std::move(matches);
  out.matches.set(std::move(pairs));
  out.correspondences.set(std::move(points));
}

/// The process() of every matcher DFI: checks, ratio and distance tests, cross-check and
/// publishing; a DFI only says how it finds nearest neighbours (Matcher::nearest).
template <typename GeneratedBase>
class Matcher : public GeneratedBase {
 protected:
  /// The k nearest rows of `searched` (L2) for each row of `queries`, nearest first (fewer when
  /// `searched` has fewer rows). Both are CV_32F with the same number of columns.
  virtual Result<Neighbours> nearest(const cv::Mat& queries, const cv::Mat& searched, int k) = 0;

  Status onProcess() override {
    const Features3D& query = *this->in.query;
    const Features3D& train = *this->in.train;
    Result<bool> matchable = validate(query, train);
    if (!matchable) return matchable.status();
    if (!*matchable) {
      this->warn(fmt::format("nothing to match: {} query and {} train features", query.size(),
                             train.size()));
      publish({}, query, train, this->out);
      return Status::ok();
    }
    const cv::Mat q = toMat(query.descriptors), t = toMat(train.descriptors);
    Result<Neighbours> knn = nearest(q, t, 2);
    if (!knn) return knn.status();
    std::vector<Match> kept = filter(*knn, this->params_.ratio, this->params_.max_distance);
    if (this->params_.cross_check && !kept.empty()) {
      // A match survives when the query feature is also its train feature's nearest neighbour.
      Result<Neighbours> reverse = nearest(t, q, 1);
      if (!reverse) return reverse.status();
      std::vector<int> train_best(train.size(), -1);
      for (std::size_t r = 0; r < reverse->size(); ++r)
        if (!(*reverse)[r].empty()) train_best[r] = (*reverse)[r][0].index;
      std::erase_if(kept, [&](const Match& m) { return train_best[m.train] != m.query; });
    }
    publish(std::move(kept), query, train, this->out);
    return Status::ok();
  }
};

}  // namespace cdff::dfn::matching3d
