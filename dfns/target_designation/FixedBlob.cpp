// TargetDesignation/FixedBlob: a user's designation, or the brightest blob that stays put while
// others move.
#include <algorithm>
#include <cmath>
#include <deque>

#include <opencv2/imgproc.hpp>

#include "TargetDesignation.gen.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn {
namespace {

struct Blob {
  Eigen::Vector2d centroid;
  double flux = 0;
  cv::Rect box;
};

/// The blobs of `image` above its median by min_snr deviations, brightest first.
std::vector<Blob> blobsOf(const Image& image, double min_snr, int max_area) {
  cv::Mat grey = toMat(image);
  if (grey.channels() == 3) cv::cvtColor(grey, grey, cv::COLOR_BGR2GRAY);
  cv::Mat f;
  grey.convertTo(f, CV_32F);
  // Median and deviation from a sparse sample (every 7th pixel): the sky dominates it.
  std::vector<float> sample;
  for (int y = 0; y < f.rows; y += 7)
    for (int x = 0; x < f.cols; x += 7) sample.push_back(f.at<float>(y, x));
  auto mid = sample.begin() + static_cast<std::ptrdiff_t>(sample.size() / 2);
  std::nth_element(sample.begin(), mid, sample.end());
  const float median = *mid;
  for (float& v : sample) v = std::abs(v - median);
  std::nth_element(sample.begin(), mid, sample.end());
  const double threshold = median + min_snr * std::max(1.4826 * *mid, 1.0);
  cv::Mat mask = f > threshold, labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<Blob> blobs(static_cast<std::size_t>(std::max(0, n - 1)));
  for (int y = 0; y < f.rows; ++y)
    for (int x = 0; x < f.cols; ++x)
      if (const int l = labels.at<int>(y, x); l > 0) {
        Blob& b = blobs[static_cast<std::size_t>(l - 1)];
        const double w = f.at<float>(y, x) - median;
        b.flux += w;
        b.centroid += w * Eigen::Vector2d(x, y);
      }
  std::vector<Blob> out;
  for (int l = 1; l < n; ++l) {
    Blob b = blobs[static_cast<std::size_t>(l - 1)];
    if (stats.at<int>(l, cv::CC_STAT_AREA) > max_area || b.flux <= 0) continue;
    b.centroid /= b.flux;
    b.box = {stats.at<int>(l, cv::CC_STAT_LEFT), stats.at<int>(l, cv::CC_STAT_TOP),
             stats.at<int>(l, cv::CC_STAT_WIDTH), stats.at<int>(l, cv::CC_STAT_HEIGHT)};
    // A blob cut by the image's edge (the Earth's limb, a body entering the field) is not whole:
    // its centroid is not an object's.
    if (b.box.x == 0 || b.box.y == 0 || b.box.x + b.box.width == f.cols ||
        b.box.y + b.box.height == f.rows)
      continue;
    out.push_back(b);
  }
  std::sort(out.begin(), out.end(), [](const Blob& a, const Blob& b) { return a.flux > b.flux; });
  return out;
}

}  // namespace

class TargetDesignationFixedBlob final : public TargetDesignationFixedBlobBase {
 protected:
  Status onConfigure() override {
    history_.clear();
    return Status::ok();
  }

  Status onProcess() override {
    const Image& image = *in.image;
    CDFF_RETURN_IF_ERROR(image.validate(
        "input 'image'", {PixelFormat::kGray8, PixelFormat::kBgr8, PixelFormat::kGray16}));
    if (in.user.isFresh()) {
      CDFF_RETURN_IF_ERROR(in.user->validate().withContext("input 'user'"));
      ImageRegion d = *in.user;
      d.stamp = image.stamp;
      d.frame_id = image.frame_id;
      d.source = "user";
      out.designation.set(std::move(d));
      history_.clear();
      return Status::ok();
    }
    const TrackState* state = in.track_state.get();
    if (!params_.automatic ||
        (state && *state != TrackState::kUninitialised && *state != TrackState::kLost)) {
      history_.clear();
      return Status::ok();
    }
    history_.push_back(blobsOf(image, params_.min_snr, params_.max_blob_area));
    while (static_cast<int>(history_.size()) > params_.frames) history_.pop_front();
    if (static_cast<int>(history_.size()) < params_.frames) return Status::ok();
    if (std::optional<ImageRegion> d = decide(image)) out.designation.set(std::move(*d));
    return Status::ok();
  }

 private:
  /// The brightest blob of the latest image that was within max_motion of a blob in each earlier
  /// image, provided another blob moved or there is no other blob.
  std::optional<ImageRegion> decide(const Image& image) {
    const std::vector<Blob>& now = history_.back();
    auto fixedIn = [&](const Blob& b, const std::vector<Blob>& frame) {
      return std::any_of(frame.begin(), frame.end(), [&](const Blob& o) {
        return (o.centroid - b.centroid).norm() <= params_.max_motion;
      });
    };
    std::vector<const Blob*> fixed;
    int moved = 0;
    for (const Blob& b : now) {
      bool stayed = true;
      for (std::size_t k = 0; k + 1 < history_.size() && stayed; ++k)
        stayed = fixedIn(b, history_[k]);
      if (stayed)
        fixed.push_back(&b);
      else
        ++moved;
    }
    if (fixed.empty() || (moved == 0 && now.size() > 1)) return std::nullopt;
    // The brightest fixed blob whose box, with its margin, lies in the image (the matcher takes
    // its template there; a target at the edge is designated once it is further in).
    std::optional<ImageRegion> region;
    for (const Blob* b : fixed) {
      const int side =
          static_cast<int>(std::ceil(std::max(b->box.width, b->box.height) + 2 * params_.margin));
      const double x = b->centroid.x() - 0.5 * (side - 1), y = b->centroid.y() - 0.5 * (side - 1);
      if (x >= 0 && y >= 0 && x + side <= image.width && y + side <= image.height) {
        region = ImageRegion::box(x, y, side, side);
        break;
      }
    }
    if (!region) return std::nullopt;
    ImageRegion& d = *region;
    d.stamp = image.stamp;
    d.frame_id = image.frame_id;
    d.source = "automatic";
    // The centroid's uncertainty: a few tenths of a pixel for a blob of a few pixels.
    d.covariance = 0.25 * Eigen::Matrix2d::Identity();
    history_.clear();
    return region;
  }

  std::deque<std::vector<Blob>> history_;
};
CDFF_REGISTER_DFI(TargetDesignationFixedBlob);

}  // namespace cdff::dfn
