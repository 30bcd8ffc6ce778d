// StereoRectification: dots of a known 3D scene, rendered into a distorted, rotated stereo pair,
// must come out on the same row of both rectified images with the disparity f B / Z of the
// rectified cameras.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "StereoRectification.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/types/opencv.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;
constexpr double kDotSigma = 2.0;      // px of the pinhole image of each camera
constexpr double kDotAmplitude = 250;  // grey levels
constexpr int kWindow = 7;             // px, half-size of the centroid window (3.5 sigma)
constexpr int kMargin = kWindow + 3;   // px, dots closer to the border are not measured

std::unique_ptr<StereoRectification> make(const std::string& yaml = "{}") {
  return testing::makeDfn<StereoRectification>("StereoRectification", "OpenCV", yaml);
}

CameraModel camera(double fx, double fy, double cx, double cy, DistortionModel model,
                   std::vector<double> distortion) {
  CameraModel c = testing::pinholeCamera(kWidth, kHeight, fx);
  c.fy = fy;
  c.cx = cx;
  c.cy = cy;
  c.distortion_model = model;
  c.distortion = std::move(distortion);
  return c;
}

struct Rig {
  CameraModel left, right;
  Transform right_T_left;
};

// Two different lenses, the right camera 12 cm to the right, toed in and rolled by a few degrees:
// unrectified, a point's rows differ by up to ~20 px.
Rig radialTangentialRig() {
  Rig rig;
  rig.left = camera(450, 448, 318, 242, DistortionModel::kRadialTangential,
                    {-0.12, 0.03, 0.0005, -0.0003, 0.0});
  rig.right = camera(455, 452, 325, 236, DistortionModel::kRadialTangential,
                     {-0.10, 0.02, -0.0004, 0.0002, 0.0});
  rig.right_T_left.parent_frame = "right";
  rig.right_T_left.child_frame = "left";
  rig.right_T_left.rotation = expSO3(Eigen::Vector3d(0.01, -0.04, 0.015));
  rig.right_T_left.translation = Eigen::Vector3d(-0.12, 0.004, -0.003);
  return rig;
}

Rig equidistantRig() {
  Rig rig = radialTangentialRig();
  rig.left =
      camera(380, 380, 321, 238, DistortionModel::kEquidistant, {0.05, -0.01, 0.002, -0.0005});
  rig.right =
      camera(384, 383, 316, 243, DistortionModel::kEquidistant, {0.04, -0.008, 0.001, -0.0003});
  return rig;
}

// Points of a tilted surface 1.4-3 m in front of the left camera, in the left frame.
std::vector<Eigen::Vector3d> scene() {
  std::vector<Eigen::Vector3d> points;
  for (double y = -0.45; y <= 0.45 + 1e-9; y += 0.075)
    for (double x = -0.6; x <= 0.6 + 1e-9; x += 0.075) {
      const double z = 1.4 + 1.0 * (x + 0.6) + 0.4 * (y + 0.45);
      points.emplace_back(x * z, y * z, z);
    }
  return points;
}

cv::Point2d distortedPixel(const CameraModel& c, const Eigen::Vector3d& p) {
  std::vector<cv::Point3d> object{{p.x(), p.y(), p.z()}};
  std::vector<cv::Point2d> pixels;
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  if (c.distortion_model == DistortionModel::kEquidistant)
    cv::fisheye::projectPoints(object, pixels, zero, zero, cameraMatrix(c),
                               distortionCoefficients(c));
  else
    cv::projectPoints(object, zero, zero, cameraMatrix(c), distortionCoefficients(c), pixels);
  return pixels[0];
}

bool inside(const cv::Point2d& p, int margin) {
  return p.x >= margin && p.y >= margin && p.x <= kWidth - 1 - margin &&
         p.y <= kHeight - 1 - margin;
}

// Renders each point as a Gaussian dot of kDotSigma px in the camera's pinhole image, seen
// through its lens: each pixel shows its own ray (OpenCV's iterative inversion of the model,
// converged far below 1e-3 px), so that only the DFN's resampling can move a dot.
cv::Mat render(const CameraModel& c, const std::vector<Eigen::Vector3d>& points_in_camera) {
  std::vector<cv::Point2f> pixels;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      pixels.emplace_back(static_cast<float>(x), static_cast<float>(y));
  cv::Mat rays;
  const cv::TermCriteria converged(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12);
  if (c.distortion_model == DistortionModel::kEquidistant)
    cv::fisheye::undistortPoints(pixels, rays, cameraMatrix(c), distortionCoefficients(c),
                                 cv::noArray(), cv::noArray(), converged);
  else
    cv::undistortPoints(pixels, rays, cameraMatrix(c), distortionCoefficients(c), cv::noArray(),
                        cv::noArray(), converged);
  rays = rays.reshape(2, kHeight);
  cv::Mat image(kHeight, kWidth, CV_32FC1, cv::Scalar(0));
  constexpr int kReach = 14;  // px around the distorted centre: > 5 sigma with the lens' scaling
  for (const Eigen::Vector3d& p : points_in_camera) {
    const Eigen::Vector2d q = c.project(p);
    const cv::Point2d centre = distortedPixel(c, p);
    if (!inside(centre, 0)) continue;
    for (int y = std::max(0, static_cast<int>(centre.y) - kReach);
         y <= std::min(kHeight - 1, static_cast<int>(centre.y) + kReach); ++y)
      for (int x = std::max(0, static_cast<int>(centre.x) - kReach);
           x <= std::min(kWidth - 1, static_cast<int>(centre.x) + kReach); ++x) {
        const cv::Point2f ray = rays.at<cv::Point2f>(y, x);
        const double dx = c.fx * ray.x + c.cx - q.x(), dy = c.fy * ray.y + c.cy - q.y();
        image.at<float>(y, x) += static_cast<float>(
            kDotAmplitude * std::exp(-(dx * dx + dy * dy) / (2 * kDotSigma * kDotSigma)));
      }
  }
  cv::Mat grey;
  image.convertTo(grey, CV_8U);
  return grey;
}

StereoImagePair renderPair(const Rig& rig, const std::vector<Eigen::Vector3d>& points) {
  std::vector<Eigen::Vector3d> in_right;
  for (const Eigen::Vector3d& p : points) in_right.push_back(rig.right_T_left * p);
  StereoImagePair pair;
  pair.left = testing::toImage(render(rig.left, points), 11);
  pair.right = testing::toImage(render(rig.right, in_right), 11);
  pair.left.frame_id = "left";
  pair.right.frame_id = "right";
  pair.left.camera = rig.left;
  pair.right.camera = rig.right;
  pair.right_T_left = rig.right_T_left;
  return pair;
}

// Intensity centroid in a window, re-centred so that a start a few px off converges.
cv::Point2d centroid(const cv::Mat& grey, cv::Point2d start) {
  cv::Mat image;
  grey.convertTo(image, CV_32F);
  cv::Point2d c = start;
  for (int iteration = 0; iteration < 4; ++iteration) {
    const int x0 = static_cast<int>(std::lround(c.x)), y0 = static_cast<int>(std::lround(c.y));
    double sum = 0, sx = 0, sy = 0;
    for (int y = y0 - kWindow; y <= y0 + kWindow; ++y)
      for (int x = x0 - kWindow; x <= x0 + kWindow; ++x) {
        if (x < 0 || y < 0 || x >= image.cols || y >= image.rows) continue;
        const double v = image.at<float>(y, x);
        sum += v;
        sx += v * x;
        sy += v * y;
      }
    if (sum <= 0) return {std::numeric_limits<double>::quiet_NaN(), 0};
    c = {sx / sum, sy / sum};
  }
  return c;
}

// Where a point should land in a rectified image, from OpenCV's rectification of the same rig:
// only a start for the centroid search, every assertion is on the measured centroids.
std::vector<cv::Point2d> searchStarts(const Rig& rig, const std::vector<Eigen::Vector3d>& points,
                                      bool right, double alpha) {
  const CameraModel& c = right ? rig.right : rig.left;
  const Eigen::Matrix3d r = rig.right_T_left.rotation.toRotationMatrix();
  cv::Mat rm(3, 3, CV_64F), tm(3, 1, CV_64F);
  for (int i = 0; i < 3; ++i) {
    tm.at<double>(i) = rig.right_T_left.translation(i);
    for (int j = 0; j < 3; ++j) rm.at<double>(i, j) = r(i, j);
  }
  cv::Mat r1, r2, p1, p2, q;
  const cv::Size size(kWidth, kHeight);
  const bool fisheye = c.distortion_model == DistortionModel::kEquidistant;
  if (fisheye)
    cv::fisheye::stereoRectify(cameraMatrix(rig.left), distortionCoefficients(rig.left),
                               cameraMatrix(rig.right), distortionCoefficients(rig.right), size, rm,
                               tm, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, size, alpha);
  else
    cv::stereoRectify(cameraMatrix(rig.left), distortionCoefficients(rig.left),
                      cameraMatrix(rig.right), distortionCoefficients(rig.right), size, rm, tm, r1,
                      r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, alpha);
  std::vector<cv::Point2d> distorted, starts;
  for (const Eigen::Vector3d& p : points)
    distorted.push_back(distortedPixel(c, right ? rig.right_T_left * p : p));
  if (fisheye)
    cv::fisheye::undistortPoints(distorted, starts, cameraMatrix(c), distortionCoefficients(c),
                                 right ? r2 : r1, right ? p2 : p1);
  else
    cv::undistortPoints(distorted, starts, cameraMatrix(c), distortionCoefficients(c),
                        right ? r2 : r1, right ? p2 : p1);
  return starts;
}

struct Residuals {
  int measured = 0;
  double max_row_px = 0;        // |v_left - v_right|
  double max_disparity_px = 0;  // |d - f B / Z|
};

// Tolerances. Each dot is resampled once (bilinear, fixed-point maps), which moves its centroid
// by up to ~0.06 px (the derivation is in ImageUndistortion_test.cpp: bilinear error ~0.03 px on
// a sigma = 2 px dot, 1/64 px map quantization, 8-bit rounding). The rectifying homography is a
// rotation of a few degrees, affine to 1e-4 over a dot, so it moves the centroid by < 0.001 px.
// A row or disparity difference combines two centroids: 2 x 0.06 = 0.12 px. Z is obtained from
// the measured left pixel, whose 0.06 px error changes f B / Z by < 0.01 %.
// Measured: rows 0.04-0.065 px, disparities 0.04-0.055 px. Unrectified, rows differ by up to
// ~20 px; ignoring the right lens' distortion leaves 9 px of row error.
constexpr double kMaxRowErrorPx = 0.12;
constexpr double kMaxDisparityErrorPx = 0.12;
// Bicubic adds the 8-bit clipping of its negative lobes (0.08 px per centroid): 0.16 px.
constexpr double kMaxCubicErrorPx = 0.16;

Residuals measure(const StereoRectification& dfn, const Rig& rig,
                  const std::vector<Eigen::Vector3d>& points, double alpha) {
  Residuals res;
  const StereoImagePair& out = *dfn.out.rectified;
  const CameraModel& l = *out.left.camera;
  const CameraModel& r = *out.right.camera;
  const double baseline = *dfn.out.baseline;
  const std::vector<cv::Point2d> left_starts = searchStarts(rig, points, false, alpha);
  const std::vector<cv::Point2d> right_starts = searchStarts(rig, points, true, alpha);
  const cv::Mat left = toMat(out.left), right = toMat(out.right);
  for (std::size_t i = 0; i < points.size(); ++i) {
    // Only dots wholly inside both inputs and both outputs.
    if (!inside(distortedPixel(rig.left, points[i]), kMargin) ||
        !inside(distortedPixel(rig.right, rig.right_T_left * points[i]), kMargin) ||
        !inside(left_starts[i], kMargin) || !inside(right_starts[i], kMargin))
      continue;
    const cv::Point2d a = centroid(left, left_starts[i]);
    const cv::Point2d b = centroid(right, right_starts[i]);
    if (!std::isfinite(a.x) || !std::isfinite(b.x)) {
      ADD_FAILURE() << "no dot near " << left_starts[i] << " / " << right_starts[i];
      continue;
    }
    // The range |p| does not depend on the rotation into the rectified frame; with the measured
    // left ray it gives the rectified depth Z and the disparity f B / Z.
    const Eigen::Vector3d ray((a.x - l.cx) / l.fx, (a.y - l.cy) / l.fy, 1.0);
    const double z = points[i].norm() / ray.norm();
    const double disparity = (a.x - l.cx) - (b.x - r.cx);
    res.max_row_px = std::max(res.max_row_px, std::abs(a.y - b.y));
    res.max_disparity_px =
        std::max(res.max_disparity_px, std::abs(disparity - l.fx * baseline / z));
    ++res.measured;
  }
  return res;
}

struct Case {
  bool fisheye;
  std::string parameters;
  double alpha;
  double tolerance_px;  // on rows and disparities
};

// Readable test names in CTest's list (gtest prints unknown parameters as raw bytes).
void PrintTo(const Case& c, std::ostream* os) {
  *os << (c.fisheye ? "equidistant " : "radial-tangential ") << c.parameters;
}

// Nearest neighbour: each centroid may be off by 0.5 px per axis (see the ImageUndistortion
// test), two of them by 1 px.
constexpr double kMaxNearestErrorPx = 1.0;

class StereoRectificationTest : public ::testing::TestWithParam<Case> {};

TEST_P(StereoRectificationTest, CorrespondingPointsShareARowAndDisparityMatchesDepth) {
  const Case& c = GetParam();
  const Rig rig = c.fisheye ? equidistantRig() : radialTangentialRig();
  const std::vector<Eigen::Vector3d> points = scene();
  auto dfn = make(c.parameters);
  dfn->in.stereo.set(renderPair(rig, points));
  ASSERT_OK(dfn->process());

  const StereoImagePair& out = *dfn->out.rectified;
  EXPECT_NEAR(*dfn->out.baseline, rig.right_T_left.translation.norm(), 1e-9);
  EXPECT_NEAR(out.right_T_left.translation.x(), -*dfn->out.baseline, 1e-9);
  EXPECT_EQ(out.right_T_left.translation.y(), 0.0);
  EXPECT_EQ(out.right_T_left.translation.z(), 0.0);
  EXPECT_EQ(out.right_T_left.rotation.angularDistance(Eigen::Quaterniond::Identity()), 0.0);
  EXPECT_EQ(out.right_T_left.parent_frame, "right_rectified");
  EXPECT_EQ(out.right_T_left.child_frame, "left_rectified");
  EXPECT_EQ(out.left.frame_id, "left_rectified");
  EXPECT_EQ(out.left.stamp, 11);
  EXPECT_OK(out.validate());
  ASSERT_TRUE(out.left.camera && out.right.camera);
  const CameraModel& l = *out.left.camera;
  const CameraModel& r = *out.right.camera;
  EXPECT_EQ(l.distortion_model, DistortionModel::kNone);
  EXPECT_EQ(r.distortion_model, DistortionModel::kNone);
  // Row alignment needs one focal length and one cy for both rectified cameras.
  EXPECT_EQ(l.fy, r.fy);
  EXPECT_EQ(l.cy, r.cy);
  EXPECT_EQ(l.fx, r.fx);
  EXPECT_EQ(l.cx, r.cx);  // zero_disparity (the default)

  // The rectified left frame shares the left camera's centre and has the baseline along its x:
  // the right camera's centre, c = -R^T t in the left frame, is at (baseline, 0, 0) in it.
  const Transform& left_T_rectified = *dfn->out.rectified_frame;
  EXPECT_EQ(left_T_rectified.parent_frame, "left");
  EXPECT_EQ(left_T_rectified.child_frame, "left_rectified");
  EXPECT_EQ(left_T_rectified.translation, Eigen::Vector3d::Zero());
  const Eigen::Vector3d right_centre =
      -(rig.right_T_left.rotation.conjugate() * rig.right_T_left.translation);
  const Eigen::Vector3d in_rectified = left_T_rectified.rotation.conjugate() * right_centre;
  EXPECT_NEAR(in_rectified.x(), *dfn->out.baseline, 1e-9);
  EXPECT_NEAR(in_rectified.y(), 0.0, 1e-9);
  EXPECT_NEAR(in_rectified.z(), 0.0, 1e-9);

  const Residuals res = measure(*dfn, rig, points, c.alpha);
  EXPECT_GE(res.measured, 80);
  EXPECT_LE(res.max_row_px, c.tolerance_px);
  EXPECT_LE(res.max_disparity_px, c.tolerance_px);
}

INSTANTIATE_TEST_SUITE_P(
    Rigs, StereoRectificationTest,
    ::testing::Values(Case{false, "{}", 0.0, kMaxRowErrorPx},
                      Case{false, "{alpha: 1}", 1.0, kMaxRowErrorPx},
                      Case{true, "{}", 0.0, kMaxRowErrorPx},
                      Case{false, "{interpolation: cubic}", 0.0, kMaxCubicErrorPx},
                      Case{false, "{interpolation: nearest}", 0.0, kMaxNearestErrorPx}),
    [](const ::testing::TestParamInfo<Case>& info) {
      std::string name = info.param.fisheye ? "Equidistant" : "RadTan";
      name += info.param.alpha > 0 ? "Alpha1" : "Alpha0";
      if (info.param.parameters.find("cubic") != std::string::npos) name += "Cubic";
      if (info.param.parameters.find("nearest") != std::string::npos) name += "Nearest";
      return name;
    });

TEST(StereoRectificationOpenCV, MapsFollowACalibrationChange) {
  // One instance, two rigs: maps cached for the first would leave the second's rows ~20 px apart.
  const std::vector<Eigen::Vector3d> points = scene();
  auto dfn = make();
  Rig rig = radialTangentialRig();
  dfn->in.stereo.set(renderPair(rig, points));
  ASSERT_OK(dfn->process());
  EXPECT_LE(measure(*dfn, rig, points, 0).max_row_px, kMaxRowErrorPx);
  rig.right_T_left.rotation = expSO3(Eigen::Vector3d(-0.02, 0.03, -0.03));
  dfn->in.stereo.set(renderPair(rig, points));
  ASSERT_OK(dfn->process());
  const Residuals res = measure(*dfn, rig, points, 0);
  EXPECT_GE(res.measured, 80);
  EXPECT_LE(res.max_row_px, kMaxRowErrorPx);
  EXPECT_LE(res.max_disparity_px, kMaxDisparityErrorPx);
}

TEST(StereoRectificationOpenCV, WithoutZeroDisparityPrincipalPointsMayDiffer) {
  // Disparity is then (u_l - cx_l) - (u_r - cx_r); measure() uses that form, so the geometry
  // must hold whichever principal points OpenCV picks.
  const std::vector<Eigen::Vector3d> points = scene();
  const Rig rig = radialTangentialRig();
  auto dfn = make("{zero_disparity: false}");
  dfn->in.stereo.set(renderPair(rig, points));
  ASSERT_OK(dfn->process());
  const CameraModel& l = *dfn->out.rectified->left.camera;
  const CameraModel& r = *dfn->out.rectified->right.camera;
  EXPECT_EQ(l.cy, r.cy);
  EXPECT_NE(l.cx, r.cx);
}

class StereoRectificationBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dfn_ = make();
    good_ = renderPair(radialTangentialRig(), scene());
    dfn_->in.stereo.set(good_);
    ASSERT_OK(dfn_->process());
  }
  void expectRejected(const StereoImagePair& pair, const std::string& fragment) {
    dfn_->in.stereo.set(pair);
    testing::expectRejected(*dfn_, fragment);
  }
  std::unique_ptr<StereoRectification> dfn_;
  StereoImagePair good_;
};

TEST_F(StereoRectificationBadInput, SizeMismatch) {
  StereoImagePair pair = good_;
  pair.right = testing::toImage(cv::Mat(240, 320, CV_8UC1, cv::Scalar(0)));
  pair.right.camera = testing::pinholeCamera(320, 240, 200);
  expectRejected(pair, "differ in size");
}

TEST_F(StereoRectificationBadInput, MissingCalibration) {
  StereoImagePair pair = good_;
  pair.right.camera.reset();
  expectRejected(pair, "camera model");
}

TEST_F(StereoRectificationBadInput, NonFiniteExtrinsics) {
  StereoImagePair pair = good_;
  pair.right_T_left.translation.y() = std::numeric_limits<double>::quiet_NaN();
  expectRejected(pair, "nan");
}

TEST_F(StereoRectificationBadInput, ZeroBaseline) {
  StereoImagePair pair = good_;
  pair.right_T_left.translation.setZero();
  expectRejected(pair, "min_baseline");
}

TEST_F(StereoRectificationBadInput, VerticalRig) {
  StereoImagePair pair = good_;
  pair.right_T_left.translation = Eigen::Vector3d(0.01, -0.12, 0);
  expectRejected(pair, "vertical");
}

TEST_F(StereoRectificationBadInput, EmptyImage) {
  StereoImagePair pair = good_;
  pair.left = Image{};
  expectRejected(pair, "empty");
}

TEST_F(StereoRectificationBadInput, DifferentPixelFormats) {
  StereoImagePair pair = good_;
  cv::Mat wide;
  toMat(good_.right).convertTo(wide, CV_16U, 256);
  pair.right = testing::toImage(wide);
  pair.right.camera = good_.right.camera;
  expectRejected(pair, "pixel format");
}

TEST_F(StereoRectificationBadInput, MixedDistortionModels) {
  StereoImagePair pair = good_;
  pair.right.camera = equidistantRig().right;
  expectRejected(pair, "mixes distortion models");
}

TEST_F(StereoRectificationBadInput, NanIntrinsics) {
  StereoImagePair pair = good_;
  pair.left.camera->cx = std::numeric_limits<double>::quiet_NaN();
  expectRejected(pair, "cx");
}

TEST(StereoRectificationOpenCV, RejectsBadParameters) {
  auto node = Registry::instance().create("StereoRectification", "OpenCV");
  ASSERT_TRUE(node.isOk());
  Node& dfn = *node.value();
  Status s = dfn.configure(YAML::Load("alpha: -1"), "p.yaml");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("alpha"), std::string::npos) << s.message();
  s = dfn.configure(YAML::Load("interpolation: area"), "p.yaml");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("{nearest, linear, cubic}"), std::string::npos) << s.message();
  s = dfn.configure(YAML::Load("min_baseline: 0"), "p.yaml");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("min_baseline"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace cdff::dfn
