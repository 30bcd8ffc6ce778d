// FeaturesExtraction2D: features must be repeatable under a known homography (the same scene
// points are found again where the homography maps them), respect the budget, the mask and the
// input's metadata, and bad inputs must be reported without touching the output.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "FeaturesExtraction2D.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/types/opencv.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<FeaturesExtraction2D> make(const std::string& dfi, const std::string& yaml = "{}") {
  return testing::makeDfn<FeaturesExtraction2D>("FeaturesExtraction2D", dfi, yaml);
}

Features2D extract(FeaturesExtraction2D& dfn, const cv::Mat& image, Timestamp stamp = 0) {
  dfn.in.image.set(testing::toImage(image, stamp));
  EXPECT_OK(dfn.process());
  return dfn.out.features.hasValue() ? *dfn.out.features : Features2D{};
}

// A rotation of 12 degrees about the image centre, a 5 % zoom and a shift: a second view of a
// planar scene whose every point has a known position.
cv::Mat viewChange(int width, int height) {
  cv::Mat a = cv::getRotationMatrix2D(cv::Point2f(width / 2.0f, height / 2.0f), 12.0, 1.05);
  cv::Mat h = cv::Mat::eye(3, 3, CV_64F);
  a.copyTo(h.rowRange(0, 2));
  h.at<double>(0, 2) += 9.0;
  h.at<double>(1, 2) -= 6.0;
  return h;
}

Eigen::Vector2d apply(const cv::Mat& h, const Eigen::Vector2f& p) {
  const cv::Mat q = h * (cv::Mat_<double>(3, 1) << p.x(), p.y(), 1.0);
  return {q.at<double>(0) / q.at<double>(2), q.at<double>(1) / q.at<double>(2)};
}

// Fraction of the features of `a` (mapped by `h` well inside the second image) that have a
// feature of `b` within `radius` pixels: the detector's repeatability.
double repeatability(const Features2D& a, const Features2D& b, const cv::Mat& h, int width,
                     int height, double radius) {
  int visible = 0, repeated = 0;
  for (const Keypoint2D& k : a.keypoints) {
    const Eigen::Vector2d p = apply(h, k.position);
    if (p.x() < 40 || p.y() < 40 || p.x() > width - 40 || p.y() > height - 40) continue;
    ++visible;
    for (const Keypoint2D& q : b.keypoints)
      if ((q.position.cast<double>() - p).norm() < radius) {
        ++repeated;
        break;
      }
  }
  return visible ? static_cast<double>(repeated) / visible : 0.0;
}

class Extractors : public ::testing::TestWithParam<std::string> {};

TEST_P(Extractors, FeaturesAreRepeatableUnderAKnownHomography) {
  constexpr int kW = 640, kH = 480;
  const cv::Mat scene = testing::texturedScene(kW, kH, 42);
  const cv::Mat h = viewChange(kW, kH);
  cv::Mat warped;
  cv::warpPerspective(scene, warped, h, scene.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 128);
  auto dfn = make(GetParam(), "max_features: 800");
  const Features2D a = extract(*dfn, scene);
  const Features2D b = extract(*dfn, warped);
  ASSERT_GT(a.size(), 200u);
  ASSERT_GT(b.size(), 200u);
  // Both detectors find most corners again within 2 px after a 12 degree rotation and a 5 %
  // zoom (measured: ORB 0.78, AKAZE 0.94); below 0.6 the detector has regressed.
  const double measured = repeatability(a, b, h, kW, kH, 2.0);
  RecordProperty("repeatability", std::to_string(measured));
  EXPECT_GT(measured, 0.6);
}

TEST_P(Extractors, TheBudgetIsKeptWithTheStrongestFirstAndOneDescriptorPerKeypoint) {
  auto dfn = make(GetParam(), "max_features: 150");
  const Features2D f = extract(*dfn, testing::texturedScene(640, 480, 3), 123456);
  ASSERT_EQ(f.size(), 150u);
  EXPECT_EQ(f.descriptors.rows, 150);
  EXPECT_EQ(f.descriptors.element, DescriptorMatrix::Element::kUint8);
  EXPECT_EQ(f.descriptors.distance, DescriptorMatrix::Distance::kHamming);
  EXPECT_EQ(f.stamp, 123456);
  EXPECT_EQ(f.frame_id, "camera");
  for (std::size_t i = 1; i < f.size(); ++i)
    EXPECT_GE(f.keypoints[i - 1].response, f.keypoints[i].response) << i;
  EXPECT_OK(f.validate());
}

TEST_P(Extractors, AMaskConfinesTheFeatures) {
  const cv::Mat scene = testing::texturedScene(640, 480, 5);
  cv::Mat mask(480, 640, CV_8UC1, cv::Scalar(0));
  const cv::Rect region(200, 150, 240, 180);
  mask(region).setTo(255);
  auto dfn = make(GetParam());
  dfn->in.mask.set(testing::toImage(mask));
  const Features2D f = extract(*dfn, scene);
  ASSERT_GT(f.size(), 20u);
  // Detection happens on mask pixels; sub-pixel refinement may move a corner by under a pixel.
  for (const Keypoint2D& k : f.keypoints) {
    EXPECT_GT(k.position.x(), region.x - 1.0f) << k.position.transpose();
    EXPECT_GT(k.position.y(), region.y - 1.0f) << k.position.transpose();
    EXPECT_LT(k.position.x(), region.x + region.width) << k.position.transpose();
    EXPECT_LT(k.position.y(), region.y + region.height) << k.position.transpose();
  }
}

TEST_P(Extractors, AColourImageGivesTheFeaturesOfItsGreyLevels) {
  const cv::Mat grey = testing::texturedScene(320, 240, 9);
  cv::Mat colour;
  cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
  auto dfn = make(GetParam());
  const Features2D from_grey = extract(*dfn, grey);
  const Features2D from_colour = extract(*dfn, colour);
  ASSERT_EQ(from_grey.size(), from_colour.size());
  for (std::size_t i = 0; i < from_grey.size(); ++i)
    EXPECT_EQ(from_grey.keypoints[i].position, from_colour.keypoints[i].position);
}

TEST_P(Extractors, AUniformImageGivesNoFeatureAndAWarning) {
  auto dfn = make(GetParam());
  const Features2D f = extract(*dfn, cv::Mat(240, 320, CV_8UC1, cv::Scalar(77)));
  EXPECT_EQ(f.size(), 0u);
  EXPECT_EQ(dfn->diagnostics().warning_count, 1u);
}

TEST_P(Extractors, BadInputsAreReportedAndLeaveTheOutputUntouched) {
  auto dfn = make(GetParam());
  extract(*dfn, testing::texturedScene(320, 240, 1), 7);
  dfn->in.image.set(Image{});
  testing::expectRejected(*dfn, "empty");
  dfn->in.image.set(testing::toImage(cv::Mat(240, 320, CV_16UC1, cv::Scalar(1000))));
  testing::expectRejected(*dfn, "16UC1");
  dfn->in.image.set(testing::toImage(testing::texturedScene(320, 240, 1)));
  dfn->in.mask.set(testing::toImage(cv::Mat(100, 100, CV_8UC1, cv::Scalar(255))));
  testing::expectRejected(*dfn, "mask");
}

INSTANTIATE_TEST_SUITE_P(FeaturesExtraction2D, Extractors, ::testing::Values("Orb", "Akaze"));

TEST(FeaturesExtraction2DOrb, InconsistentOrOutOfRangeParametersAreRejected) {
  auto node = Registry::instance().create("FeaturesExtraction2D", "Orb");
  ASSERT_TRUE(node.isOk());
  Status s = node.value()->configure(YAML::Load("{patch_size: 61, edge_threshold: 10}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("edge_threshold"), std::string::npos) << s.message();
  s = node.value()->configure(YAML::Load("{scale_factor: 3.0}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("[1.01, 2]"), std::string::npos) << s.message();
  s = node.value()->configure(YAML::Load("{max_feature: 10}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("max_feature"), std::string::npos) << s.message();
}

TEST(FeaturesExtraction2DOrb, WtaKAboveTwoGivesHammingTwoDescriptors) {
  auto dfn = make("Orb", "{wta_k: 3}");
  const Features2D f = extract(*dfn, testing::texturedScene(320, 240, 4));
  ASSERT_GT(f.size(), 0u);
  EXPECT_EQ(f.descriptors.distance, DescriptorMatrix::Distance::kHamming2);
}

}  // namespace
}  // namespace cdff::dfn
