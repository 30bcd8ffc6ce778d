#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "StereoMatching.gen.hpp"
#include "stereo_matching_common.hpp"

namespace cdff::dfn {

class StereoMatchingBm final : public StereoMatchingBmBase {
 protected:
  Status onConfigure() override {
    CDFF_RETURN_IF_ERROR(stereo_matching::checkParameters(params_));
    matcher_ = cv::StereoBM::create(16, params_.block_size);
    return Status::ok();
  }

  Status onProcess() override {
    const StereoImagePair& pair = *in.rectified;
    Result<stereo_matching::Search> search = stereo_matching::prepare(
        pair, params_.min_depth, params_.max_depth, params_.pyramid_level, params_.block_size);
    if (!search) return search.status();
    cv::Mat left = stereo_matching::pyramidLevel(pair.left, params_.pyramid_level);
    cv::Mat right = stereo_matching::pyramidLevel(pair.right, params_.pyramid_level);
    if (left.channels() == 3) {  // StereoBM matches grey images only
      cv::cvtColor(left, left_grey_, cv::COLOR_BGR2GRAY);
      cv::cvtColor(right, right_grey_, cv::COLOR_BGR2GRAY);
      left = left_grey_;
      right = right_grey_;
    }
    stereo_matching::setSearchAndFilters(*matcher_, *search, params_);
    matcher_->setUniquenessRatio(params_.uniqueness_ratio);
    matcher_->setPreFilterCap(params_.pre_filter_cap);
    matcher_->setTextureThreshold(params_.texture_threshold);
    cv::Mat fixed_point;
    matcher_->compute(left, right, fixed_point);
    Result<double> published = stereo_matching::publish(fixed_point, *search, pair.left, out);
    return published.status();
  }

 private:
  cv::Ptr<cv::StereoBM> matcher_;
  cv::Mat left_grey_, right_grey_;
};

CDFF_REGISTER_DFI(StereoMatchingBm);

}  // namespace cdff::dfn
