#include "essential_common.hpp"

namespace cdff::dfn {

class EssentialMatrixEstimationRansac final : public EssentialMatrixEstimationRansacBase {
 protected:
  Status onProcess() override {
    const CameraModel& second = in.second_camera.hasValue() ? *in.second_camera : *in.camera;
    return essential::estimate(*in.correspondences, *in.camera, second,
                               essential::settings(params_, cv::RANSAC, "RANSAC", true), out);
  }
};

CDFF_REGISTER_DFI(EssentialMatrixEstimationRansac);

}  // namespace cdff::dfn
