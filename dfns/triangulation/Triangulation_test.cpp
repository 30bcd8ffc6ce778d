// Triangulation: on two synthetic views of known pose with pixel noise the points must be found
// within the error the noise and the parallax allow, and wrong matches, points behind a camera
// and points without parallax refused with their status; bad inputs and a pose without baseline
// must be reported.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>

#include "Triangulation.gen.hpp"
#include "cdff/types/opencv.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"
#include "support/two_view.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<Triangulation> make(const std::string& dfi, const std::string& yaml = "{}") {
  return testing::makeDfn<Triangulation>("Triangulation", dfi, yaml);
}

void setInputs(Triangulation& dfn, const testing::TwoViewScene& scene,
               const Correspondences2D& pairs) {
  dfn.in.correspondences.set(pairs);
  dfn.in.camera.set(scene.camera);
  dfn.in.pose.set(scene.first_T_second);
}

class Triangulators : public ::testing::TestWithParam<std::string> {};

TEST_P(Triangulators, PointsAreWithinTheNoiseAndWrongMatchesAreRefused) {
  testing::TwoViewOptions options;
  options.points = 1000;
  options.sigma_px = 0.5;
  options.outlier_fraction = 0.2;
  const testing::TwoViewScene scene = testing::twoViewScene(options);
  auto dfn = make(GetParam(), "{max_reprojection_error: 2.0, min_parallax: 1.0}");
  setInputs(*dfn, scene, scene.observed);
  ASSERT_OK(dfn->process());
  const nlohmann::json& status = *dfn->out.status;
  ASSERT_EQ(status.size(), scene.points.size());
  const PointCloud& cloud = *dfn->out.points;
  EXPECT_EQ(cloud.frame_id, "first");
  ASSERT_EQ(static_cast<int>(cloud.size()), *dfn->out.accepted);
  // A ray is known to sigma sqrt(2) / f rad across (the noise of a pixel, as a direction, and
  // both rays count); the range along the first ray is then known to range * that / parallax.
  // Every accepted inlier within 5 of those (the worst of ~800 Gaussian draws is about 3.5,
  // and the float storage adds nothing at this scale); the error is mostly along the ray, so the
  // mean of the normalised errors is that of |N(0, 1)|, sqrt(2 / pi) = 0.80 (+-0.25: both a
  // model that overstates and one that understates the error fail).
  const double ray_sigma = std::sqrt(2.0) * options.sigma_px / scene.camera.fx;
  std::size_t k = 0;
  int inliers = 0, kept_inliers = 0, outliers = 0, kept_outliers = 0;
  double normalised_sum = 0;
  for (std::size_t i = 0; i < status.size(); ++i) {
    (scene.inlier[i] ? inliers : outliers)++;
    if (status[i] != "ok") continue;
    const Eigen::Vector3d p = cloud.points[k++].vec().cast<double>();
    if (!scene.inlier[i]) {
      ++kept_outliers;
      continue;
    }
    ++kept_inliers;
    const Eigen::Vector3d truth = scene.points[i];
    const Eigen::Vector3d c2 = scene.first_T_second.translation;
    const double parallax = std::atan2(truth.cross(truth - c2).norm(), truth.dot(truth - c2));
    const double sigma = truth.norm() * ray_sigma / parallax;
    const double normalised = (p - truth).norm() / sigma;
    EXPECT_LT(normalised, 5.0) << "pair " << i << ": " << (p - truth).norm() << " m";
    normalised_sum += normalised;
  }
  EXPECT_NEAR(normalised_sum / kept_inliers, 0.80, 0.25);
  // Inliers: the reprojection error of a noise-free match is within 2 px = 4 sigma of the pixel
  // noise; at most 2 % refused (the parallax is 4-7 deg everywhere). Outliers (refused as behind a
  // camera, without parallax or off their pixels, whichever their random ray gives): the point
  // splits the error between the views, so a pair within ~4 px of its epipolar line passes, a
  // band of about 1 % of the image: at most 4 %.
  EXPECT_GE(kept_inliers, 0.98 * inliers);
  EXPECT_LE(kept_outliers, 0.04 * outliers);
}

TEST_P(Triangulators, PointsBehindACameraAndWithoutParallaxAreRefused) {
  const testing::TwoViewScene scene = testing::twoViewScene({});
  Correspondences2D pairs;
  // Pair 0: a true match. Pair 1: the same pixel in both views far from the baseline's
  // direction: rays that meet behind the cameras or not at all. Pair 2: the epipole's
  // neighbourhood is avoided; a point 10 km away seen through both cameras: no parallax.
  pairs.first = {scene.truth.first[0]};
  pairs.second = {scene.truth.second[0]};
  const Transform second_T_first = scene.first_T_second.inverse();
  const Eigen::Vector3d far(30, 10, 10000);
  pairs.first.push_back(scene.camera.project(far));
  pairs.second.push_back(scene.camera.project(second_T_first * far));
  // A point 2 m behind the first camera, projected through both centres (negative depths).
  const Eigen::Vector3d behind(0.3, 0.2, -5);
  auto projectThrough = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector2d(scene.camera.fx * p.x() / p.z() + scene.camera.cx,
                           scene.camera.fy * p.y() / p.z() + scene.camera.cy);
  };
  pairs.first.push_back(projectThrough(behind));
  pairs.second.push_back(projectThrough(second_T_first * behind));
  auto dfn = make(GetParam());
  setInputs(*dfn, scene, pairs);
  ASSERT_OK(dfn->process());
  EXPECT_EQ((*dfn->out.status)[0], "ok");
  EXPECT_EQ((*dfn->out.status)[1], "low_parallax");
  EXPECT_EQ((*dfn->out.status)[2], "behind_camera");
  EXPECT_EQ(*dfn->out.accepted, 1);
  EXPECT_LT((dfn->out.points->points[0].vec().cast<double>() - scene.points[0]).norm(), 1e-5);
  ASSERT_EQ(dfn->diagnostics().warnings.size(), 1u);
}

TEST_P(Triangulators, BadInputIsReported) {
  const testing::TwoViewScene scene = testing::twoViewScene({});
  auto dfn = make(GetParam());
  setInputs(*dfn, scene, Correspondences2D{});
  testing::expectRejected(*dfn, "input 'correspondences' is empty");
  Correspondences2D nan = scene.observed;
  nan.second[5].x() = std::numeric_limits<double>::quiet_NaN();
  dfn->in.correspondences.set(nan);
  testing::expectRejected(*dfn, "entry 5 is not finite");
  dfn->in.correspondences.set(scene.observed);
  Transform no_baseline = scene.first_T_second;
  no_baseline.translation.setZero();
  dfn->in.pose.set(no_baseline);
  testing::expectRejected(*dfn, "has a translation of 0 m: no baseline");
  Transform bad_rotation = scene.first_T_second;
  bad_rotation.rotation.coeffs() *= 2;
  dfn->in.pose.set(bad_rotation);
  testing::expectRejected(*dfn, "input 'pose'");
  dfn->in.pose.set(scene.first_T_second);
  CameraModel bad = scene.camera;
  bad.fy = -1;
  dfn->in.second_camera.set(bad);
  testing::expectRejected(*dfn, "input 'second_camera': camera model focal lengths");
}

// `points` (in a camera's frame) through a camera model with distortion, by OpenCV's projection.
std::vector<Eigen::Vector2d> distortedPixels(const CameraModel& camera,
                                             const std::vector<Eigen::Vector3d>& points) {
  std::vector<cv::Point3d> in;
  for (const auto& p : points) in.emplace_back(p.x(), p.y(), p.z());
  std::vector<cv::Point2d> out;
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  if (camera.distortion_model == DistortionModel::kEquidistant)
    cv::fisheye::projectPoints(in, out, zero, zero, cameraMatrix(camera),
                               distortionCoefficients(camera));
  else
    cv::projectPoints(in, zero, zero, cameraMatrix(camera), distortionCoefficients(camera), out);
  std::vector<Eigen::Vector2d> pixels;
  for (const auto& q : out) pixels.emplace_back(q.x, q.y);
  return pixels;
}

TEST_P(Triangulators, TheCamerasDistortionIsRemoved) {
  // Noise-free pixels through a radial-tangential first camera and an equidistant (fisheye)
  // second one: the points come back exactly (to the float storage, 1e-6 of the range) and all
  // are accepted; through the same cameras without their distortion some are off by more than
  // 1 % of their range.
  const testing::TwoViewScene scene = testing::twoViewScene({});
  CameraModel first = scene.camera, second = scene.camera;
  first.distortion_model = DistortionModel::kRadialTangential;
  first.distortion = {-0.25, 0.08, 0.001, -0.0015, 0.0};
  second.distortion_model = DistortionModel::kEquidistant;
  second.distortion = {0.05, -0.01, 0.002, -0.0005};
  std::vector<Eigen::Vector3d> in_second;
  const Transform second_T_first = scene.first_T_second.inverse();
  for (const auto& p : scene.points) in_second.push_back(second_T_first * p);
  Correspondences2D pairs;
  pairs.first = distortedPixels(first, scene.points);
  pairs.second = distortedPixels(second, in_second);
  auto dfn = make(GetParam());
  setInputs(*dfn, scene, pairs);
  dfn->in.camera.set(first);
  dfn->in.second_camera.set(second);
  ASSERT_OK(dfn->process());
  ASSERT_EQ(*dfn->out.accepted, static_cast<int>(scene.points.size()));
  for (std::size_t i = 0; i < scene.points.size(); ++i)
    EXPECT_LT((dfn->out.points->points[i].vec().cast<double>() - scene.points[i]).norm(),
              1e-5 * scene.points[i].norm())
        << i;
  dfn->in.camera.set(scene.camera);
  dfn->in.second_camera.set(scene.camera);
  ASSERT_OK(dfn->process());
  double worst = 0;
  std::size_t k = 0;
  for (std::size_t i = 0; i < scene.points.size(); ++i)
    if ((*dfn->out.status)[i] == "ok")
      worst = std::max(
          worst, (dfn->out.points->points[k++].vec().cast<double>() - scene.points[i]).norm() /
                     scene.points[i].norm());
  EXPECT_GT(worst, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Triangulation, Triangulators, ::testing::Values("Dlt", "Midpoint"));

TEST(Triangulation, OutOfRangeParametersAreRejected) {
  auto node = Registry::instance().create("Triangulation", "Midpoint");
  ASSERT_TRUE(node.isOk());
  for (const char* bad : {"{max_reprojection_error: 0}", "{min_parallax: -1}"}) {
    const Status s = node.value()->configure(YAML::Load(bad));
    EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << bad;
  }
}

}  // namespace
}  // namespace cdff::dfn
