// PerspectiveNPoint: on synthetic 3D-2D pairs with pixel noise and injected outliers the pose
// must agree with the truth as its own covariance says (NEES), and the outliers must be found;
// too few pairs, non-finite values, collinear points and a bad camera must be reported.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "PerspectiveNPoint.gen.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"
#include "support/two_view.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<PerspectiveNPoint> make(const std::string& dfi, const std::string& yaml = "{}") {
  return testing::makeDfn<PerspectiveNPoint>("PerspectiveNPoint", dfi, yaml);
}

// The scene's points (the first camera's frame is the model's) and the second view's pixels:
// the truth camera_T_model is second_T_first.
Correspondences2D3D pairsOf(const testing::TwoViewScene& scene) {
  Correspondences2D3D c;
  c.points = scene.points;
  c.pixels = scene.observed.second;
  return c;
}

class Solvers : public ::testing::TestWithParam<std::string> {};

TEST_P(Solvers, ThePoseAgreesWithTheTruthAsItsCovarianceSaysAndOutliersAreFound) {
  // 40 draws of 100 pairs, 0.5 px noise, 20 % outliers. The error [dt, dtheta] (truth = exp(dtheta)
  // estimate, t = estimate + dt) weighed by the output covariance is chi-square with 6 degrees of
  // freedom when the covariance is honest: each draw below chi2_6(0.9999) = 27.9, their mean
  // within 6 +- 2 (its standard deviation over 40 draws is 0.55; the first-order covariance and
  // its residual-estimated scale add a little).
  double nees_sum = 0;
  constexpr int kDraws = 40;
  for (int draw = 0; draw < kDraws; ++draw) {
    testing::TwoViewOptions options;
    options.points = 100;
    options.sigma_px = 0.5;
    options.outlier_fraction = 0.2;
    options.seed = static_cast<std::uint32_t>(100 + draw);
    const testing::TwoViewScene scene = testing::twoViewScene(options);
    auto dfn = make(GetParam());
    dfn->in.correspondences.set(pairsOf(scene));
    dfn->in.camera.set(scene.camera);
    ASSERT_OK(dfn->process());
    const PoseWithCovariance& pose = *dfn->out.pose;
    EXPECT_EQ(pose.pose.parent_frame, "camera_optical");
    EXPECT_EQ(pose.pose.child_frame, "model");
    EXPECT_OK(pose.validate());
    const Transform truth = scene.first_T_second.inverse();
    Vector6d error;
    error.head<3>() = truth.translation - pose.pose.translation;
    error.tail<3>() = logSO3(truth.rotation * pose.pose.rotation.inverse());
    const double nees = error.dot(pose.covariance.ldlt().solve(error));
    EXPECT_LT(nees, 27.9) << "draw " << draw;
    nees_sum += nees;
    // Inliers: a match's reprojection error is within 2 px = 4 sigma of the noise: at most 1
    // refused; outliers: a random pixel within 2 px of its point's projection has probability
    // 12.6 / (1024 x 768): none kept.
    int kept_inliers = 0, kept_outliers = 0, inliers = 0;
    for (bool in : scene.inlier) inliers += in;
    for (const auto& index : *dfn->out.inlier_indices)
      (scene.inlier[index.get<std::size_t>()] ? kept_inliers : kept_outliers)++;
    EXPECT_EQ(kept_inliers + kept_outliers, *dfn->out.inlier_count);
    EXPECT_GE(kept_inliers, inliers - 1) << "draw " << draw;
    EXPECT_EQ(kept_outliers, 0) << "draw " << draw;
  }
  EXPECT_NEAR(nees_sum / kDraws, 6.0, 2.0);
}

TEST_P(Solvers, BadInputIsReported) {
  const testing::TwoViewScene scene = testing::twoViewScene({});
  auto dfn = make(GetParam());
  dfn->in.camera.set(scene.camera);
  Correspondences2D3D three = pairsOf(scene);
  three.points.resize(3);
  three.pixels.resize(3);
  dfn->in.correspondences.set(three);
  testing::expectRejected(*dfn, "has 3 pairs; expected at least 4");
  Correspondences2D3D nan = pairsOf(scene);
  nan.points[9].z() = std::numeric_limits<double>::quiet_NaN();
  dfn->in.correspondences.set(nan);
  testing::expectRejected(*dfn, "entry 9 is not finite");
  CameraModel bad = scene.camera;
  bad.width = 0;
  dfn->in.correspondences.set(pairsOf(scene));
  dfn->in.camera.set(bad);
  testing::expectRejected(*dfn, "input 'camera': camera model size is 0x768");
}

TEST_P(Solvers, CollinearPointsAreReported) {
  // 30 points on one line: the rotation about it is not observable.
  testing::TwoViewScene scene = testing::twoViewScene({});
  Correspondences2D3D line;
  const Transform camera_T_model = scene.first_T_second.inverse();
  for (int i = 0; i < 30; ++i) {
    const Eigen::Vector3d p(-1.0 + 0.07 * i, 0.5 - 0.03 * i, 5.0 + 0.05 * i);
    line.points.push_back(p);
    line.pixels.push_back(scene.camera.project(camera_T_model * p));
  }
  auto dfn = make(GetParam());
  dfn->in.camera.set(scene.camera);
  dfn->in.correspondences.set(line);
  const std::vector<const void*> before = {dfn->out.pose.anyValue().raw()};
  const Status s = dfn->process();
  EXPECT_FALSE(s.isOk());
  EXPECT_EQ(s.code(), StatusCode::kNumericalFailure) << s.toString();
  EXPECT_EQ(dfn->out.pose.anyValue().raw(), before[0]);
}

INSTANTIATE_TEST_SUITE_P(PerspectiveNPoint, Solvers,
                         ::testing::Values("EpnpRansac", "SqpnpRansac"));

TEST(PerspectiveNPoint, OutOfRangeParametersAreRejected) {
  auto node = Registry::instance().create("PerspectiveNPoint", "SqpnpRansac");
  ASSERT_TRUE(node.isOk());
  for (const char* bad : {"{threshold: 0}", "{min_inliers: 3}", "{max_iterations: 0}"}) {
    const Status s = node.value()->configure(YAML::Load(bad));
    EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << bad;
  }
}

}  // namespace
}  // namespace cdff::dfn
