// TemplateMatching/Ecc: OpenCV's enhanced correlation coefficient maximisation.
#include <opencv2/video/tracking.hpp>

#include "TemplateMatching.gen.hpp"
#include "template_track.hpp"

namespace cdff::dfn {
namespace tm = template_matching;

namespace {

/// cv::findTransformECC from the coarse warp: translation for a template too small to see scale,
/// affine otherwise (OpenCV has no similarity motion). Its warp maps template pixels to the
/// level's pixels, as ours does.
std::optional<Eigen::Matrix3d> refineEcc(const tm::Crop& crop, int level, const tm::Template& t,
                                         const Eigen::Matrix3d& start, const tm::Settings& s) {
  const Eigen::Matrix3d to_level = crop.imageToLevel(level);
  const Eigen::Matrix3d m = to_level * start;
  cv::Mat warp(2, 3, CV_32F);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) warp.at<float>(i, j) = static_cast<float>(m(i, j) / m(2, 2));
  const int motion = t.estimates_scale ? cv::MOTION_AFFINE : cv::MOTION_TRANSLATION;
  try {
    cv::findTransformECC(
        t.pixels, crop.levels[static_cast<std::size_t>(level)], warp, motion,
        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, s.max_iterations, 1e-4),
        cv::noArray(), 1);
  } catch (const cv::Exception&) {
    return std::nullopt;  // did not converge, or the warp left the image
  }
  Eigen::Matrix3d refined = Eigen::Matrix3d::Identity();
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) refined(i, j) = warp.at<float>(i, j);
  return to_level.inverse() * refined;
}

}  // namespace

class TemplateMatchingEcc final : public TemplateMatchingEccBase {
 protected:
  Status onConfigure() override {
    track_.reset();  // new parameters wait for a new designation
    return Status::ok();
  }

  Status onProcess() override {
    return tm::processStep(in, out, tm::settingsOf(params_), track_, refineEcc);
  }

 private:
  std::optional<tm::Template> track_;
};
CDFF_REGISTER_DFI(TemplateMatchingEcc);

}  // namespace cdff::dfn
