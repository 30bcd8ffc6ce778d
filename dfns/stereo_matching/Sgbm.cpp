#include <opencv2/calib3d.hpp>

#include "StereoMatching.gen.hpp"
#include "stereo_matching_common.hpp"

namespace cdff::dfn {

class StereoMatchingSgbm final : public StereoMatchingSgbmBase {
 protected:
  Status onConfigure() override {
    CDFF_RETURN_IF_ERROR(stereo_matching::checkParameters(params_));
    if (params_.smoothness_large > 0 && params_.smoothness_large <= params_.smoothness_small)
      return invalidParameter(
          "parameter 'smoothness_large' ({}) is not above 'smoothness_small' ({}); expected "
          "P2 > P1, or 0 for OpenCV's recommendation",
          params_.smoothness_large, params_.smoothness_small);
    matcher_ = cv::StereoSGBM::create(0, 16, params_.block_size);
    return Status::ok();
  }

  Status onProcess() override {
    const StereoImagePair& pair = *in.rectified;
    Result<stereo_matching::Search> search = stereo_matching::prepare(
        pair, params_.min_depth, params_.max_depth, params_.pyramid_level, params_.block_size);
    if (!search) return search.status();
    const cv::Mat left = stereo_matching::pyramidLevel(pair.left, params_.pyramid_level);
    const cv::Mat right = stereo_matching::pyramidLevel(pair.right, params_.pyramid_level);
    const int area = channels(pair.left.format) * params_.block_size * params_.block_size;
    stereo_matching::setSearchAndFilters(*matcher_, *search, params_);
    matcher_->setP1(params_.smoothness_small > 0 ? params_.smoothness_small : 8 * area);
    matcher_->setP2(params_.smoothness_large > 0 ? params_.smoothness_large : 32 * area);
    matcher_->setUniquenessRatio(params_.uniqueness_ratio);
    matcher_->setPreFilterCap(params_.pre_filter_cap);
    matcher_->setMode(params_.mode == "hh"          ? cv::StereoSGBM::MODE_HH
                      : params_.mode == "sgbm_3way" ? cv::StereoSGBM::MODE_SGBM_3WAY
                      : params_.mode == "hh4"       ? cv::StereoSGBM::MODE_HH4
                                                    : cv::StereoSGBM::MODE_SGBM);
    cv::Mat fixed_point;
    matcher_->compute(left, right, fixed_point);
    stereo_matching::dropUntextured(fixed_point, left, params_.block_size, params_.min_texture);
    Result<double> published = stereo_matching::publish(fixed_point, *search, pair.left, out);
    return published.status();
  }

 private:
  cv::Ptr<cv::StereoSGBM> matcher_;
};

CDFF_REGISTER_DFI(StereoMatchingSgbm);

}  // namespace cdff::dfn
