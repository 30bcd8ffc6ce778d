// The .cao face model loads in ViSP 3.5's model-based tracker, with the faces' orientation that
// ViSP's visibility test expects.
// (C++17: see cao_fixture.hpp.)
#include <filesystem>

#include <gtest/gtest.h>
#include <visp3/mbt/vpMbGenericTracker.h>
#include <Eigen/Geometry>

#include "cao_fixture.hpp"

namespace cdff::egse {
namespace {

TEST(VispCao, LoadsInVpMbGenericTrackerWithOutwardFaces) {
  const auto path =
      std::filesystem::temp_directory_path() / ("cdff_visp_" + std::to_string(::getpid()) + ".cao");
  const testing::CaoFixture fixture = testing::writeTargetCao(path.string());
  ASSERT_TRUE(fixture.error.empty()) << fixture.error;

  vpMbGenericTracker tracker(1, vpMbGenericTracker::EDGE_TRACKER);
  ASSERT_NO_THROW(tracker.loadModel(path.string()));
  std::filesystem::remove(path);
  EXPECT_EQ(tracker.getNbPolygon(), fixture.polygon_count);

  // The first polygons are the bus faces (-x, +x, -y, +y, -z, +z) with their points in our
  // order: ViSP keeps the order of the file.
  vpMbtPolygon* aft = tracker.getPolygon(0);
  ASSERT_NE(aft, nullptr);
  ASSERT_EQ(aft->getNbPoint(), 4u);
  EXPECT_NEAR(aft->getPoint(0).get_oX(), fixture.aft_face_x, 1e-6);

  // A camera 6 m away on the -x, +y, +z side looking at the bus centre sees the -x, +y and +z
  // faces and not the three others.
  vpCameraParameters cam(800, 800, 320, 240);
  tracker.setCameraParameters(cam);
  tracker.setNearClippingDistance(0.1);
  tracker.setFarClippingDistance(100);
  const Eigen::Vector3d eye = Eigen::Vector3d(-1, 1, 1).normalized() * 6.0;
  const Eigen::Vector3d forward = (-eye).normalized();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d target_R_camera;
  target_R_camera << right, down, forward;  // optical frame: x right, y down, z forward
  const Eigen::Matrix3d R = target_R_camera.transpose();
  const Eigen::Vector3d t = -R * eye;
  vpHomogeneousMatrix cMo;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) cMo[r][c] = R(r, c);
    cMo[r][3] = t(r);
  }
  vpImage<unsigned char> image(480, 640, 0);
  ASSERT_NO_THROW(tracker.initFromPose(image, cMo));
  auto& faces = tracker.getFaces();
  const bool expected[6] = {true, false, false, true, false, true};
  for (unsigned int f = 0; f < 6; ++f)
    EXPECT_EQ(faces.isVisible(f), expected[f]) << "bus face " << f;
}

// The second target's and a perturbed model's face models load too, every polygon kept.
TEST(VispCao, TheSecondTargetAndAPerturbedModelLoad) {
  for (const auto writer : {&testing::writeHexagonalCao, &testing::writePerturbedCao}) {
    const auto path = std::filesystem::temp_directory_path() /
                      ("cdff_visp_other_" + std::to_string(::getpid()) + ".cao");
    const testing::CaoFixture fixture = writer(path.string());
    ASSERT_TRUE(fixture.error.empty()) << fixture.error;
    vpMbGenericTracker tracker(1, vpMbGenericTracker::EDGE_TRACKER);
    ASSERT_NO_THROW(tracker.loadModel(path.string()));
    std::filesystem::remove(path);
    EXPECT_EQ(tracker.getNbPolygon(), fixture.polygon_count);
  }
}

}  // namespace
}  // namespace cdff::egse
