#include "pnp_common.hpp"

namespace cdff::dfn {

class PerspectiveNPointEpnpRansac final : public PerspectiveNPointEpnpRansacBase {
 protected:
  Status onProcess() override {
    return pnp::estimate(*in.correspondences, *in.camera, params_, cv::SOLVEPNP_EPNP, "EPnP", out);
  }
};

CDFF_REGISTER_DFI(PerspectiveNPointEpnpRansac);

}  // namespace cdff::dfn
