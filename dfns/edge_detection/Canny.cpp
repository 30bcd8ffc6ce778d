#include <opencv2/imgproc.hpp>

#include "EdgeDetection.gen.hpp"
#include "cdff/types/opencv.hpp"
#include "edge_common.hpp"

namespace cdff::dfn {

class EdgeDetectionCanny final : public EdgeDetectionCannyBase {
 protected:
  Status onConfigure() override {
    if (params_.high_threshold < params_.low_threshold)
      return invalidParameter(
          "{}: high_threshold ({}) is below low_threshold ({}); expected "
          "high_threshold >= low_threshold",
          name(), params_.high_threshold, params_.low_threshold);
    if (params_.aperture_size % 2 == 0)
      return invalidParameter("{}: aperture_size is {}; expected 3, 5 or 7", name(),
                              params_.aperture_size);
    return Status::ok();
  }

  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(
        in.image->validate("input 'image'", {PixelFormat::kGray8, PixelFormat::kBgr8}));
    const cv::Mat gray = edge::toGray(*in.image);
    cv::Mat edges;
    cv::Canny(gray, edges, params_.low_threshold, params_.high_threshold, params_.aperture_size,
              params_.l2_gradient);
    return edge::publish(*in.image, edges, out.edges, out.edge_fraction);
  }
};

CDFF_REGISTER_DFI(EdgeDetectionCanny);

}  // namespace cdff::dfn
