#include "fundamental_common.hpp"

namespace cdff::dfn {

class FundamentalMatrixEstimationRansac final : public FundamentalMatrixEstimationRansacBase {
 protected:
  Status onProcess() override {
    return fundamental::estimate(
        *in.correspondences, fundamental::settings(params_, cv::FM_RANSAC, "RANSAC", true), out);
  }
};

CDFF_REGISTER_DFI(FundamentalMatrixEstimationRansac);

}  // namespace cdff::dfn
