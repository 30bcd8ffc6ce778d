// Conversions to and from OpenCV and PCL: zero-copy where the layout allows.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "cdff/types/opencv.hpp"
#include "cdff/types/pcl.hpp"
#include "support/synthetic.hpp"

namespace cdff {
namespace {

TEST(OpenCv, FromMatSharesPixels) {
  cv::Mat mat(48, 64, CV_8UC3, cv::Scalar(1, 2, 3));
  auto image = fromMat(mat, 5, "cam");
  ASSERT_TRUE(image.isOk());
  EXPECT_EQ(image->pixels.data(), mat.data);
  EXPECT_EQ(image->format, PixelFormat::kBgr8);
  EXPECT_EQ(image->stride_bytes, mat.step[0]);
  EXPECT_EQ(image->at<cv::Vec3b>(10, 20)[2], 3);
}

TEST(OpenCv, RoiKeepsItsStrideWithoutCopy) {
  cv::Mat mat(100, 100, CV_16UC1, cv::Scalar(7));
  cv::Mat roi = mat(cv::Rect(10, 20, 30, 40));
  auto image = fromMat(roi);
  ASSERT_TRUE(image.isOk());
  EXPECT_EQ(image->width, 30);
  EXPECT_EQ(image->stride_bytes, 200u);
  EXPECT_OK(image->validate());
  EXPECT_EQ(image->pixels.data(), roi.data);
}

TEST(OpenCv, ToMatViewsPixelsAndKeepsThemAlive) {
  cv::Mat view;
  const std::uint8_t* pixels = nullptr;
  {
    auto image = Image::fromBytes(std::vector<std::uint8_t>(32 * 16, 9), 32, 16,
                                  PixelFormat::kGray8);
    ASSERT_TRUE(image.isOk());
    pixels = image->pixels.data();
    view = toMat(*image);
  }  // the image is gone; the Mat still owns a reference to its pixels
  EXPECT_EQ(view.data, pixels);
  EXPECT_EQ(view.at<uchar>(15, 31), 9);
  cv::Mat copy = view;  // Mat copies share the reference count
  view.release();
  EXPECT_EQ(copy.at<uchar>(0, 0), 9);
}

TEST(OpenCv, ReallocatingAViewInPlaceLeavesTheImageIntact) {
  cv::Mat colour(16, 16, CV_8UC3, cv::Scalar(10, 20, 30));
  auto image = fromMat(colour.clone());
  ASSERT_TRUE(image.isOk());
  cv::Mat view = toMat(*image);
  cv::cvtColor(view, view, cv::COLOR_BGR2GRAY);  // reallocates the Mat, must not free our pixels
  EXPECT_EQ(view.type(), CV_8UC1);
  EXPECT_EQ(image->at<cv::Vec3b>(3, 3)[2], 30);
  cv::Mat again = toMat(*image);
  again.create(4, 4, CV_32FC1);
  EXPECT_EQ(image->at<cv::Vec3b>(15, 15)[0], 10);
}

TEST(OpenCv, UnsupportedMatTypeIsRejected) {
  auto image = fromMat(cv::Mat(4, 4, CV_64FC1));
  ASSERT_FALSE(image.isOk());
  EXPECT_NE(image.status().message().find("expected 8UC1, 8UC3, 16UC1 or 32FC1"),
            std::string::npos);
}

TEST(OpenCv, DescriptorsAndKeypointsRoundTrip) {
  cv::Mat d(5, 32, CV_8UC1);
  cv::randu(d, 0, 255);
  auto descriptors = descriptorsFromMat(d);
  ASSERT_TRUE(descriptors.isOk());
  EXPECT_OK(descriptors->validate());
  EXPECT_EQ(cv::norm(toMat(*descriptors), d, cv::NORM_L1), 0.0);
  EXPECT_EQ(toMat(*descriptors).data, d.data);

  std::vector<cv::KeyPoint> kps{cv::KeyPoint(1.5f, 2.5f, 31.0f, 45.0f, 0.7f, 2)};
  auto back = toCvKeypoints(fromCvKeypoints(kps));
  EXPECT_EQ(back[0].pt, kps[0].pt);
  EXPECT_EQ(back[0].octave, 2);
  EXPECT_FLOAT_EQ(back[0].angle, 45.0f);
}

TEST(Pcl, FromPclIsZeroCopyAndToPclCopiesExactly) {
  auto pcl_cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (int i = 0; i < 1000; ++i) pcl_cloud->push_back(pcl::PointXYZ(i, 2.0f * i, -i));
  pcl_cloud->header.frame_id = "lidar";
  pcl_cloud->header.stamp = 1234;
  PointCloud cloud = fromPcl(pcl::PointCloud<pcl::PointXYZ>::ConstPtr(pcl_cloud));
  EXPECT_EQ(reinterpret_cast<const void*>(cloud.points.data()),
            reinterpret_cast<const void*>(pcl_cloud->points.data()));
  EXPECT_EQ(cloud.frame_id, "lidar");
  EXPECT_EQ(cloud.stamp, 1234);
  EXPECT_EQ(cloud.points[999].y, 1998.0f);

  auto back = toPcl(cloud);
  ASSERT_EQ(back->size(), 1000u);
  EXPECT_EQ((*back)[500].x, 500.0f);
  EXPECT_EQ((*back)[500].z, -500.0f);
  EXPECT_EQ(back->header.frame_id, "lidar");
}

TEST(Pcl, NormalsRoundTrip) {
  PointCloud cloud = PointCloud::fromXyz({{1, 2, 3}});
  EXPECT_FALSE(toPclWithNormals(cloud).isOk());
  cloud.normals = Buffer<Point4f>::fromVector({Point4f(0, 0, 1)});
  auto pcl_cloud = toPclWithNormals(cloud);
  ASSERT_TRUE(pcl_cloud.isOk());
  PointCloud back = fromPcl(pcl::PointCloud<pcl::PointNormal>::ConstPtr(pcl_cloud.value()));
  EXPECT_EQ(back.normals[0].z, 1.0f);
  EXPECT_EQ(back.points[0].y, 2.0f);
}

}  // namespace
}  // namespace cdff
