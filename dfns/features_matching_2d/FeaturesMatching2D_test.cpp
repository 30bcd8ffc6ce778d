// FeaturesMatching2D: on descriptor sets built with a known pairing, the matcher must recover it;
// on two views related by a known homography, the accepted matches must agree with it; bad
// inputs must be reported.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "FeaturesMatching2D.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/types/opencv.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<FeaturesMatching2D> make(const std::string& dfi, const std::string& yaml = "{}") {
  return testing::makeDfn<FeaturesMatching2D>("FeaturesMatching2D", dfi, yaml);
}

Features2D featuresFrom(const cv::Mat& descriptors) {
  Features2D f;
  for (int i = 0; i < descriptors.rows; ++i) {
    Keypoint2D k;
    k.position = {static_cast<float>(i), 0.0f};
    f.keypoints.push_back(k);
  }
  f.descriptors = descriptorsFromMat(descriptors).value();
  return f;
}

// `n` random 32-byte descriptors, and the same ones shuffled with `flips` bits flipped in each:
// train feature permutation[i] is the true partner of query feature i.
struct KnownPairing {
  Features2D query, train;
  std::vector<int> permutation;
};

KnownPairing knownPairing(int n, int flips, std::uint32_t seed) {
  std::mt19937 rng(seed);
  cv::Mat q(n, 32, CV_8UC1);
  cv::randu(q, 0, 256);
  KnownPairing p;
  p.permutation.resize(n);
  std::iota(p.permutation.begin(), p.permutation.end(), 0);
  std::shuffle(p.permutation.begin(), p.permutation.end(), rng);
  cv::Mat t(n, 32, CV_8UC1);
  std::uniform_int_distribution<int> bit(0, 255);
  for (int i = 0; i < n; ++i) {
    cv::Mat row = q.row(i).clone();
    std::vector<int> flipped;
    while (static_cast<int>(flipped.size()) < flips) {
      const int b = bit(rng);
      if (std::find(flipped.begin(), flipped.end(), b) != flipped.end()) continue;
      flipped.push_back(b);
      row.at<std::uint8_t>(0, b / 8) ^= static_cast<std::uint8_t>(1u << (b % 8));
    }
    row.copyTo(t.row(p.permutation[i]));
  }
  p.query = featuresFrom(q);
  p.train = featuresFrom(t);
  return p;
}

class Matchers : public ::testing::TestWithParam<std::string> {};

TEST_P(Matchers, AKnownPairingIsRecovered) {
  // Random 256-bit descriptors are ~128 bits apart; 20 flipped bits keep each true partner far
  // closer than any other, so every pair must be found with its exact distance.
  const KnownPairing p = knownPairing(500, 20, 1);
  auto dfn = make(GetParam());
  dfn->in.query.set(p.query);
  dfn->in.train.set(p.train);
  ASSERT_OK(dfn->process());
  const Matches& m = *dfn->out.matches;
  // LSH may miss a neighbour whose bits fall in no shared bucket; brute force may not.
  const std::size_t expected_min = GetParam() == "BruteForceHamming" ? 500 : 475;
  EXPECT_GE(m.size(), expected_min);
  for (const Match& match : m.matches) {
    EXPECT_EQ(match.train, p.permutation[match.query]);
    EXPECT_FLOAT_EQ(match.distance, 20.0f);
  }
  const Correspondences2D& c = *dfn->out.correspondences;
  ASSERT_EQ(c.size(), m.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    EXPECT_EQ(c.first[i].x(), m.matches[i].query);
    EXPECT_EQ(c.second[i].x(), m.matches[i].train);
  }
}

struct TwoViews {
  Features2D a, b;
  cv::Mat h;  // b pixel = h * a pixel
};

TwoViews twoViews() {
  constexpr int kW = 640, kH = 480;
  const cv::Mat scene = testing::texturedScene(kW, kH, 21);
  cv::Mat h = cv::Mat::eye(3, 3, CV_64F);
  cv::getRotationMatrix2D(cv::Point2f(kW / 2.0f, kH / 2.0f), 8.0, 0.95).copyTo(h.rowRange(0, 2));
  cv::Mat warped;
  cv::warpPerspective(scene, warped, h, scene.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 128);
  auto orb = cv::ORB::create(1500);
  TwoViews v;
  v.h = h;
  using Pair = std::pair<const cv::Mat*, Features2D*>;
  for (auto [image, features] : {Pair{&scene, &v.a}, Pair{&warped, &v.b}}) {
    std::vector<cv::KeyPoint> k;
    cv::Mat d;
    orb->detectAndCompute(*image, cv::noArray(), k, d);
    features->keypoints = fromCvKeypoints(k);
    features->descriptors = descriptorsFromMat(d).value();
  }
  return v;
}

// Fraction of the matches that agree with the true homography within 2 px at the keypoint's
// pyramid level (ORB localises a corner to about a pixel of its level, 1.2^octave full pixels).
double precision(const Matches& m, const Correspondences2D& c, const Features2D& query,
                 const cv::Mat& h) {
  int correct = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double tolerance = 2.0 * std::pow(1.2, query.keypoints[m.matches[i].query].octave);
    const cv::Mat p = h * (cv::Mat_<double>(3, 1) << c.first[i].x(), c.first[i].y(), 1.0);
    const Eigen::Vector2d predicted(p.at<double>(0) / p.at<double>(2),
                                    p.at<double>(1) / p.at<double>(2));
    if ((predicted - c.second[i]).norm() < tolerance) ++correct;
  }
  return c.size() ? static_cast<double>(correct) / c.size() : 0.0;
}

TEST_P(Matchers, MatchesOfTwoViewsAgreeWithTheTrueHomographyAndTheRatioTestHelps) {
  const TwoViews v = twoViews();
  auto strict = make(GetParam(), "ratio: 0.75");
  auto loose = make(GetParam(), "ratio: 1.0");
  for (auto* dfn : {strict.get(), loose.get()}) {
    dfn->in.query.set(v.a);
    dfn->in.train.set(v.b);
    ASSERT_OK(dfn->process());
  }
  const double strict_precision =
      precision(*strict->out.matches, *strict->out.correspondences, v.a, v.h);
  const double loose_precision =
      precision(*loose->out.matches, *loose->out.correspondences, v.a, v.h);
  RecordProperty("precision_ratio_0_75", std::to_string(strict_precision));
  RecordProperty("precision_no_ratio", std::to_string(loose_precision));
  EXPECT_GT(strict->out.matches->size(), 300u);
  // Measured: 0.98 with the ratio test, 0.68 without (the rest are lookalike corners).
  EXPECT_GT(strict_precision, 0.95);
  EXPECT_GT(strict_precision, loose_precision);
  for (std::size_t i = 1; i < strict->out.matches->size(); ++i)
    EXPECT_LE(strict->out.matches->matches[i - 1].distance,
              strict->out.matches->matches[i].distance);
}

TEST_P(Matchers, CrossCheckKeepsOnlyMutualNearestNeighbours) {
  const TwoViews v = twoViews();
  auto dfn = make(GetParam(), "{cross_check: true, ratio: 1.0}");
  dfn->in.query.set(v.a);
  dfn->in.train.set(v.b);
  ASSERT_OK(dfn->process());
  ASSERT_GT(dfn->out.matches->size(), 100u);
  // Exact reverse nearest neighbours; LSH is approximate, so a few of its pairs may differ.
  cv::BFMatcher reference(cv::NORM_HAMMING);
  std::vector<cv::DMatch> reverse;
  reference.match(toMat(v.b.descriptors), toMat(v.a.descriptors), reverse);
  int mutual = 0;
  for (const Match& m : dfn->out.matches->matches)
    if (reverse[m.train].trainIdx == m.query) ++mutual;
  const double fraction = static_cast<double>(mutual) / dfn->out.matches->size();
  EXPECT_GE(fraction, GetParam() == "BruteForceHamming" ? 1.0 : 0.95);
}

TEST_P(Matchers, AnEmptySetGivesNoMatchAndAWarning) {
  auto dfn = make(GetParam());
  const KnownPairing p = knownPairing(10, 5, 2);
  dfn->in.query.set(Features2D{});
  dfn->in.train.set(p.train);
  ASSERT_OK(dfn->process());
  EXPECT_EQ(dfn->out.matches->size(), 0u);
  EXPECT_EQ(dfn->out.correspondences->size(), 0u);
  EXPECT_EQ(dfn->diagnostics().warning_count, 1u);
}

TEST_P(Matchers, IncompatibleDescriptorsAreReportedAndLeaveTheOutputsUntouched) {
  auto dfn = make(GetParam());
  const KnownPairing p = knownPairing(50, 5, 3);
  dfn->in.query.set(p.query);
  dfn->in.train.set(p.train);
  ASSERT_OK(dfn->process());
  const auto expect_error = [&](const Features2D& query, const std::string& fragment) {
    dfn->in.query.set(query);
    dfn->in.train.set(p.train);
    testing::expectRejected(*dfn, fragment);
  };
  cv::Mat short_rows(50, 16, CV_8UC1, cv::Scalar(3));
  expect_error(featuresFrom(short_rows), "16 and 32 bytes");
  cv::Mat real(50, 32, CV_32FC1, cv::Scalar(0.5));
  expect_error(featuresFrom(real), "float32");
  Features2D no_descriptors = p.query;
  no_descriptors.descriptors = {};
  expect_error(no_descriptors, "no descriptors");
  Features2D nan_keypoint = p.query;
  nan_keypoint.keypoints[3].position.x() = std::numeric_limits<float>::quiet_NaN();
  expect_error(nan_keypoint, "keypoint 3");
}

INSTANTIATE_TEST_SUITE_P(FeaturesMatching2D, Matchers,
                         ::testing::Values("BruteForceHamming", "FlannLsh"));

TEST(FeaturesMatching2DFlannLsh, HammingTwoDescriptorsAreRefusedWithAnAlternative) {
  auto dfn = make("FlannLsh");
  KnownPairing p = knownPairing(20, 2, 4);
  p.query.descriptors.distance = p.train.descriptors.distance =
      DescriptorMatrix::Distance::kHamming2;
  dfn->in.query.set(p.query);
  dfn->in.train.set(p.train);
  testing::expectRejected(*dfn, "BruteForceHamming");
}

TEST(FeaturesMatching2D, OutOfRangeParametersAreRejected) {
  auto node = Registry::instance().create("FeaturesMatching2D", "FlannLsh");
  ASSERT_TRUE(node.isOk());
  Status s = node.value()->configure(YAML::Load("{ratio: 1.5}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("ratio"), std::string::npos) << s.message();
  s = node.value()->configure(YAML::Load("{key_bits: 40}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  s = node.value()->configure(YAML::Load("{cross_check: maybe}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
}

}  // namespace
}  // namespace cdff::dfn
