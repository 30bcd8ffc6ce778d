#include <opencv2/imgproc.hpp>

#include "EdgeDetection.gen.hpp"
#include "cdff/types/opencv.hpp"
#include "edge_common.hpp"

namespace cdff::dfn {

class EdgeDetectionSobel final : public EdgeDetectionSobelBase {
 protected:
  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(
        in.image->validate("input 'image'", {PixelFormat::kGray8, PixelFormat::kBgr8}));
    const cv::Mat gray = edge::toGray(*in.image);
    if (params_.kernel == "scharr") {
      cv::Scharr(gray, dx_, CV_32F, 1, 0);
      cv::Scharr(gray, dy_, CV_32F, 0, 1);
    } else {
      const int size = params_.kernel == "sobel5" ? 5 : 3;
      cv::Sobel(gray, dx_, CV_32F, 1, 0, size);
      cv::Sobel(gray, dy_, CV_32F, 0, 1, size);
    }
    cv::magnitude(dx_, dy_, magnitude_);
    // The edge map is handed downstream and shared, so it is the only fresh allocation.
    cv::Mat edges;
    cv::compare(magnitude_, params_.threshold, edges, cv::CMP_GT);
    return edge::publish(*in.image, edges, out.edges, out.edge_fraction);
  }

 private:
  // Scratch buffers kept between calls: allocating ~24 MB of fresh pages per 2 MP frame costs
  // more than the filtering itself.
  cv::Mat dx_, dy_, magnitude_;
};

CDFF_REGISTER_DFI(EdgeDetectionSobel);

}  // namespace cdff::dfn
