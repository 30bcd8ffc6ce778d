// FundamentalMatrixEstimation: on two synthetic views with pixel noise and injected outliers the
// estimated F must agree with the true one to within the noise and the outliers must be found;
// too few pairs, non-finite pixels and a planar scene (F undetermined) must be reported.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "FundamentalMatrixEstimation.gen.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"
#include "support/two_view.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<FundamentalMatrixEstimation> make(const std::string& dfi,
                                                  const std::string& yaml = "{}") {
  return testing::makeDfn<FundamentalMatrixEstimation>("FundamentalMatrixEstimation", dfi, yaml);
}

Eigen::Matrix3d matrixFrom(const nlohmann::json& j) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = j.at(r).at(c).get<double>();
  return m;
}

class Estimators : public ::testing::TestWithParam<std::string> {};

// 200 and 2000 pairs (5 draws each), sigma 0.5 px on each pixel, 20 % of the second pixels
// replaced by random ones.
void checkEstimate(const std::string& dfi, int points, std::uint32_t seed) {
  SCOPED_TRACE(::testing::Message() << points << " pairs, seed " << seed);
  testing::TwoViewOptions options;
  options.points = points;
  options.sigma_px = 0.5;
  options.outlier_fraction = 0.2;
  options.seed = seed;
  const testing::TwoViewScene scene = testing::twoViewScene(options);
  auto dfn = make(dfi, "{threshold: 3.0, confidence: 0.9999}");
  dfn->in.correspondences.set(scene.observed);
  ASSERT_OK(dfn->process());
  const Eigen::Matrix3d f = matrixFrom(*dfn->out.fundamental);
  EXPECT_NEAR(f.norm(), 1.0, 1e-9);
  EXPECT_GE(f(2, 2), 0.0);
  EXPECT_LT(std::abs(f.determinant()), 1e-9) << "F must have rank 2";

  // The noise-free pairs under the estimated F: the maximum-likelihood fit of 7 parameters to N
  // inliers with pixel noise sigma leaves them sigma sqrt(7 / N) RMS from the constraint
  // (Sampson distance; the trace of the hat matrix), and sqrt(chi2_7(0.999) / 7) = 1.85 times that
  // at most; 2.5 leaves room for the Sampson distance being a first-order approximation.
  int true_inliers = 0;
  double sum2 = 0;
  for (std::size_t i = 0; i < scene.inlier.size(); ++i) {
    if (!scene.inlier[i]) continue;
    ++true_inliers;
    sum2 += std::pow(testing::sampsonDistance(f, scene.truth.first[i], scene.truth.second[i]), 2);
  }
  const double rms = std::sqrt(sum2 / true_inliers);
  EXPECT_LT(rms, 2.5 * options.sigma_px * std::sqrt(7.0 / true_inliers)) << rms << " px";
  // Classification: threshold 3 px is 4 sigma of the epipolar distance of an inlier (sigma
  // sqrt(2) = 0.71 px), so at most 1 % of the inliers may be lost; a random pixel lies within
  // 3 px of its epipolar line with probability about 6 / 1000, so at most 3 + 1.5 % of the
  // outliers may pass.
  const nlohmann::json& indices = *dfn->out.inlier_indices;
  ASSERT_EQ(static_cast<int>(indices.size()), *dfn->out.inlier_count);
  ASSERT_EQ(dfn->out.inliers->size(), indices.size());
  int kept_inliers = 0, kept_outliers = 0;
  for (const auto& index : indices) {
    const auto i = index.get<std::size_t>();
    ASSERT_LT(i, scene.inlier.size());
    (scene.inlier[i] ? kept_inliers : kept_outliers)++;
  }
  EXPECT_GE(kept_inliers, 0.99 * true_inliers) << kept_inliers << " of " << true_inliers;
  EXPECT_LE(kept_outliers, 3 + 0.015 * (points - true_inliers)) << "outliers accepted";
  EXPECT_EQ(dfn->out.inliers->first[0], scene.observed.first[indices[0].get<std::size_t>()]);
}

TEST_P(Estimators, FAgreesWithTheTruthAndTheOutliersAreFound) {
  for (int points : {200, 2000})
    for (std::uint32_t seed = 1; seed <= 5; ++seed) checkEstimate(GetParam(), points, seed);
}

TEST_P(Estimators, TooFewPairsAreReported) {
  testing::TwoViewOptions options;
  options.points = 7;
  auto dfn = make(GetParam());
  dfn->in.correspondences.set(testing::twoViewScene(options).observed);
  testing::expectRejected(*dfn, "has 7 pairs; expected at least 8");
}

TEST_P(Estimators, ANonFinitePixelIsReported) {
  testing::TwoViewScene scene = testing::twoViewScene({});
  scene.observed.second[17].y() = std::numeric_limits<double>::quiet_NaN();
  auto dfn = make(GetParam());
  dfn->in.correspondences.set(scene.observed);
  testing::expectRejected(*dfn, "entry 17 is not finite");
}

TEST_P(Estimators, APlanarSceneIsReportedAsDegenerate) {
  testing::TwoViewOptions options;
  options.planar = true;
  auto dfn = make(GetParam(), "{threshold: 2.0}");
  dfn->in.correspondences.set(testing::twoViewScene(options).observed);
  testing::expectRejected(*dfn, "planar scene or a camera that did not move");
}

TEST_P(Estimators, NoTranslationIsReportedAsDegenerate) {
  testing::TwoViewOptions options;
  options.baseline = 0.0;
  auto dfn = make(GetParam(), "{threshold: 2.0}");
  dfn->in.correspondences.set(testing::twoViewScene(options).observed);
  testing::expectRejected(*dfn, "one homography explains");
}

INSTANTIATE_TEST_SUITE_P(FundamentalMatrixEstimation, Estimators,
                         ::testing::Values("Ransac", "Magsac"));

TEST(FundamentalMatrixEstimation, OutOfRangeParametersAreRejected) {
  auto node = Registry::instance().create("FundamentalMatrixEstimation", "Magsac");
  ASSERT_TRUE(node.isOk());
  for (const char* bad : {"{threshold: 0}", "{confidence: 1.5}", "{max_iterations: 1}",
                          "{max_homography_fraction: 2}"}) {
    const Status s = node.value()->configure(YAML::Load(bad));
    EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << bad;
  }
}

}  // namespace
}  // namespace cdff::dfn
