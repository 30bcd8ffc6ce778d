// ContourSampling/Uniform: samples lie on their contour, project where their pixel says, are
// evenly spaced in the image with the contour's normal, respect max_samples by spreading over
// every contour, and stay away from the image border.
#include <gtest/gtest.h>

#include <map>

#include "ContourSampling.gen.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<ContourSampling> make(const std::string& yaml = "{}") {
  return testing::makeDfn<ContourSampling>("ContourSampling", "Uniform", yaml);
}

// Two segments seen obliquely (so that even image spacing differs from even 3D spacing).
ModelContours obliqueContours() {
  ModelContours c;
  c.camera = testing::pinholeCamera(640, 480, 500);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitY()).toRotationMatrix();
  pose.translation() << 0.05, 0.02, 1.0;
  c.camera_T_model = Transform::fromIsometry(pose, "camera", "model");
  c.camera_T_reference = Transform::identity("camera", "camera");
  c.segments = {{{-0.4, -0.1, 0}, {0.4, -0.1, 0}, 0, ContourKind::kSilhouette},
                {{-0.3, 0.2, 0.1}, {0.3, 0.25, -0.1}, 1, ContourKind::kCrease}};
  return c;
}

TEST(ContourSampling, SamplesAreEvenlySpacedInTheImageOnTheirContour) {
  auto node = make("{step: 7}");
  const ModelContours contours = obliqueContours();
  node->in.contours.set(contours);
  ASSERT_OK(node->process());
  const ContourSamples& s = *node->out.samples;
  ASSERT_GT(s.samples.size(), 40u);
  EXPECT_EQ(*node->out.sample_count, static_cast<int>(s.samples.size()));
  const Eigen::Isometry3d pose = contours.camera_T_model.isometry();
  std::map<std::uint32_t, std::vector<const ContourSample*>> by_segment;
  for (const ContourSample& sample : s.samples) {
    const ContourSegment& seg = contours.segments[sample.segment];
    // On the 3D segment ...
    const Eigen::Vector3d d = seg.b - seg.a;
    const double t = (sample.point - seg.a).dot(d) / d.squaredNorm();
    EXPECT_LT((seg.a + t * d - sample.point).norm(), 1e-12);
    EXPECT_GE(t, 0);
    EXPECT_LE(t, 1);
    // ... projecting to its pixel, with the unit normal of the projected segment.
    EXPECT_LT((contours.camera.project(pose * sample.point) - sample.pixel).norm(), 1e-9);
    const Eigen::Vector2d image_dir =
        contours.camera.project(pose * seg.b) - contours.camera.project(pose * seg.a);
    EXPECT_NEAR(sample.normal.norm(), 1.0, 1e-12);
    EXPECT_NEAR(sample.normal.dot(image_dir.normalized()), 0.0, 1e-12);
    EXPECT_EQ(sample.candidate_count, 0u);
    by_segment[sample.segment].push_back(&sample);
  }
  ASSERT_EQ(by_segment.size(), 2u);
  for (const auto& [segment, samples] : by_segment) {
    const Eigen::Vector2d a = contours.camera.project(pose * contours.segments[segment].a);
    const Eigen::Vector2d b = contours.camera.project(pose * contours.segments[segment].b);
    const double length = (b - a).norm();
    const double spacing = length / std::floor(length / 7.0);  // whole samples per segment
    for (std::size_t i = 1; i < samples.size(); ++i)
      EXPECT_NEAR((samples[i]->pixel - samples[i - 1]->pixel).norm(), spacing, 1e-6);
  }
  EXPECT_FALSE(s.matched);
  EXPECT_EQ(s.contours.get(), node->in.contours.get()) << "the contours are shared, not copied";
}

TEST(ContourSampling, MaxSamplesSpreadsTheBudgetOverEveryContour) {
  auto node = make("{step: 1, max_samples: 60}");
  node->in.contours.set(obliqueContours());
  ASSERT_OK(node->process());
  const ContourSamples& s = *node->out.samples;
  EXPECT_LE(s.samples.size(), 60u);
  EXPECT_GE(s.samples.size(), 55u);
  int first = 0, second = 0;
  for (const ContourSample& sample : s.samples) (sample.segment == 0 ? first : second)++;
  EXPECT_GT(first, 15);
  EXPECT_GT(second, 15);
}

TEST(ContourSampling, SamplesNearTheBorderAreDropped) {
  auto node = make("{step: 2, image_margin: 20}");
  ModelContours c = obliqueContours();
  c.camera_T_model.translation.x() = 0.55;  // pushes the contours across the right border
  node->in.contours.set(c);
  ASSERT_OK(node->process());
  ASSERT_FALSE(node->out.samples->samples.empty());
  for (const ContourSample& sample : node->out.samples->samples) {
    EXPECT_GE(sample.pixel.x(), 20);
    EXPECT_LE(sample.pixel.x(), 639 - 20);
  }
}

TEST(ContourSampling, NoContoursGiveNoSamplesWithoutAnError) {
  auto node = make();
  ModelContours c = obliqueContours();
  c.segments.clear();
  node->in.contours.set(c);
  ASSERT_OK(node->process());
  EXPECT_TRUE(node->out.samples->samples.empty());
  EXPECT_EQ(node->diagnostics().warning_count, 0u);
}

TEST(ContourSampling, MalformedContoursAreRejected) {
  auto node = make();
  ModelContours c = obliqueContours();
  c.camera.fx = -1;
  node->in.contours.set(c);
  testing::expectRejected(*node, "input 'contours' camera");
  c = obliqueContours();
  c.segments[1].b.y() = std::numeric_limits<double>::infinity();
  node->in.contours.set(c);
  testing::expectRejected(*node, "segment 1 has a non-finite end point");
}

TEST(ContourSampling, ParametersOutOfRangeAreRejected) {
  auto node = Registry::instance().createAs<ContourSampling>("ContourSampling", "Uniform");
  ASSERT_TRUE(node.isOk());
  const Status s = node.value()->configure(YAML::Load("{step: 0}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("step"), std::string::npos);
}

}  // namespace
}  // namespace cdff::dfn
