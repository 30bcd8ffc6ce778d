#pragma once
// Shared by the EdgeDetection DFIs: grey conversion and publishing the edge map.

#include <opencv2/imgproc.hpp>

#include "cdff/dfn/port.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn::edge {

inline cv::Mat toGray(const Image& image) {
  cv::Mat mat = toMat(image);
  if (image.format == PixelFormat::kGray8) return mat;
  cv::Mat gray;
  cv::cvtColor(mat, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

inline Status publish(const Image& input, const cv::Mat& edges, OutputPort<Image>& edges_out,
                      OutputPort<double>& fraction_out) {
  Result<Image> image = fromMat(edges, input.stamp, input.frame_id);
  if (!image) return image.status();
  image->camera = input.camera;
  const double fraction =
      static_cast<double>(cv::countNonZero(edges)) / static_cast<double>(edges.total());
  edges_out.set(std::move(image).value());
  fraction_out.set(fraction);
  return Status::ok();
}

}  // namespace cdff::dfn::edge
