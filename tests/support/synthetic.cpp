#include "support/synthetic.hpp"

#include <opencv2/imgproc.hpp>

#include "cdff/types/opencv.hpp"

namespace cdff::testing {

cv::Mat texturedScene(int width, int height, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(0, width - 1), y(0, height - 1), grey(20, 235);
  std::uniform_int_distribution<int> radius(3, std::max(4, std::min(width, height) / 12));
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(128));
  const int shapes = width * height / 2000 + 20;
  for (int i = 0; i < shapes; ++i) {
    const cv::Point c(x(rng), y(rng));
    switch (i % 3) {
      case 0:
        cv::circle(image, c, radius(rng), cv::Scalar(grey(rng)), cv::FILLED);
        break;
      case 1:
        cv::rectangle(image, cv::Rect(c, cv::Size(radius(rng) * 2, radius(rng))),
                      cv::Scalar(grey(rng)), cv::FILLED);
        break;
      default:
        cv::line(image, c, cv::Point(x(rng), y(rng)), cv::Scalar(grey(rng)), 2);
    }
  }
  return image;
}

cv::Mat rectangleImage(int width, int height, const cv::Rect& rect) {
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(0));
  cv::rectangle(image, rect, cv::Scalar(200), cv::FILLED);
  return image;
}

CameraModel pinholeCamera(int width, int height, double f) {
  CameraModel camera;
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = f;
  camera.cx = (width - 1) / 2.0;
  camera.cy = (height - 1) / 2.0;
  return camera;
}

Image toImage(const cv::Mat& mat, Timestamp stamp) {
  Result<Image> image = fromMat(mat, stamp, "camera");
  EXPECT_TRUE(image.isOk()) << image.status().toString();
  return image.value();
}

}  // namespace cdff::testing
