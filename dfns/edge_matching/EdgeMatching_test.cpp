// EdgeMatching/NormalSearch on rendered images with known geometry: from the true pose the
// edges are found at the samples (sub-pixel), from a shifted pose at the offset the shift
// predicts along each normal; edges across the contour are refused; a black image gives no
// candidates and a warning; mismatched inputs are rejected.
#include <gtest/gtest.h>

#include <algorithm>

#include <opencv2/imgproc.hpp>

#include "EdgeMatching.gen.hpp"
#include "cdff/tracking/contours.hpp"
#include "cdff/tracking/edge_search.hpp"
#include "cdff/types/opencv.hpp"
#include "support/dfn_testing.hpp"
#include "support/model_rendering.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<EdgeMatching> make(const std::string& yaml = "{}") {
  return testing::makeDfn<EdgeMatching>("EdgeMatching", "NormalSearch", yaml);
}

struct Scene {
  CameraModel camera = testing::pinholeCamera(640, 480, 600);
  PolygonModel box = testing::boxModel({0.25, 0.2, 0.15});
  Eigen::Isometry3d truth = testing::lookAt({0.35, -0.45, 0.3}, Eigen::Vector3d::Zero());
};

Image render(const Scene& s, double noise, double gain = 1.0) {
  testing::RenderOptions options;
  options.noise_sigma = noise;
  options.gain = gain;
  Image image = testing::toImage(testing::renderModel(s.box, s.camera, s.truth, options));
  image.camera = s.camera;
  return image;
}

ContourSamples samplesAt(const Scene& s, const Eigen::Isometry3d& pose) {
  auto model = tracking::TrackingModel::build(s.box).value();
  auto contours =
      tracking::computeContours(model, s.camera, Transform::fromIsometry(pose, "camera", "box"),
                                Transform::identity("camera", "camera"), {});
  return tracking::sampleContours(std::make_shared<const ModelContours>(contours.value()), {});
}

TEST(EdgeMatching, EdgesAreFoundAtTheTrueContoursToATenthOfAPixel) {
  const Scene scene;
  auto node = make();
  node->in.image.set(render(scene, 2.0));
  node->in.samples.set(samplesAt(scene, scene.truth));
  ASSERT_OK(node->process());
  const ContourSamples& m = *node->out.matches;
  ASSERT_TRUE(m.matched);
  ASSERT_GT(m.samples.size(), 100u);
  EXPECT_GT(*node->out.matched_ratio, 0.95);
  std::vector<double> errors;
  for (const ContourSample& s : m.samples) {
    if (s.candidate_count == 0) continue;
    // The strongest candidate is the contour itself (the box's faces are untextured).
    errors.push_back(std::abs(m.candidates[s.first_candidate].offset));
  }
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  const double p90 = errors[errors.size() * 9 / 10];
  ::testing::Test::RecordProperty("median_offset_px", std::to_string(median));
  EXPECT_LT(median, 0.1);
  EXPECT_LT(p90, 0.25);
}

TEST(EdgeMatching, FromAShiftedPoseTheOffsetsAreTheShiftAlongEachNormal) {
  const Scene scene;
  Eigen::Isometry3d predicted = scene.truth;
  predicted.translation() += Eigen::Vector3d(0.004, -0.003, 0.01);
  predicted.linear() =
      Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitZ()).toRotationMatrix() * predicted.linear();
  auto node = make();
  node->in.image.set(render(scene, 2.0));
  const ContourSamples samples = samplesAt(scene, predicted);
  node->in.samples.set(samples);
  ASSERT_OK(node->process());
  const ContourSamples& m = *node->out.matches;
  int checked = 0, good = 0;
  for (const ContourSample& s : m.samples) {
    // Where the sample's model point really is in the image, relative to its predicted pixel.
    const Eigen::Vector2d truth_px = scene.camera.project(scene.truth * s.point);
    const double expected = (truth_px - s.pixel).dot(s.normal);
    if (std::abs(expected) > 7 || s.candidate_count == 0) continue;
    ++checked;
    // Along the normal the edge sits at the true projection of the contour line; the sample's
    // own point slides along it, which the normal offset does not see.
    bool found = false;
    for (std::uint32_t c = 0; c < s.candidate_count; ++c)
      found = found || std::abs(m.candidates[s.first_candidate + c].offset - expected) < 0.6;
    good += found ? 1 : 0;
  }
  ASSERT_GT(checked, 100);
  EXPECT_GT(double(good) / checked, 0.9);
}

TEST(EdgeMatching, EdgesAcrossTheContourAreRefused) {
  // A horizontal step edge, searched with samples whose contour is vertical there.
  cv::Mat mat(200, 200, CV_8UC1, cv::Scalar(30));
  mat.rowRange(100, 200).setTo(200);
  Image image = testing::toImage(mat);
  image.camera = testing::pinholeCamera(200, 200, 200);
  ContourSamples samples;
  auto contours = std::make_shared<ModelContours>();
  contours->camera = *image.camera;
  contours->camera_T_model = Transform::identity("camera", "model");
  contours->camera_T_reference = Transform::identity("camera", "camera");
  contours->segments = {{{0, 0, 1}, {0, 1, 1}, 0, ContourKind::kLine}};
  samples.contours = contours;
  for (double angle : {0.0, 0.3, 1.2, M_PI / 2}) {
    ContourSample s;
    s.pixel = {100, 100.3};
    s.normal = {std::cos(angle), std::sin(angle)};
    samples.samples.push_back(s);
  }
  auto node = make("{angular_threshold: 30}");
  node->in.image.set(image);
  node->in.samples.set(samples);
  ASSERT_OK(node->process());
  const ContourSamples& m = *node->out.matches;
  EXPECT_EQ(m.samples[0].candidate_count, 0u) << "gradient perpendicular to the normal";
  EXPECT_EQ(m.samples[1].candidate_count, 0u) << "72 degrees off";
  EXPECT_EQ(m.samples[2].candidate_count, 1u) << "21 degrees off";
  ASSERT_EQ(m.samples[3].candidate_count, 1u);
  // The step between rows 99 and 100 is at y = 99.5, 0.8 px before the sample along +y.
  EXPECT_NEAR(m.candidates[m.samples[3].first_candidate].offset, -0.8, 0.05);
}

TEST(EdgeMatching, ABlackImageGivesNoCandidatesAndAWarning) {
  const Scene scene;
  auto node = make();
  Image black = testing::toImage(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)));
  black.camera = scene.camera;
  node->in.image.set(black);
  node->in.samples.set(samplesAt(scene, scene.truth));
  ASSERT_OK(node->process());
  EXPECT_EQ(node->out.matches->matchedCount(), 0u);
  EXPECT_EQ(*node->out.matched_ratio, 0.0);
  EXPECT_EQ(node->diagnostics().warning_count, 1u);
}

TEST(EdgeMatching, ColourImagesAreSearchedInGrey) {
  const Scene scene;
  Image grey = render(scene, 0.0);
  cv::Mat colour;
  cv::cvtColor(toMat(grey), colour, cv::COLOR_GRAY2BGR);
  Image bgr = testing::toImage(colour);
  bgr.camera = scene.camera;
  auto node = make();
  node->in.image.set(bgr);
  node->in.samples.set(samplesAt(scene, scene.truth));
  ASSERT_OK(node->process());
  EXPECT_GT(*node->out.matched_ratio, 0.95);
}

TEST(EdgeMatching, MismatchedInputsAreRejected) {
  const Scene scene;
  auto node = make();
  Image small = testing::toImage(cv::Mat(240, 320, CV_8UC1, cv::Scalar(0)));
  node->in.image.set(small);
  node->in.samples.set(samplesAt(scene, scene.truth));
  testing::expectRejected(*node, "image is 320x240 but the contours were computed for a 640x480");
  Image depth = testing::toImage(cv::Mat(480, 640, CV_16UC1, cv::Scalar(0)));
  node->in.image.set(depth);
  testing::expectRejected(*node, "input 'image'");
  node->in.image.set(render(scene, 0.0));
  node->in.samples.set(ContourSamples{});
  testing::expectRejected(*node, "carry no contours");
}

// Contrast adaptation (tracking::EdgeSearchOptions::relative_gradient, what the visual tracking
// DFPC uses): a dim image whose edges are all below min_gradient is matched once the threshold
// follows its contrast, at the same place; in pure noise the threshold stays above the noise.
TEST(EdgeMatching, ContrastAdaptationFindsTheEdgesOfADimImageAndNotNoise) {
  const Scene scene;
  const Image dim = render(scene, 0.5, 0.04);  // edges of a few grey levels
  const ContourSamples samples = samplesAt(scene, scene.truth);
  tracking::EdgeSearchOptions fixed;
  Result<ContourSamples> plain = tracking::searchEdges(dim, samples, fixed);
  ASSERT_OK(plain.status());
  const auto ratio = [](const ContourSamples& m) {
    return static_cast<double>(m.matchedCount()) / static_cast<double>(m.samples.size());
  };
  EXPECT_LT(ratio(*plain), 0.2);
  tracking::EdgeSearchOptions adaptive = fixed;
  adaptive.relative_gradient = 0.25;
  double threshold = 0;
  Result<ContourSamples> adapted = tracking::searchEdges(dim, samples, adaptive, &threshold);
  ASSERT_OK(adapted.status());
  EXPECT_LT(threshold, fixed.min_gradient);
  EXPECT_GT(ratio(*adapted), 0.9);
  std::vector<double> errors;
  for (const ContourSample& s : adapted->samples)
    if (s.candidate_count > 0)
      errors.push_back(std::abs(adapted->candidates[s.first_candidate].offset));
  std::sort(errors.begin(), errors.end());
  ASSERT_FALSE(errors.empty());
  EXPECT_LT(errors[errors.size() / 2], 0.3);  // median offset of the strongest candidate, px

  // Noise alone (sigma 2 grey levels on black, clipped at 0): the threshold rises above its floor
  // with the noise, and almost no sample finds a candidate.
  const Image noise = render(scene, 2.0, 0.0);
  Result<ContourSamples> in_noise = tracking::searchEdges(noise, samples, adaptive, &threshold);
  ASSERT_OK(in_noise.status());
  EXPECT_GT(threshold, 2 * adaptive.min_gradient_floor);
  EXPECT_LT(ratio(*in_noise), 0.05);

  adaptive.relative_gradient = 1.5;
  EXPECT_FALSE(tracking::searchEdges(dim, samples, adaptive).status().isOk());
}

}  // namespace
}  // namespace cdff::dfn
