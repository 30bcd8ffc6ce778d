// ImageUndistortion: dots rendered at the distorted positions of known rays must come back to
// the positions the undistorted pinhole model gives those rays.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "ImageUndistortion.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/types/opencv.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;
constexpr double kDotSigma = 2.0;      // px
constexpr double kDotAmplitude = 250;  // grey levels
constexpr int kWindow = 7;             // px, half-size of the centroid window (3.5 sigma)
constexpr double kGridX0 = -1.2, kGridY0 = -1.0;  // first dot, normalised coordinates
constexpr int kMargin = kWindow + 3;              // px, dots closer to the border are not measured

std::unique_ptr<ImageUndistortion> make(const std::string& dfi, const std::string& yaml = "{}") {
  return testing::makeDfn<ImageUndistortion>("ImageUndistortion", dfi, yaml);
}

// Barrel distortion that moves the image corners by about 80 px.
CameraModel radialTangentialCamera() {
  CameraModel c = testing::pinholeCamera(kWidth, kHeight, 420);
  c.fy = 415;
  c.cx = 322.3;
  c.cy = 236.8;
  c.distortion_model = DistortionModel::kRadialTangential;
  c.distortion = {-0.25, 0.08, 0.001, -0.0008, 0.0};
  return c;
}

// A fisheye lens: equidistant projection, about 30 px from pinhole at 0.6 rad off-axis.
CameraModel equidistantCamera() {
  CameraModel c = testing::pinholeCamera(kWidth, kHeight, 380);
  c.cx = 318.6;
  c.cy = 241.2;
  c.distortion_model = DistortionModel::kEquidistant;
  c.distortion = {0.05, -0.01, 0.002, -0.0005};
  return c;
}

// Rays (normalised image coordinates x/z, y/z) on a grid.
std::vector<cv::Point3d> rays(double step) {
  std::vector<cv::Point3d> out;
  for (double y = kGridY0; y <= 1.0 + 1e-9; y += step)
    for (double x = kGridX0; x <= 1.2 + 1e-9; x += step) out.emplace_back(x, y, 1.0);
  return out;
}

std::vector<cv::Point2d> distortedPixels(const CameraModel& camera,
                                         const std::vector<cv::Point3d>& rays) {
  std::vector<cv::Point2d> pixels;
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  if (camera.distortion_model == DistortionModel::kEquidistant)
    cv::fisheye::projectPoints(rays, pixels, zero, zero, cameraMatrix(camera),
                               distortionCoefficients(camera));
  else
    cv::projectPoints(rays, zero, zero, cameraMatrix(camera), distortionCoefficients(camera),
                      pixels);
  return pixels;
}

bool inside(const cv::Point2d& p, int margin) {
  return p.x >= margin && p.y >= margin && p.x <= kWidth - 1 - margin &&
         p.y <= kHeight - 1 - margin;
}

// The ray (normalised coordinates) that each pixel of the distorted image sees, by OpenCV's
// iterative inversion of the model, converged far below 1e-3 px.
cv::Mat pixelRays(const CameraModel& camera) {
  std::vector<cv::Point2f> pixels;
  pixels.reserve(static_cast<std::size_t>(kWidth) * kHeight);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      pixels.emplace_back(static_cast<float>(x), static_cast<float>(y));
  cv::Mat rays;
  const cv::TermCriteria converged(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12);
  if (camera.distortion_model == DistortionModel::kEquidistant)
    cv::fisheye::undistortPoints(pixels, rays, cameraMatrix(camera), distortionCoefficients(camera),
                                 cv::noArray(), cv::noArray(), converged);
  else
    cv::undistortPoints(pixels, rays, cameraMatrix(camera), distortionCoefficients(camera),
                        cv::noArray(), cv::noArray(), converged);
  return rays.reshape(2, kHeight);
}

// The distorted image of a grid of Gaussian dots of kDotSigma pinhole pixels (fx, fy of the
// camera) centred on the rays of `grid`: the undistorted image with K kept is exactly that dot
// grid, so only the resampling of the DFN can move a dot.
cv::Mat renderDots(const CameraModel& camera, double step) {
  const cv::Mat rays = pixelRays(camera);
  cv::Mat image(kHeight, kWidth, CV_32FC1, cv::Scalar(0));
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const cv::Point2f ray = rays.at<cv::Point2f>(y, x);
      // The nearest dot only: the next is more than 7 sigma away.
      const double gx = kGridX0 + step * std::round((ray.x - kGridX0) / step);
      const double gy = kGridY0 + step * std::round((ray.y - kGridY0) / step);
      const double dx = (ray.x - gx) * camera.fx, dy = (ray.y - gy) * camera.fy;
      image.at<float>(y, x) = static_cast<float>(
          kDotAmplitude * std::exp(-(dx * dx + dy * dy) / (2 * kDotSigma * kDotSigma)));
    }
  return image;
}

Image toFormat(const cv::Mat& grey_float, PixelFormat format) {
  cv::Mat m;
  switch (format) {
    case PixelFormat::kGray8:
      grey_float.convertTo(m, CV_8U);
      break;
    case PixelFormat::kGray16:
      grey_float.convertTo(m, CV_16U, 256.0);
      break;
    case PixelFormat::kFloat32:
      m = grey_float / 255.0;
      break;
    case PixelFormat::kBgr8: {
      cv::Mat grey;
      grey_float.convertTo(grey, CV_8U);
      cv::cvtColor(grey, m, cv::COLOR_GRAY2BGR);
      break;
    }
  }
  return testing::toImage(m, 7);
}

// Intensity centroid in a window, re-centred twice so that a start 1-2 px off still converges.
cv::Point2d centroid(const cv::Mat& image, cv::Point2d start) {
  cv::Point2d c = start;
  for (int iteration = 0; iteration < 3; ++iteration) {
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

cv::Mat greyFloat(const Image& image) {
  cv::Mat m = toMat(image), grey, f;
  // Not in place: toMat()'s view must not be reallocated.
  if (image.format == PixelFormat::kBgr8) {
    cv::cvtColor(m, grey, cv::COLOR_BGR2GRAY);
    m = grey;
  }
  m.convertTo(f, CV_32F);
  return f;
}

struct DotErrors {
  int measured = 0;
  double max_px = 0;
  double rms_px = 0;
};

// Undistorts the dot image of `camera` and compares each dot with the ray's pinhole projection
// in the output model.
DotErrors undistortDots(ImageUndistortion& dfn, const CameraModel& camera, double step,
                        PixelFormat format = PixelFormat::kGray8) {
  const std::vector<cv::Point3d> grid = rays(step);
  const std::vector<cv::Point2d> distorted = distortedPixels(camera, grid);
  std::vector<cv::Point3d> rendered_rays;  // dots wholly inside the input
  for (std::size_t i = 0; i < grid.size(); ++i)
    if (inside(distorted[i], kMargin)) rendered_rays.push_back(grid[i]);
  Image input = toFormat(renderDots(camera, step), format);
  input.camera = camera;
  dfn.in.image.set(input);
  DotErrors e;
  const Status s = dfn.process();
  EXPECT_OK(s);
  if (!s) return e;
  const Image& out = *dfn.out.undistorted;
  EXPECT_EQ(out.width, kWidth);
  EXPECT_EQ(out.height, kHeight);
  EXPECT_EQ(out.format, format);
  EXPECT_EQ(out.stamp, 7);
  EXPECT_EQ(out.frame_id, "camera");
  EXPECT_TRUE(out.camera.has_value());
  if (!out.camera) return e;
  EXPECT_EQ(out.camera->distortion_model, DistortionModel::kNone);
  EXPECT_FALSE(out.camera->hasDistortion());
  const cv::Mat pixels = greyFloat(out);
  double sum2 = 0;
  for (const cv::Point3d& ray : rendered_rays) {
    const Eigen::Vector2d q = out.camera->project({ray.x, ray.y, ray.z});
    const cv::Point2d expected(q.x(), q.y());
    if (!inside(expected, kMargin)) continue;
    const cv::Point2d found = centroid(pixels, expected);
    const double error = std::hypot(found.x - expected.x, found.y - expected.y);
    EXPECT_TRUE(std::isfinite(error)) << "no dot near " << expected;
    e.max_px = std::max(e.max_px, std::isfinite(error) ? error : 1e9);
    sum2 += error * error;
    ++e.measured;
  }
  e.rms_px = e.measured ? std::sqrt(sum2 / e.measured) : 0;
  return e;
}

// Tolerance of the dot positions after undistortion. The input is rendered exactly (each pixel
// shows its own ray), so only the resampling moves a dot:
//  - bilinear interpolation errs by up to t(1-t)/2 |f''| <= A / (8 sigma^2) ~ 8 grey levels near
//    a dot's centre; the error pattern follows the sub-pixel phase of the map, which varies
//    across a dot, so it does not cancel in the centroid: ~10 px of +-4 grey at ~2 px from the
//    centre over a dot mass of 2 pi sigma^2 A ~ 6300 gives ~0.03 px, a little more where
//    alpha = 1 shrinks the dots;
//  - the fixed-point maps place each sample within 1/64 px (5 fractional bits): < 0.016 px;
//  - 8-bit rounding (+-0.5 grey on a 250 dot) moves a centroid by ~0.003 px.
// Hence 0.06 px (measured: rms 0.010-0.016 px, max 0.028-0.047 px). Bicubic adds the clipping
// at 0 of its negative lobes in 8 bits (measured max 0.056 px): 0.08 px. Ignoring the distortion
// would move edge dots by 10-80 px, a principal point off by 0.1 px would move all by 0.1 px.
constexpr double kMaxDotErrorPx = 0.06;
constexpr double kMaxCubicDotErrorPx = 0.08;
// Grid steps (normalised coordinates) keeping dots > 7 sigma apart in every image.
constexpr double kRadTanStep = 0.07;
constexpr double kFisheyeStep = 0.1;

struct Case {
  std::string dfi;
  std::string parameters;
  bool fisheye;
};

// Readable test names in CTest's list (gtest prints unknown parameters as raw bytes).
void PrintTo(const Case& c, std::ostream* os) {
  *os << c.dfi << (c.fisheye ? " equidistant " : " radial-tangential ") << c.parameters;
}

class ImageUndistortionTest : public ::testing::TestWithParam<Case> {};

TEST_P(ImageUndistortionTest, DotsReturnToTheirPinholePositions) {
  const Case& c = GetParam();
  auto dfn = make(c.dfi, c.parameters);
  const CameraModel camera = c.fisheye ? equidistantCamera() : radialTangentialCamera();
  const DotErrors e = undistortDots(*dfn, camera, c.fisheye ? kFisheyeStep : kRadTanStep);
  EXPECT_GE(e.measured, 150);
  const bool cubic = c.parameters.find("cubic") != std::string::npos;
  EXPECT_LE(e.max_px, cubic ? kMaxCubicDotErrorPx : kMaxDotErrorPx)
      << "rms " << e.rms_px << " px over " << e.measured;
  const CameraModel& out = *dfn->out.undistorted->camera;
  if (c.parameters.find("optimal") == std::string::npos) {
    EXPECT_EQ(out.fx, camera.fx);
    EXPECT_EQ(out.fy, camera.fy);
    EXPECT_EQ(out.cx, camera.cx);
    EXPECT_EQ(out.cy, camera.cy);
  } else {
    // alpha = 1 keeps every input pixel of a barrel lens: the output must zoom out.
    EXPECT_LT(out.fx, camera.fx);
  }
}

INSTANTIATE_TEST_SUITE_P(
    AllDfis, ImageUndistortionTest,
    ::testing::Values(Case{"RemapCached", "{}", false}, Case{"RemapCached", "{}", true},
                      Case{"RemapCached", "{interpolation: cubic}", false},
                      Case{"RemapCached", "{new_camera_matrix: optimal, alpha: 1}", false},
                      Case{"RemapCached", "{new_camera_matrix: optimal, alpha: 1}", true},
                      Case{"Direct", "{}", false}, Case{"Direct", "{}", true},
                      Case{"Direct", "{new_camera_matrix: optimal, alpha: 1}", false},
                      Case{"Direct", "{new_camera_matrix: optimal, alpha: 1}", true}),
    [](const ::testing::TestParamInfo<Case>& info) {
      std::string name = info.param.dfi + (info.param.fisheye ? "Equidistant" : "RadTan");
      if (info.param.parameters.find("cubic") != std::string::npos) name += "Cubic";
      if (info.param.parameters.find("optimal") != std::string::npos) name += "Optimal";
      return name;
    });

TEST(ImageUndistortionRemapCached, NearestNeighbourIsWithinHalfAPixel) {
  // Each sample comes from up to 0.5 px away along each axis; the centroid averages them but may
  // keep that bound: 0.5 px per axis, sqrt(0.5) px in all (measured max 0.45 px). Truncated
  // rather than rounded maps would reach 1 px per axis.
  auto dfn = make("RemapCached", "{interpolation: nearest}");
  const DotErrors e = undistortDots(*dfn, radialTangentialCamera(), kRadTanStep);
  EXPECT_GE(e.measured, 150);
  EXPECT_LE(e.max_px, std::sqrt(0.5));
}

TEST(ImageUndistortionRemapCached, EveryPixelFormatIsUndistorted) {
  for (PixelFormat format : {PixelFormat::kBgr8, PixelFormat::kGray16, PixelFormat::kFloat32}) {
    SCOPED_TRACE(toString(format));
    auto dfn = make("RemapCached");
    const DotErrors e = undistortDots(*dfn, radialTangentialCamera(), kRadTanStep, format);
    EXPECT_GE(e.measured, 150);
    EXPECT_LE(e.max_px, kMaxDotErrorPx);
  }
}

TEST(ImageUndistortionRemapCached, MapsFollowACameraModelChange) {
  // Same instance, another lens: cached maps of the first camera would leave the second
  // camera's dots 10-30 px away.
  auto dfn = make("RemapCached");
  EXPECT_LE(undistortDots(*dfn, radialTangentialCamera(), kRadTanStep).max_px, kMaxDotErrorPx);
  EXPECT_LE(undistortDots(*dfn, equidistantCamera(), kFisheyeStep).max_px, kMaxDotErrorPx);
  CameraModel shifted = radialTangentialCamera();
  shifted.cx += 6;
  shifted.distortion[0] = -0.2;
  EXPECT_LE(undistortDots(*dfn, shifted, kRadTanStep).max_px, kMaxDotErrorPx);
}

TEST(ImageUndistortion, BothDfisAgree) {
  // Both compute the same fixed-point bilinear maps (cv::undistort builds them stripe by
  // stripe): a map entry may differ by one 1/32 px step, which on the dots' steepest slope
  // (250 * exp(-1/2) / 1.5 ~ 100 grey/px) is ~3 grey levels; almost all pixels are equal.
  for (const std::string parameters : {"{}", "{new_camera_matrix: optimal, alpha: 0.5}"}) {
    for (bool fisheye : {false, true}) {
      SCOPED_TRACE(parameters + (fisheye ? " equidistant" : " radial_tangential"));
      auto cached = make("RemapCached", parameters);
      auto direct = make("Direct", parameters);
      const CameraModel camera = fisheye ? equidistantCamera() : radialTangentialCamera();
      undistortDots(*cached, camera, kRadTanStep);
      undistortDots(*direct, camera, kRadTanStep);
      ASSERT_TRUE(cached->out.undistorted.hasValue() && direct->out.undistorted.hasValue());
      const CameraModel& a = *cached->out.undistorted->camera;
      const CameraModel& b = *direct->out.undistorted->camera;
      EXPECT_EQ(a.fx, b.fx);
      EXPECT_EQ(a.cx, b.cx);
      cv::Mat diff;
      cv::absdiff(toMat(*cached->out.undistorted), toMat(*direct->out.undistorted), diff);
      double max_diff = 0;
      cv::minMaxLoc(diff, nullptr, &max_diff);
      EXPECT_LE(max_diff, 4.0);
      EXPECT_LE(cv::countNonZero(diff), static_cast<int>(diff.total() / 1000));
    }
  }
}

TEST(ImageUndistortion, UndistortedInputPassesThrough) {
  for (const std::string dfi : {"RemapCached", "Direct"}) {
    auto dfn = make(dfi);
    Image input = testing::toImage(testing::texturedScene(kWidth, kHeight, 3));
    input.camera = testing::pinholeCamera(kWidth, kHeight, 400);
    input.camera->distortion_model = DistortionModel::kRadialTangential;
    input.camera->distortion = {0, 0, 0, 0};
    dfn->in.image.set(input);
    ASSERT_OK(dfn->process());
    EXPECT_EQ(dfn->out.undistorted->pixels.data(), input.pixels.data()) << dfi;
    EXPECT_EQ(dfn->out.undistorted->camera->distortion_model, DistortionModel::kNone);
  }
}

class ImageUndistortionBadInput : public ::testing::TestWithParam<std::string> {
 protected:
  // A good call first, so that each bad call can be seen to leave the output untouched.
  void SetUp() override {
    dfn_ = make(GetParam());
    good_ = testing::toImage(testing::texturedScene(kWidth, kHeight, 1));
    good_.camera = radialTangentialCamera();
    dfn_->in.image.set(good_);
    ASSERT_OK(dfn_->process());
  }
  void expectRejected(const Image& image, const std::string& fragment) {
    dfn_->in.image.set(image);
    testing::expectRejected(*dfn_, fragment);
  }
  std::unique_ptr<ImageUndistortion> dfn_;
  Image good_;
};

TEST_P(ImageUndistortionBadInput, NoCameraModel) {
  Image image = good_;
  image.camera.reset();
  expectRejected(image, "no camera model");
}

TEST_P(ImageUndistortionBadInput, EmptyImage) {
  expectRejected(Image{}, "empty");
}

TEST_P(ImageUndistortionBadInput, CameraModelOfAnotherSize) {
  Image image = good_;
  image.camera->width = 1280;
  image.camera->height = 960;
  expectRejected(image, "1280x960");
}

TEST_P(ImageUndistortionBadInput, NanDistortionCoefficient) {
  Image image = good_;
  image.camera->distortion[1] = std::numeric_limits<double>::quiet_NaN();
  expectRejected(image, "non-finite");
}

TEST_P(ImageUndistortionBadInput, WrongCoefficientCount) {
  Image image = good_;
  image.camera->distortion_model = DistortionModel::kEquidistant;  // 5 coefficients, needs 4
  expectRejected(image, "equidistant");
}

TEST_P(ImageUndistortionBadInput, MissingInput) {
  dfn_->in.image.set(std::shared_ptr<const Image>());
  const Status s = dfn_->process();
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("'image'"), std::string::npos) << s.message();
}

INSTANTIATE_TEST_SUITE_P(AllDfis, ImageUndistortionBadInput,
                         ::testing::Values("RemapCached", "Direct"));

TEST(ImageUndistortion, RejectsBadParameters) {
  for (const std::string dfi : {"RemapCached", "Direct"}) {
    auto node = Registry::instance().create("ImageUndistortion", dfi);
    ASSERT_TRUE(node.isOk());
    Node& dfn = *node.value();
    Status s = dfn.configure(YAML::Load("{new_camera_matrix: optimal, alpha: 1.5}"), "p.yaml");
    EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << dfi;
    EXPECT_NE(s.message().find("alpha"), std::string::npos) << s.message();
    s = dfn.configure(YAML::Load("new_camera_matrix: scaled"), "p.yaml");
    EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << dfi;
    EXPECT_NE(s.message().find("{keep, optimal}"), std::string::npos) << s.message();
  }
  auto node = Registry::instance().create("ImageUndistortion", "RemapCached");
  ASSERT_TRUE(node.isOk());
  const Status s = node.value()->configure(YAML::Load("interpolation: lanczos"), "p.yaml");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("{nearest, linear, cubic}"), std::string::npos) << s.message();
  // Direct is bilinear only: an interpolation key is unknown there.
  auto direct = Registry::instance().create("ImageUndistortion", "Direct");
  ASSERT_TRUE(direct.isOk());
  EXPECT_EQ(direct.value()->configure(YAML::Load("interpolation: cubic"), "p.yaml").code(),
            StatusCode::kInvalidParameter);
}

}  // namespace
}  // namespace cdff::dfn
