// DepthToPointCloud/Pinhole on synthetic depth maps: a tilted plane comes back as points on that
// plane, a distorted camera's points project back onto their pixels, pixels without a
// measurement and outside the ranges are left out, and bad inputs are reported.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>

#include "DepthToPointCloud.gen.hpp"
#include "cdff/types/opencv.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<DepthToPointCloud> make(const std::string& yaml = "{}") {
  return testing::makeDfn<DepthToPointCloud>("DepthToPointCloud", "Pinhole", yaml);
}

/// A depth map of the camera `camera` whose pixel (u, v) holds depth(u, v) metres (32FC1).
template <typename Depth>
DepthMap depthMap(const CameraModel& camera, Depth depth) {
  cv::Mat metres(camera.height, camera.width, CV_32F);
  for (int v = 0; v < camera.height; ++v)
    for (int u = 0; u < camera.width; ++u) metres.at<float>(v, u) = depth(u, v);
  DepthMap map;
  map.image = testing::toImage(metres, 5'000'000);
  map.image.frame_id = "tof_optical";
  map.image.camera = camera;
  return map;
}

// The plane n . p = d seen by an ideal pinhole: the depth along the axis of pixel (u, v) is
// d / (n . ray) with ray = ((u - cx) / f, (v - cy) / f, 1). Every point must lie on the plane
// (float precision: 1e-5 of the range) and there is one per pixel.
TEST(DepthToPointCloudPinhole, ATiltedPlaneComesBackOnThePlane) {
  const CameraModel camera = testing::pinholeCamera(64, 48, 60.0);
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.2, 1.0).normalized();
  const double d = 4.0;
  const DepthMap map = depthMap(camera, [&](int u, int v) {
    const Eigen::Vector3d ray((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
    return static_cast<float>(d / n.dot(ray));
  });
  auto node = make();
  node->in.depth.set(map);
  ASSERT_OK(node->process());
  const PointCloud& cloud = *node->out.cloud;
  EXPECT_EQ(cloud.points.size(), static_cast<std::size_t>(64 * 48));
  EXPECT_EQ(cloud.frame_id, "tof_optical");
  EXPECT_EQ(cloud.stamp, 5'000'000);
  for (const Point4f& p : cloud.points) EXPECT_NEAR(n.dot(p.vec().cast<double>()), d, 1e-4);
}

// With radial-tangential or equidistant (fisheye) distortion each point, projected by OpenCV
// with the same model, lands on the centre of its pixel (within 0.01 px: the undistortion's
// iterations) at its depth.
TEST(DepthToPointCloudPinhole, ADistortedCamerasPointsProjectBackOntoTheirPixels) {
  for (const DistortionModel model :
       {DistortionModel::kRadialTangential, DistortionModel::kEquidistant}) {
    SCOPED_TRACE(toString(model));
    CameraModel camera = testing::pinholeCamera(40, 30, 35.0);
    camera.distortion_model = model;
    camera.distortion = model == DistortionModel::kEquidistant
                            ? std::vector<double>{0.05, -0.01, 0.002, 0.0}
                            : std::vector<double>{-0.2, 0.05, 0.001, -0.001, 0.0};
    const DepthMap map = depthMap(camera, [](int u, int v) { return 2.0f + 0.01f * (u + v); });
    auto node = make();
    node->in.depth.set(map);
    ASSERT_OK(node->process());
    const PointCloud& cloud = *node->out.cloud;
    ASSERT_EQ(cloud.points.size(), static_cast<std::size_t>(40 * 30));
    std::vector<cv::Point3f> points;
    for (const Point4f& p : cloud.points) points.emplace_back(p.x, p.y, p.z);
    std::vector<cv::Point2f> pixels;
    if (model == DistortionModel::kEquidistant)
      cv::fisheye::projectPoints(points, pixels, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                                 cameraMatrix(camera), distortionCoefficients(camera));
    else
      cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cameraMatrix(camera),
                        distortionCoefficients(camera), pixels);
    std::size_t i = 0;
    for (int v = 0; v < camera.height; ++v)
      for (int u = 0; u < camera.width; ++u, ++i) {
        EXPECT_NEAR(pixels[i].x, u, 0.01);
        EXPECT_NEAR(pixels[i].y, v, 0.01);
        EXPECT_NEAR(points[i].z, 2.0f + 0.01f * (u + v), 1e-5);
      }
  }
}

// No measurement (0, negative, NaN, infinite) gives no point; the stride keeps one pixel in
// stride^2; the ranges cut by distance from the optical centre.
TEST(DepthToPointCloudPinhole, UnmeasuredPixelsStrideAndRangesLeavePointsOut) {
  const CameraModel camera = testing::pinholeCamera(20, 10, 20.0);
  const float bad[] = {0.0f, -1.0f, std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity()};
  const DepthMap map = depthMap(camera, [&](int u, int v) {
    if (v == 0 && u < 4) return bad[u];
    return u < 10 ? 2.0f : 6.0f;
  });
  auto all = make();
  all->in.depth.set(map);
  ASSERT_OK(all->process());
  EXPECT_EQ(all->out.cloud->points.size(), 200u - 4u);
  for (const Point4f& p : all->out.cloud->points) EXPECT_TRUE(std::isfinite(p.z));

  auto strided = make("{stride: 2}");
  strided->in.depth.set(map);
  ASSERT_OK(strided->process());
  EXPECT_EQ(strided->out.cloud->points.size(), 50u - 2u);  // pixels (0, 0) and (2, 0) are bad

  auto near = make("{max_range: 4}");
  near->in.depth.set(map);
  ASSERT_OK(near->process());
  EXPECT_EQ(near->out.cloud->points.size(), 100u - 4u);
  for (const Point4f& p : near->out.cloud->points) EXPECT_LE(p.vec().norm(), 4.0f);

  auto far = make("{min_range: 4}");
  far->in.depth.set(map);
  ASSERT_OK(far->process());
  EXPECT_EQ(far->out.cloud->points.size(), 100u);
}

TEST(DepthToPointCloudPinhole, BadInputsAreReported) {
  const CameraModel camera = testing::pinholeCamera(8, 6, 10.0);
  DepthMap map = depthMap(camera, [](int, int) { return 3.0f; });

  // No calibration: the pixels cannot be projected.
  DepthMap uncalibrated = map;
  uncalibrated.image.camera.reset();
  auto node = make();
  node->in.depth.set(uncalibrated);
  testing::expectRejected(*node, "no calibration");

  // An empty depth map.
  DepthMap empty;
  empty.image.camera = camera;
  node->in.depth.set(empty);
  EXPECT_FALSE(node->process().isOk());

  // Ranges that keep nothing, a stride of 0.
  for (const char* bad : {"{min_range: 5, max_range: 2}", "{stride: 0}", "{max_range: -1}"}) {
    auto d = dfn::Registry::instance().createAs<DepthToPointCloud>("DepthToPointCloud", "Pinhole");
    ASSERT_OK(d.status());
    EXPECT_FALSE(d.value()->configure(YAML::Load(bad)).isOk()) << bad;
  }
}

}  // namespace
}  // namespace cdff::dfn
