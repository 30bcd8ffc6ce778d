#pragma once
// Synthetic data with known ground truth, for unit tests and benchmarks.

#include <cstdint>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "cdff/types/types.hpp"

namespace cdff::testing {

/// A grey image with textured blobs and straight edges, reproducible from `seed`.
cv::Mat texturedScene(int width, int height, std::uint32_t seed);

/// A grey image of one filled axis-aligned rectangle (value 200) on black: its edges are known.
cv::Mat rectangleImage(int width, int height, const cv::Rect& rect);

/// A camera model for a width x height image with focal length f and the centre at the middle.
CameraModel pinholeCamera(int width, int height, double f);

/// An Image wrapping `mat` (8UC1/8UC3/16UC1/32FC1), with an optional camera model.
Image toImage(const cv::Mat& mat, Timestamp stamp = 0);

}  // namespace cdff::testing

#define EXPECT_OK(expr)                                                    \
  do {                                                                     \
    const ::cdff::Status cdff_test_status_ = (expr);                       \
    EXPECT_TRUE(cdff_test_status_.isOk()) << cdff_test_status_.toString(); \
  } while (false)

#define ASSERT_OK(expr)                                                    \
  do {                                                                     \
    const ::cdff::Status cdff_test_status_ = (expr);                       \
    ASSERT_TRUE(cdff_test_status_.isOk()) << cdff_test_status_.toString(); \
  } while (false)
