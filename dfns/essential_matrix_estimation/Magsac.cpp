#include "essential_common.hpp"

namespace cdff::dfn {

class EssentialMatrixEstimationMagsac final : public EssentialMatrixEstimationMagsacBase {
 protected:
  Status onProcess() override {
    const CameraModel& second = in.second_camera.hasValue() ? *in.second_camera : *in.camera;
    return essential::estimate(*in.correspondences, *in.camera, second,
                               essential::settings(params_, cv::USAC_MAGSAC, "MAGSAC", false), out);
  }
};

CDFF_REGISTER_DFI(EssentialMatrixEstimationMagsac);

}  // namespace cdff::dfn
