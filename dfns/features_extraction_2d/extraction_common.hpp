#pragma once
// What the FeaturesExtraction2D DFIs share: input checks, grey conversion, the budget and
// publishing. A DFI only says how it detects and describes (Extractor::detect).

#include <algorithm>
#include <numeric>
#include <string>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "FeaturesExtraction2D.gen.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn::extraction {

/// The grey image and the mask (empty when none) that the detectors run on.
struct PreparedInput {
  cv::Mat gray;
  cv::Mat mask;
};

inline Result<PreparedInput> prepare(const FeaturesExtraction2D::Inputs& in) {
  CDFF_RETURN_IF_ERROR(
      in.image->validate("input 'image'", {PixelFormat::kGray8, PixelFormat::kBgr8}));
  PreparedInput prepared;
  const cv::Mat image = toMat(*in.image);
  if (in.image->format == PixelFormat::kGray8)
    prepared.gray = image;
  else
    cv::cvtColor(image, prepared.gray, cv::COLOR_BGR2GRAY);
  if (in.mask.hasValue()) {
    const Image& mask = *in.mask;
    CDFF_RETURN_IF_ERROR(mask.validate("input 'mask'", {PixelFormat::kGray8}));
    if (mask.width != in.image->width || mask.height != in.image->height)
      return invalidInput("input 'mask' is {}x{}; expected the image's size {}x{}", mask.width,
                          mask.height, in.image->width, in.image->height);
    prepared.mask = toMat(mask);
  }
  return prepared;
}

/// Keeps the `max_features` strongest keypoints (and their descriptor rows), strongest first.
inline Status publish(const Image& image, const std::vector<cv::KeyPoint>& keypoints,
                      const cv::Mat& descriptors, DescriptorMatrix::Distance distance,
                      int max_features, OutputPort<Features2D>& out) {
  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return keypoints[a].response > keypoints[b].response; });
  if (order.size() > static_cast<std::size_t>(max_features)) order.resize(max_features);

  std::vector<cv::KeyPoint> kept;
  kept.reserve(order.size());
  cv::Mat kept_descriptors(static_cast<int>(order.size()), descriptors.cols, descriptors.type());
  for (std::size_t i = 0; i < order.size(); ++i) {
    kept.push_back(keypoints[order[i]]);
    descriptors.row(order[i]).copyTo(kept_descriptors.row(static_cast<int>(i)));
  }

  Features2D features;
  features.stamp = image.stamp;
  features.frame_id = image.frame_id;
  features.keypoints = fromCvKeypoints(kept);
  if (!kept.empty()) {
    Result<DescriptorMatrix> d = descriptorsFromMat(kept_descriptors);
    if (!d) return d.status();
    features.descriptors = std::move(d).value();
    features.descriptors.distance = distance;
  }
  out.set(std::move(features));
  return Status::ok();
}

/// The process() of every extractor DFI; `GeneratedBase` is the DFI's generated base class.
template <typename GeneratedBase>
class Extractor : public GeneratedBase {
 protected:
  struct Detection {
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    DescriptorMatrix::Distance distance = DescriptorMatrix::Distance::kHamming;
  };
  virtual Detection detect(const PreparedInput& input) = 0;
  /// The setting that most decides how many features are found, for the "none found" warning.
  virtual std::string sensitivity() const = 0;

  Status onProcess() override {
    Result<PreparedInput> input = prepare(this->in);
    if (!input) return input.status();
    const Detection found = detect(*input);
    if (found.keypoints.empty())
      this->warn(fmt::format("no feature found in the {}x{} image ({})", this->in.image->width,
                             this->in.image->height, sensitivity()));
    return publish(*this->in.image, found.keypoints, found.descriptors, found.distance,
                   this->params_.max_features, this->out.features);
  }
};

}  // namespace cdff::dfn::extraction
