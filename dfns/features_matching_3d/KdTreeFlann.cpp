#include <cmath>

#include <opencv2/flann.hpp>

#include "matching3d_common.hpp"

namespace cdff::dfn {

class FeaturesMatching3DKdTreeFlann final
    : public matching3d::Matcher<FeaturesMatching3DKdTreeFlannBase> {
 protected:
  // The index is built over `searched` on every call: a DFN keeps no state between calls, and
  // building the trees costs less than searching them.
  Result<matching3d::Neighbours> nearest(const cv::Mat& queries, const cv::Mat& searched,
                                         int k) override {
    const int found = std::min(k, searched.rows);
    cv::Mat indices, squared_distances;
    try {
      cv::flann::Index index(searched, cv::flann::KDTreeIndexParams(params_.trees),
                             cvflann::FLANN_DIST_L2);
      index.knnSearch(queries, indices, squared_distances, found,
                      cv::flann::SearchParams(params_.checks));
    } catch (const cv::Exception& e) {
      return numericalFailure("FLANN k-d tree search failed: {}", e.what());
    }
    matching3d::Neighbours neighbours(queries.rows);
    for (int q = 0; q < queries.rows; ++q) {
      for (int j = 0; j < found; ++j) {
        const int row = indices.at<int>(q, j);
        if (row < 0 || row >= searched.rows) continue;  // fewer leaves reached than asked for
        // FLANN's L2 is the squared distance; matches report the distance itself.
        neighbours[q].push_back({row, std::sqrt(squared_distances.at<float>(q, j))});
      }
    }
    return neighbours;
  }
};

CDFF_REGISTER_DFI(FeaturesMatching3DKdTreeFlann);

}  // namespace cdff::dfn
