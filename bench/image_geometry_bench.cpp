// Image geometry DFNs on the seed's Prosilica GC1600H frame (1624x1234, 8UC1): ImageUndistortion
// (RemapCached, Direct) and StereoRectification (OpenCV), beside the raw OpenCV calls they wrap
// (cv::remap with precomputed maps, cv::undistort) so that the framework overhead is visible.
#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "ImageUndistortion.gen.hpp"
#include "StereoRectification.gen.hpp"
#include "bench_support.hpp"
#include "cdff/types/opencv.hpp"

namespace {

using cdff::CameraModel;
using cdff::DistortionModel;
using cdff::Image;

constexpr int kWidth = 1624;
constexpr int kHeight = 1234;

// A 4.8 mm lens on the GC1600H's 4.4 um pixels: f ~ 1090 px, moderate barrel distortion.
CameraModel camera(double cx_offset = 0) {
  CameraModel c;
  c.width = kWidth;
  c.height = kHeight;
  c.fx = 1090;
  c.fy = 1088;
  c.cx = (kWidth - 1) / 2.0 + 3.1 + cx_offset;
  c.cy = (kHeight - 1) / 2.0 - 2.4;
  c.distortion_model = DistortionModel::kRadialTangential;
  c.distortion = {-0.21, 0.09, 0.0004, -0.0006, -0.01};
  return c;
}

Image frame(std::uint64_t seed) {
  cv::Mat m(kHeight, kWidth, CV_8UC1);
  cv::theRNG().state = seed;
  cv::randu(m, 0, 256);
  cv::GaussianBlur(m, m, cv::Size(0, 0), 2.0);  // texture, not white noise
  Image image = cdff::fromMat(m, 1, "camera").value();
  image.camera = camera();
  return image;
}

using cdff::bench::createConfigured;

void setPixels(benchmark::State& state, int images) {
  state.SetItemsProcessed(state.iterations() * images);
  state.SetBytesProcessed(state.iterations() * images * static_cast<std::int64_t>(kWidth) *
                          kHeight);
}

void BM_ImageUndistortion(benchmark::State& state, const char* dfi, const char* yaml) {
  auto dfn = createConfigured<cdff::dfn::ImageUndistortion>("ImageUndistortion", dfi, yaml);
  if (!dfn) {
    state.SkipWithError("cannot create or configure the DFI");
    return;
  }
  dfn->in.image.set(frame(1));
  for (auto _ : state) {
    const cdff::Status s = dfn->process();
    if (!s) {
      state.SkipWithError(s.toString().c_str());
      return;
    }
    benchmark::DoNotOptimize(dfn->out.undistorted.get());
  }
  setPixels(state, 1);
}
BENCHMARK_CAPTURE(BM_ImageUndistortion, RemapCached_linear, "RemapCached", "{}")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ImageUndistortion, RemapCached_nearest, "RemapCached",
                  "{interpolation: nearest}")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ImageUndistortion, RemapCached_cubic, "RemapCached", "{interpolation: cubic}")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ImageUndistortion, Direct, "Direct", "{}")->Unit(benchmark::kMillisecond);

// The camera model changes every frame (e.g. an online-calibrated principal point): the cache
// never hits, RemapCached pays initUndistortRectifyMap each call.
void BM_ImageUndistortion_RemapCached_calibrationChangesEveryFrame(benchmark::State& state) {
  auto dfn =
      createConfigured<cdff::dfn::ImageUndistortion>("ImageUndistortion", "RemapCached", "{}");
  Image images[2] = {frame(1), frame(1)};
  images[1].camera = camera(0.5);
  std::size_t i = 0;
  for (auto _ : state) {
    dfn->in.image.set(images[i++ % 2]);
    if (!dfn->process()) {
      state.SkipWithError("process failed");
      return;
    }
  }
  setPixels(state, 1);
}
BENCHMARK(BM_ImageUndistortion_RemapCached_calibrationChangesEveryFrame)
    ->Unit(benchmark::kMillisecond);

// Raw OpenCV: remap with the fixed-point maps precomputed (what RemapCached does per frame).
void BM_OpenCV_remap_linear(benchmark::State& state) {
  const Image image = frame(1);
  const CameraModel c = camera();
  cv::Mat map1, map2, out;
  cv::initUndistortRectifyMap(cdff::cameraMatrix(c), cdff::distortionCoefficients(c), cv::Mat(),
                              cdff::cameraMatrix(c), cv::Size(kWidth, kHeight), CV_16SC2, map1,
                              map2);
  const cv::Mat src = cdff::toMat(image);
  for (auto _ : state) {
    cv::remap(src, out, map1, map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    benchmark::DoNotOptimize(out.data);
  }
  setPixels(state, 1);
}
BENCHMARK(BM_OpenCV_remap_linear)->Unit(benchmark::kMillisecond);

// Raw OpenCV: cv::undistort (what Direct does per frame).
void BM_OpenCV_undistort(benchmark::State& state) {
  const Image image = frame(1);
  const CameraModel c = camera();
  const cv::Mat src = cdff::toMat(image), k = cdff::cameraMatrix(c),
                d = cdff::distortionCoefficients(c);
  cv::Mat out;
  for (auto _ : state) {
    cv::undistort(src, out, k, d, k);
    benchmark::DoNotOptimize(out.data);
  }
  setPixels(state, 1);
}
BENCHMARK(BM_OpenCV_undistort)->Unit(benchmark::kMillisecond);

cdff::StereoImagePair stereoPair() {
  cdff::StereoImagePair pair;
  pair.left = frame(1);
  pair.right = frame(2);
  pair.right.camera = camera(-7.3);
  pair.right_T_left.rotation = cdff::expSO3(Eigen::Vector3d(0.004, -0.02, 0.006));
  pair.right_T_left.translation = Eigen::Vector3d(-0.25, 0.002, 0.001);
  return pair;
}

void BM_StereoRectification_OpenCV(benchmark::State& state) {
  auto dfn =
      createConfigured<cdff::dfn::StereoRectification>("StereoRectification", "OpenCV", "{}");
  if (!dfn) {
    state.SkipWithError("cannot create or configure the DFI");
    return;
  }
  dfn->in.stereo.set(stereoPair());
  for (auto _ : state) {
    const cdff::Status s = dfn->process();
    if (!s) {
      state.SkipWithError(s.toString().c_str());
      return;
    }
    benchmark::DoNotOptimize(dfn->out.rectified.get());
  }
  setPixels(state, 2);
}
BENCHMARK(BM_StereoRectification_OpenCV)->Unit(benchmark::kMillisecond);

// Raw OpenCV: two cv::remap calls with the rectification maps precomputed.
void BM_OpenCV_stereo_remap_linear(benchmark::State& state) {
  const cdff::StereoImagePair pair = stereoPair();
  const CameraModel &l = *pair.left.camera, &r = *pair.right.camera;
  const Eigen::Matrix3d rot = pair.right_T_left.rotation.toRotationMatrix();
  cv::Mat rm(3, 3, CV_64F), tm(3, 1, CV_64F);
  for (int i = 0; i < 3; ++i) {
    tm.at<double>(i) = pair.right_T_left.translation(i);
    for (int j = 0; j < 3; ++j) rm.at<double>(i, j) = rot(i, j);
  }
  const cv::Size size(kWidth, kHeight);
  cv::Mat r1, r2, p1, p2, q, lm1, lm2, rm1, rm2, lo, ro;
  cv::stereoRectify(cdff::cameraMatrix(l), cdff::distortionCoefficients(l), cdff::cameraMatrix(r),
                    cdff::distortionCoefficients(r), size, rm, tm, r1, r2, p1, p2, q,
                    cv::CALIB_ZERO_DISPARITY, 0, size);
  cv::initUndistortRectifyMap(cdff::cameraMatrix(l), cdff::distortionCoefficients(l), r1, p1, size,
                              CV_16SC2, lm1, lm2);
  cv::initUndistortRectifyMap(cdff::cameraMatrix(r), cdff::distortionCoefficients(r), r2, p2, size,
                              CV_16SC2, rm1, rm2);
  const cv::Mat left = cdff::toMat(pair.left), right = cdff::toMat(pair.right);
  for (auto _ : state) {
    cv::remap(left, lo, lm1, lm2, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    cv::remap(right, ro, rm1, rm2, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    benchmark::DoNotOptimize(lo.data);
    benchmark::DoNotOptimize(ro.data);
  }
  setPixels(state, 2);
}
BENCHMARK(BM_OpenCV_stereo_remap_linear)->Unit(benchmark::kMillisecond);

}  // namespace
CDFF_BENCHMARK_MAIN();
