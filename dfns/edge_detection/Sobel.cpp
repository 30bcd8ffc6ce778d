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
    cv::Mat dx, dy;
    if (params_.kernel == "scharr") {
      cv::Scharr(gray, dx, CV_32F, 1, 0);
      cv::Scharr(gray, dy, CV_32F, 0, 1);
    } else {
      const int size = params_.kernel == "sobel5" ? 5 : 3;
      cv::Sobel(gray, dx, CV_32F, 1, 0, size);
      cv::Sobel(gray, dy, CV_32F, 0, 1, size);
    }
    cv::Mat magnitude;
    cv::magnitude(dx, dy, magnitude);
    cv::Mat edges;
    cv::threshold(magnitude, edges, params_.threshold, 255.0, cv::THRESH_BINARY);
    edges.convertTo(edges, CV_8U);
    return edge::publish(*in.image, edges, out.edges, out.edge_fraction);
  }
};

CDFF_REGISTER_DFI(EdgeDetectionSobel);

}  // namespace cdff::dfn
