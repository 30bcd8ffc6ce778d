#include "fundamental_common.hpp"

namespace cdff::dfn {

class FundamentalMatrixEstimationMagsac final : public FundamentalMatrixEstimationMagsacBase {
 protected:
  Status onProcess() override {
    return fundamental::estimate(
        *in.correspondences, fundamental::settings(params_, cv::USAC_MAGSAC, "MAGSAC", false), out);
  }
};

CDFF_REGISTER_DFI(FundamentalMatrixEstimationMagsac);

}  // namespace cdff::dfn
