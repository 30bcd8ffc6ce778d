#include "pnp_common.hpp"

namespace cdff::dfn {

class PerspectiveNPointSqpnpRansac final : public PerspectiveNPointSqpnpRansacBase {
 protected:
  Status onProcess() override {
    return pnp::estimate(*in.correspondences, *in.camera, params_, cv::SOLVEPNP_SQPNP, "SQPnP",
                         out);
  }
};

CDFF_REGISTER_DFI(PerspectiveNPointSqpnpRansac);

}  // namespace cdff::dfn
