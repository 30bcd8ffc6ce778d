// EssentialMatrixEstimation: on two synthetic views with pixel noise and injected outliers the
// relative pose must agree with the truth to within what the noise allows and the outliers must
// be found; too few pairs, non-finite pixels, a bad camera and no baseline must be reported.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "EssentialMatrixEstimation.gen.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"
#include "support/two_view.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<EssentialMatrixEstimation> make(const std::string& dfi,
                                                const std::string& yaml = "{}") {
  return testing::makeDfn<EssentialMatrixEstimation>("EssentialMatrixEstimation", dfi, yaml);
}

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// The Cramer-Rao bound of a relative pose from the inliers of `scene` with pixel noise sigma:
// the Fisher information J^T J / sigma^2 of their Sampson distances with respect to the 5
// degrees of freedom (a rotation dtheta of second_R_first, and the unit translation turned in
// the 2 directions across it), by central differences. Returns the standard deviations of the
// rotation (rad, root of the trace of its 3x3 block) and of the translation's direction (rad).
std::pair<double, double> poseBound(const testing::TwoViewScene& scene, double sigma) {
  const Transform truth = scene.first_T_second.inverse();  // second_T_first
  const Eigen::Vector3d t = truth.translation.normalized();
  Eigen::Matrix<double, 3, 2> across;
  across.col(0) = t.unitOrthogonal();
  across.col(1) = t.cross(across.col(0));
  const Eigen::Matrix3d k_inv = scene.camera.matrix().inverse();
  auto residuals = [&](const Eigen::Matrix<double, 5, 1>& d) {
    const Eigen::Matrix3d r = expSO3(d.head<3>()).matrix() * truth.rotation.matrix();
    const Eigen::Vector3d td = (t + across * d.tail<2>()).normalized();
    const Eigen::Matrix3d f = k_inv.transpose() * skew(td) * r * k_inv;
    std::vector<double> out;
    for (std::size_t i = 0; i < scene.inlier.size(); ++i)
      if (scene.inlier[i])
        out.push_back(testing::sampsonDistance(f, scene.truth.first[i], scene.truth.second[i]));
    return out;
  };
  const std::size_t n = residuals(Eigen::Matrix<double, 5, 1>::Zero()).size();
  Eigen::MatrixXd j(n, 5);
  for (int k = 0; k < 5; ++k) {
    Eigen::Matrix<double, 5, 1> d = Eigen::Matrix<double, 5, 1>::Zero();
    d(k) = 1e-6;
    const std::vector<double> plus = residuals(d), minus = residuals(-d);
    for (std::size_t i = 0; i < n; ++i) j(i, k) = (plus[i] - minus[i]) / 2e-6;
  }
  const Eigen::Matrix<double, 5, 5> cov = sigma * sigma * (j.transpose() * j).inverse();
  return {std::sqrt(cov.topLeftCorner<3, 3>().trace()),
          std::sqrt(cov.bottomRightCorner<2, 2>().trace())};
}

class Estimators : public ::testing::TestWithParam<std::string> {};

TEST_P(Estimators, ThePoseAgreesWithTheTruthAndTheOutliersAreFound) {
  testing::TwoViewOptions options;
  options.sigma_px = 0.5;
  options.outlier_fraction = 0.2;
  for (int seed = 1; seed <= 10; ++seed) {
    options.seed = static_cast<std::uint32_t>(seed);
    options.points = seed <= 5 ? 200 : 2000;
    const testing::TwoViewScene scene = testing::twoViewScene(options);
    auto dfn = make(GetParam(), "{threshold: 3.0, confidence: 0.9999}");
    dfn->in.correspondences.set(scene.observed);
    dfn->in.camera.set(scene.camera);
    ASSERT_OK(dfn->process());
    const Transform& pose = *dfn->out.pose;
    EXPECT_EQ(pose.parent_frame, "first_optical");
    EXPECT_EQ(pose.child_frame, "second_optical");
    EXPECT_NEAR(pose.translation.norm(), 1.0, 1e-9);
    const int n = *dfn->out.inlier_count;
    // Within 4 standard deviations of the Cramer-Rao bound of this geometry (the points span
    // 40 x 28 deg and 4-7 m of depth: the rotation and the translation's direction are strongly
    // correlated, the bound is ~50 times sigma / f / sqrt(N)).
    const auto [rotation_sigma, direction_sigma] = poseBound(scene, options.sigma_px);
    const double rotation_error = angularDistance(pose.rotation, scene.first_T_second.rotation);
    const double direction_error =
        angleBetween(pose.translation, scene.first_T_second.translation.normalized());
    // The refinement reaches the minimum: on the output inliers the estimate's Sampson cost is
    // not above the true pose's (the true pose is one of the candidates it minimises over).
    auto costOf = [&](const Transform& first_T_second) {
      const Transform second_T_first = first_T_second.inverse();
      const Eigen::Matrix3d k_inv = scene.camera.matrix().inverse();
      const Eigen::Matrix3d f = k_inv.transpose() * skew(second_T_first.translation.normalized()) *
                                second_T_first.rotation.matrix() * k_inv;
      double cost = 0;
      for (const auto& index : *dfn->out.inlier_indices) {
        const auto i = index.get<std::size_t>();
        cost += std::pow(
            testing::sampsonDistance(f, scene.observed.first[i], scene.observed.second[i]), 2);
      }
      return cost;
    };
    EXPECT_LE(costOf(pose), costOf(scene.first_T_second) * (1 + 1e-9)) << "seed " << seed;
    EXPECT_LT(rotation_error, 4 * rotation_sigma)
        << "seed " << seed << ": " << rotation_error << " rad, bound sigma " << rotation_sigma;
    EXPECT_LT(direction_error, 4 * direction_sigma)
        << "seed " << seed << ": " << direction_error << " rad, bound sigma " << direction_sigma;
    // E = [t]x R of the recovered pose, unit t (singular values 1, 1, 0).
    Eigen::Matrix3d e;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) e(r, c) = (*dfn->out.essential)[r][c].get<double>();
    const Transform second_T_first = pose.inverse();
    const Eigen::Matrix3d expected =
        skew(second_T_first.translation) * second_T_first.rotation.matrix();
    EXPECT_LT(std::min((e - expected).norm(), (e + expected).norm()), 1e-6) << "seed " << seed;
    // Classification, as for F (threshold 3 px = 4 sigma of an inlier's epipolar distance): at
    // most 1 % of the inliers lost, at most 3 + 1.5 % of the outliers kept (a random pixel is
    // within 3 px of its epipolar line with probability about 0.6 %).
    int kept_inliers = 0, kept_outliers = 0, true_inliers = 0;
    for (bool in : scene.inlier) true_inliers += in;
    const int outliers = options.points - true_inliers;
    for (const auto& index : *dfn->out.inlier_indices)
      (scene.inlier[index.get<std::size_t>()] ? kept_inliers : kept_outliers)++;
    EXPECT_EQ(kept_inliers + kept_outliers, n);
    EXPECT_GE(kept_inliers, 0.99 * true_inliers) << "seed " << seed;
    EXPECT_LE(kept_outliers, 3 + 0.015 * outliers) << "seed " << seed;
  }
}

TEST_P(Estimators, ASecondCameraIsUsedForTheSecondView) {
  // The second view seen by a camera with another focal length and centre: its pixels scale.
  const testing::TwoViewScene scene = testing::twoViewScene({});
  CameraModel second = scene.camera;
  second.fx = second.fy = 1200;
  second.cx = 500;
  Correspondences2D c = scene.truth;
  for (auto& p : c.second)
    p = Eigen::Vector2d(second.cx, second.cy) +
        1.5 * (p - Eigen::Vector2d(scene.camera.cx, scene.camera.cy));
  auto dfn = make(GetParam());
  dfn->in.correspondences.set(c);
  dfn->in.camera.set(scene.camera);
  dfn->in.second_camera.set(second);
  ASSERT_OK(dfn->process());
  EXPECT_LT(angularDistance(dfn->out.pose->rotation, scene.first_T_second.rotation), 1e-6);
  EXPECT_EQ(*dfn->out.inlier_count, 200);
}

TEST_P(Estimators, BadInputIsReported) {
  testing::TwoViewScene scene = testing::twoViewScene({});
  auto dfn = make(GetParam());
  dfn->in.camera.set(scene.camera);
  Correspondences2D four;
  four.first.assign(scene.observed.first.begin(), scene.observed.first.begin() + 4);
  four.second.assign(scene.observed.second.begin(), scene.observed.second.begin() + 4);
  dfn->in.correspondences.set(four);
  testing::expectRejected(*dfn, "has 4 pairs; expected at least 5");
  Correspondences2D nan = scene.observed;
  nan.first[3].x() = std::numeric_limits<double>::infinity();
  dfn->in.correspondences.set(nan);
  testing::expectRejected(*dfn, "entry 3 is not finite");
  CameraModel bad = scene.camera;
  bad.fx = 0;
  dfn->in.correspondences.set(scene.observed);
  dfn->in.camera.set(bad);
  testing::expectRejected(*dfn, "input 'camera': camera model focal lengths are fx=0");
}

TEST_P(Estimators, NoBaselineIsReported) {
  // A camera that only turned: every ray pair is parallel once the rotation is removed.
  testing::TwoViewOptions options;
  options.baseline = 0.0;
  const testing::TwoViewScene scene = testing::twoViewScene(options);
  auto dfn = make(GetParam(), "{threshold: 2.0}");
  dfn->in.correspondences.set(scene.observed);
  dfn->in.camera.set(scene.camera);
  testing::expectRejected(*dfn,
                          "below min_parallax 0.5000 deg: the camera turned without "
                          "moving");
}

INSTANTIATE_TEST_SUITE_P(EssentialMatrixEstimation, Estimators,
                         ::testing::Values("Ransac", "Magsac"));

TEST(EssentialMatrixEstimation, OutOfRangeParametersAreRejected) {
  auto node = Registry::instance().create("EssentialMatrixEstimation", "Ransac");
  ASSERT_TRUE(node.isOk());
  for (const char* bad : {"{threshold: -1}", "{confidence: 0.1}", "{min_parallax: 120}"}) {
    const Status s = node.value()->configure(YAML::Load(bad));
    EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << bad;
  }
}

}  // namespace
}  // namespace cdff::dfn
