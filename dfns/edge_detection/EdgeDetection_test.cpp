// EdgeDetection: edges of a synthetic rectangle must lie on its known border.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "EdgeDetection.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/types/opencv.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

const cv::Rect kRect(40, 30, 100, 60);

std::unique_ptr<EdgeDetection> make(const std::string& dfi, const char* yaml = "{}") {
  return testing::makeDfn<EdgeDetection>("EdgeDetection", dfi, yaml);
}

// Distance from every edge pixel to the rectangle border, and the share of the border covered.
struct EdgeQuality {
  double max_distance_px = 0;
  double border_coverage = 0;
};

EdgeQuality measure(const Image& edges) {
  cv::Mat border(edges.height, edges.width, CV_8UC1, cv::Scalar(0));
  cv::rectangle(border, kRect, cv::Scalar(255), 1);
  cv::Mat distance_to_border;
  cv::distanceTransform(255 - border, distance_to_border, cv::DIST_L2, 3);
  cv::Mat e = toMat(edges);
  EdgeQuality q;
  int covered = 0, border_pixels = 0;
  cv::Mat dilated_edges;
  cv::dilate(e, dilated_edges, cv::Mat::ones(5, 5, CV_8U));
  for (int y = 0; y < e.rows; ++y) {
    for (int x = 0; x < e.cols; ++x) {
      if (e.at<uchar>(y, x))
        q.max_distance_px = std::max<double>(q.max_distance_px, distance_to_border.at<float>(y, x));
      if (border.at<uchar>(y, x)) {
        ++border_pixels;
        covered += dilated_edges.at<uchar>(y, x) ? 1 : 0;
      }
    }
  }
  q.border_coverage = static_cast<double>(covered) / border_pixels;
  return q;
}

class EdgeDetectionTest : public ::testing::TestWithParam<std::string> {};

TEST_P(EdgeDetectionTest, EdgesLieOnTheRectangleBorder) {
  auto dfn = make(GetParam());
  Image input = testing::toImage(testing::rectangleImage(180, 120, kRect), 42);
  input.camera = testing::pinholeCamera(180, 120, 100);
  dfn->in.image.set(input);
  ASSERT_OK(dfn->process());
  const Image& edges = *dfn->out.edges;
  EXPECT_EQ(edges.width, 180);
  EXPECT_EQ(edges.height, 120);
  EXPECT_EQ(edges.format, PixelFormat::kGray8);
  EXPECT_EQ(edges.stamp, 42);
  ASSERT_TRUE(edges.camera.has_value());
  const EdgeQuality q = measure(edges);
  // Derivative kernels of up to 5 px spread a step edge by at most 2 px on either side.
  EXPECT_LE(q.max_distance_px, 2.0);
  EXPECT_GE(q.border_coverage, 0.98);
  const double border_area = 2.0 * (kRect.width + kRect.height);
  EXPECT_GT(*dfn->out.edge_fraction, 0.5 * border_area / (180 * 120));
  EXPECT_LT(*dfn->out.edge_fraction, 5.0 * border_area / (180 * 120));
}

TEST_P(EdgeDetectionTest, ColourInputGivesTheSameEdgesAsGrey) {
  cv::Mat grey = testing::rectangleImage(180, 120, kRect);
  cv::Mat colour;
  cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
  auto a = make(GetParam());
  auto b = make(GetParam());
  a->in.image.set(testing::toImage(grey));
  b->in.image.set(testing::toImage(colour));
  ASSERT_OK(a->process());
  ASSERT_OK(b->process());
  EXPECT_EQ(cv::norm(toMat(*a->out.edges), toMat(*b->out.edges), cv::NORM_L1), 0.0);
}

TEST_P(EdgeDetectionTest, EmptyImageIsRejectedAndOutputsStayUntouched) {
  auto dfn = make(GetParam());
  dfn->in.image.set(testing::toImage(testing::rectangleImage(180, 120, kRect)));
  ASSERT_OK(dfn->process());
  const Image* before = dfn->out.edges.get();

  dfn->in.image.set(Image{});
  Status s = dfn->process();
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("empty"), std::string::npos) << s.message();
  EXPECT_EQ(dfn->out.edges.get(), before);
  EXPECT_EQ(dfn->diagnostics().error_count, 1u);
  EXPECT_EQ(dfn->diagnostics().call_count, 2u);
}

TEST_P(EdgeDetectionTest, WrongPixelFormatIsRejected) {
  auto dfn = make(GetParam());
  dfn->in.image.set(testing::toImage(cv::Mat(10, 10, CV_32FC1, cv::Scalar(1.0f))));
  Status s = dfn->process();
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("32FC1"), std::string::npos) << s.message();
}

TEST_P(EdgeDetectionTest, MissingInputIsRejected) {
  auto dfn = make(GetParam());
  Status s = dfn->process();
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("'image'"), std::string::npos) << s.message();
}

INSTANTIATE_TEST_SUITE_P(AllDfis, EdgeDetectionTest, ::testing::Values("Canny", "Sobel"));

TEST(EdgeDetectionCanny, RejectsBadParameters) {
  auto node = Registry::instance().create("EdgeDetection", "Canny");
  ASSERT_TRUE(node.isOk());
  Node& dfn = *node.value();
  Status s = dfn.configure(YAML::Load("{low_threshold: 100, high_threshold: 10}"), "p.yaml");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("high_threshold"), std::string::npos) << s.message();

  s = dfn.configure(YAML::Load("aperture_size: 9"), "p.yaml");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("[3, 7]"), std::string::npos) << s.message();

  s = dfn.configure(YAML::Load("aperture_size: 4"), "p.yaml");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
}

TEST(EdgeDetectionSobel, RejectsUnknownKernel) {
  auto node = Registry::instance().create("EdgeDetection", "Sobel");
  ASSERT_TRUE(node.isOk());
  Status s = node.value()->configure(YAML::Load("kernel: prewitt"), "p.yaml");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("{sobel3, sobel5, scharr}"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace cdff::dfn
