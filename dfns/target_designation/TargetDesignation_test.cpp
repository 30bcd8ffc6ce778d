// TargetDesignation: a far-range scene of a small bright target that stays put while ten stars
// (some brighter than the target) drift with the servicer's attitude; the automatic designation
// must pick the target, never a star, and wait while nothing moves (a star and the target cannot
// be told apart then). A user's designation passes through. Bad input: an empty or a
// floating-point image, a malformed user designation.
#include <gtest/gtest.h>

#include <random>

#include <opencv2/imgproc.hpp>

#include "TargetDesignation.gen.hpp"
#include "cdff/types/opencv.hpp"
#include "support/dfn_testing.hpp"

namespace cdff::dfn {
namespace {

/// A Gaussian spot of `sigma` px and peak `peak` at (x, y), added to `image`.
void spot(cv::Mat& image, double x, double y, double sigma, double peak) {
  for (int v = std::max(0, static_cast<int>(y) - 8);
       v < std::min(image.rows, static_cast<int>(y) + 9); ++v)
    for (int u = std::max(0, static_cast<int>(x) - 8);
         u < std::min(image.cols, static_cast<int>(x) + 9); ++u)
      image.at<float>(v, u) += static_cast<float>(
          peak * std::exp(-((u - x) * (u - x) + (v - y) * (v - y)) / (2 * sigma * sigma)));
}

class TargetDesignationTest : public ::testing::Test {
 protected:
  std::unique_ptr<TargetDesignation> dfn_ =
      testing::makeDfn<TargetDesignation>("TargetDesignation", "FixedBlob");
  std::mt19937 rng_{5};
  const Eigen::Vector2d target_{300.4, 251.7};

  /// Frame k: the target (an elongated blob, 3 x 2 px) fixed, the stars shifted by k * drift;
  /// with `limb`, the Earth's sunlit limb, brighter than everything, cut by the image's bottom
  /// edge and fixed too (the Earth below the line of sight).
  Image frame(int k, const Eigen::Vector2d& drift, bool limb = false) {
    cv::Mat f(512, 512, CV_32F, cv::Scalar(4.0f));
    std::normal_distribution<float> noise(0.0f, 1.5f);
    for (float& p : cv::Mat_<float>(f)) p += noise(rng_);
    spot(f, target_.x() - 1, target_.y(), 1.0, 90);
    spot(f, target_.x() + 1, target_.y(), 1.0, 90);
    std::mt19937 stars(99);  // the same sky every frame
    std::uniform_real_distribution<double> where(40, 470), bright(30, 200);
    for (int i = 0; i < 10; ++i) {
      const double x = where(stars) + k * drift.x(), y = where(stars) + k * drift.y();
      spot(f, x, y, 0.8, bright(stars));
    }
    if (limb) cv::ellipse(f, {256, 900}, {400, 400}, 0, 0, 360, cv::Scalar(250), cv::FILLED);
    cv::Mat bytes;
    f.convertTo(bytes, CV_8U);
    return fromMat(bytes, static_cast<Timestamp>(k) * 1'000'000, "camera_far_optical").value();
  }
};

TEST_F(TargetDesignationTest, PicksTheBlobThatStaysPutWhileTheStarsDrift) {
  for (int k = 0; k < 3; ++k) {
    dfn_->in.image.set(frame(k, {4.0, -2.5}));
    ASSERT_TRUE(dfn_->process().isOk()) << dfn_->diagnostics().last_error;
  }
  ASSERT_NE(dfn_->out.designation.get(), nullptr);
  const ImageRegion& d = *dfn_->out.designation;
  EXPECT_EQ(d.source, "automatic");
  EXPECT_LT((d.centre() - target_).norm(), 0.3);
  EXPECT_GE(d.width, 12);  // the blob and a margin
}

TEST_F(TargetDesignationTest, AFixedBlobCutByTheImageEdgeIsNotTheTarget) {
  // The limb is the brightest blob that stays put, but its centroid is not an object's: only a
  // blob whole in the image, with its designation's margin, is designated.
  for (int k = 0; k < 3; ++k) {
    dfn_->in.image.set(frame(k, {4.0, -2.5}, true));
    ASSERT_TRUE(dfn_->process().isOk()) << dfn_->diagnostics().last_error;
  }
  ASSERT_NE(dfn_->out.designation.get(), nullptr);
  EXPECT_LT((dfn_->out.designation->centre() - target_).norm(), 0.5);
}

TEST_F(TargetDesignationTest, WaitsWhileNothingMoves) {
  for (int k = 0; k < 5; ++k) {
    dfn_->in.image.set(frame(k, {0.0, 0.0}));
    ASSERT_TRUE(dfn_->process().isOk());
  }
  EXPECT_EQ(dfn_->out.designation.get(), nullptr);
}

TEST_F(TargetDesignationTest, DoesNothingWhileTheTrackIsEstablished) {
  dfn_->in.track_state.set(TrackState::kTracking);
  for (int k = 0; k < 4; ++k) {
    dfn_->in.image.set(frame(k, {4.0, -2.5}));
    ASSERT_TRUE(dfn_->process().isOk());
  }
  EXPECT_EQ(dfn_->out.designation.get(), nullptr);
}

TEST_F(TargetDesignationTest, PassesAUsersDesignationThrough) {
  dfn_->in.image.set(frame(0, {4.0, -2.5}));
  ImageRegion user = ImageRegion::box(100, 120, 20, 20);
  user.source = "whatever the interface wrote";
  dfn_->in.user.set(user);
  ASSERT_TRUE(dfn_->process().isOk());
  ASSERT_NE(dfn_->out.designation.get(), nullptr);
  EXPECT_EQ(dfn_->out.designation->source, "user");
  EXPECT_EQ(dfn_->out.designation->stamp, 0);
  EXPECT_EQ(dfn_->out.designation->frame_id, "camera_far_optical");
}

TEST_F(TargetDesignationTest, BadInput) {
  dfn_->in.image.set(Image{});
  testing::expectRejected(*dfn_, "input 'image'");
  dfn_->in.image.set(fromMat(cv::Mat(8, 8, CV_32F, cv::Scalar(1.0f)), 0, "c").value());
  testing::expectRejected(*dfn_, "input 'image'");
  dfn_->in.image.set(frame(0, {0, 0}));
  ImageRegion bad = ImageRegion::box(10, 10, 0, 5);
  dfn_->in.user.set(bad);
  testing::expectRejected(*dfn_, "input 'user'");
}

}  // namespace
}  // namespace cdff::dfn
