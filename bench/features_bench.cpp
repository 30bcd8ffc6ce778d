// Feature DFNs on the seed's Prosilica GC1600H frame (1624x1234, 8UC1): EdgeDetection (Canny,
// Sobel), FeaturesExtraction2D (ORB, AKAZE) and FeaturesMatching2D (brute force, FLANN LSH),
// each beside the raw OpenCV call it wraps, in the same run, so that the framework's overhead is
// visible.
#include <benchmark/benchmark.h>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "EdgeDetection.gen.hpp"
#include "FeaturesExtraction2D.gen.hpp"
#include "FeaturesMatching2D.gen.hpp"
#include "bench_support.hpp"
#include "cdff/types/opencv.hpp"

namespace {

constexpr int kWidth = 1624;
constexpr int kHeight = 1234;

// Random shapes on a mid-grey background: corners and edges everywhere, like a textured target.
cv::Mat scene(std::uint32_t seed) {
  cv::RNG rng(seed);
  cv::Mat image(kHeight, kWidth, CV_8UC1, cv::Scalar(100));
  for (int i = 0; i < 2500; ++i) {
    const cv::Point c(rng.uniform(0, kWidth), rng.uniform(0, kHeight));
    const cv::Scalar grey(rng.uniform(10, 245));
    if (i % 2)
      cv::circle(image, c, rng.uniform(4, 40), grey, cv::FILLED);
    else
      cv::rectangle(image, cv::Rect(c, cv::Size(rng.uniform(4, 40), rng.uniform(4, 40))), grey,
                    cv::FILLED);
  }
  return image;
}

// The same scene rotated by 5 degrees: a second view to match against.
cv::Mat secondView() {
  cv::Mat rotated;
  cv::warpAffine(scene(1), rotated,
                 cv::getRotationMatrix2D(cv::Point2f(kWidth / 2.0f, kHeight / 2.0f), 5.0, 1.0),
                 cv::Size(kWidth, kHeight), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 100);
  return rotated;
}

using cdff::bench::createConfigured;

void BM_EdgeDetection(benchmark::State& state, const char* dfi) {
  auto dfn = createConfigured<cdff::dfn::EdgeDetection>("EdgeDetection", dfi, "{}");
  dfn->in.image.set(cdff::fromMat(scene(1)).value());
  for (auto _ : state)
    if (!dfn->process()) state.SkipWithError("EdgeDetection failed");
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_EdgeDetection, Canny, "Canny")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_EdgeDetection, Sobel, "Sobel")->Unit(benchmark::kMillisecond);

void BM_OpenCV_Canny(benchmark::State& state) {
  const cv::Mat image = scene(1);
  cv::Mat edges;
  for (auto _ : state) cv::Canny(image, edges, 50, 150);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_OpenCV_Canny)->Unit(benchmark::kMillisecond);

void BM_FeaturesExtraction2D(benchmark::State& state, const char* dfi) {
  auto dfn = createConfigured<cdff::dfn::FeaturesExtraction2D>("FeaturesExtraction2D", dfi,
                                                               "max_features: 2000");
  dfn->in.image.set(cdff::fromMat(scene(1)).value());
  for (auto _ : state)
    if (!dfn->process()) state.SkipWithError("FeaturesExtraction2D failed");
  state.counters["features"] = static_cast<double>(dfn->out.features->size());
}
BENCHMARK_CAPTURE(BM_FeaturesExtraction2D, Orb, "Orb")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_FeaturesExtraction2D, Akaze, "Akaze")->Unit(benchmark::kMillisecond);

void BM_OpenCV_ORB_detectAndCompute(benchmark::State& state) {
  const cv::Mat image = scene(1);
  auto orb = cv::ORB::create(2000);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  for (auto _ : state) orb->detectAndCompute(image, cv::noArray(), keypoints, descriptors);
  state.counters["features"] = static_cast<double>(keypoints.size());
}
BENCHMARK(BM_OpenCV_ORB_detectAndCompute)->Unit(benchmark::kMillisecond);

void BM_FeaturesMatching2D(benchmark::State& state, const char* dfi) {
  auto extract = createConfigured<cdff::dfn::FeaturesExtraction2D>("FeaturesExtraction2D", "Orb",
                                                                   "max_features: 2000");
  auto match = createConfigured<cdff::dfn::FeaturesMatching2D>("FeaturesMatching2D", dfi, "{}");
  extract->in.image.set(cdff::fromMat(scene(1)).value());
  (void)extract->process();
  match->in.query.set(extract->out.features.shared());
  extract->in.image.set(cdff::fromMat(secondView()).value());
  (void)extract->process();
  match->in.train.set(extract->out.features.shared());
  for (auto _ : state)
    if (!match->process()) state.SkipWithError("FeaturesMatching2D failed");
  state.counters["matches"] = static_cast<double>(match->out.matches->size());
}
BENCHMARK_CAPTURE(BM_FeaturesMatching2D, BruteForceHamming, "BruteForceHamming")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_FeaturesMatching2D, FlannLsh, "FlannLsh")->Unit(benchmark::kMillisecond);

void BM_OpenCV_BFMatcher_knn2(benchmark::State& state) {
  auto orb = cv::ORB::create(2000);
  std::vector<cv::KeyPoint> k1, k2;
  cv::Mat d1, d2;
  orb->detectAndCompute(scene(1), cv::noArray(), k1, d1);
  orb->detectAndCompute(secondView(), cv::noArray(), k2, d2);
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  for (auto _ : state) matcher.knnMatch(d1, d2, knn, 2);
}
BENCHMARK(BM_OpenCV_BFMatcher_knn2)->Unit(benchmark::kMillisecond);

}  // namespace

CDFF_BENCHMARK_MAIN();
