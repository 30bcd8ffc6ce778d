// The acquisition's parts in src/cdff/tracking/ on their own: the image pyramid, the prediction
// and its spread in the image, the gate and the confirmation of an acquired pose by the next
// frame. The acquisition as a whole is tested through the DFI (ModelBasedTracking_test.cpp) and
// the DFPC (tests/dfpc/visual_tracking_sim_test.cpp).
#include <gtest/gtest.h>

#include "cdff/tracking/acquiring_edge_tracker.hpp"
#include "support/model_rendering.hpp"
#include "support/synthetic.hpp"

namespace cdff::tracking {
namespace {

Transform pose(const Eigen::Vector3d& t, const Eigen::Vector3d& r = Eigen::Vector3d::Zero()) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = t;
  p.linear() = expSO3(r).toRotationMatrix();
  return Transform::fromIsometry(p, "camera", "model");
}

TEST(ImagePyramid, HalvingAveragesTwoByTwoAndKeepsThePixelCentres) {
  // 5x3: the last odd column and row are dropped.
  Image image = Image::fromBytes({0, 1, 10, 20, 99, 2, 4, 30, 41, 99, 99, 99, 99, 99, 99}, 5, 3,
                                 PixelFormat::kGray8)
                    .value();
  image.stamp = 42;
  const Image half = halveImage(image);
  ASSERT_EQ(half.width, 2);
  ASSERT_EQ(half.height, 1);
  EXPECT_EQ(half.row(0)[0], 2);   // (0 + 1 + 2 + 4 + 2) / 4, rounded to nearest
  EXPECT_EQ(half.row(0)[1], 25);  // (10 + 20 + 30 + 41 + 2) / 4
  EXPECT_EQ(half.stamp, 42);
  // The centre of a 4-pixel-wide image (1.5) is the centre of the 2-pixel-wide one (0.5).
  CameraModel camera = testing::pinholeCamera(4, 4, 100);
  camera.cx = camera.cy = 1.5;
  const CameraModel h = halveCamera(camera);
  EXPECT_EQ(h.width, 2);
  EXPECT_DOUBLE_EQ(h.fx, 50);
  EXPECT_DOUBLE_EQ(h.cx, 0.5);
  EXPECT_DOUBLE_EQ(cameraAtLevel(camera, 2).fx, 25);
}

TEST(ImagePyramid, LevelsAreBuiltOnceAndAMissingImageStaysMissing) {
  std::vector<std::uint8_t> bytes(64 * 48, 100);
  const Image image = Image::fromBytes(std::move(bytes), 64, 48, PixelFormat::kGray8).value();
  const CameraModel camera = testing::pinholeCamera(64, 48, 60);
  const std::vector<CameraFrame> frames = {
      {&image, camera, Transform::identity("camera", "camera")},
      {nullptr, camera, Transform::identity("camera", "camera")}};
  FramePyramids pyramids(frames);
  const Image& level2 = pyramids.image(0, 2);
  EXPECT_EQ(level2.width, 16);
  EXPECT_EQ(&pyramids.image(0, 2), &level2);  // built once
  pyramids.image(0, 3);                       // more levels leave the others in place
  EXPECT_EQ(&pyramids.image(0, 2), &level2);
  const CameraFrame missing = pyramids.frame(1, 1);
  EXPECT_EQ(missing.image, nullptr);
  EXPECT_EQ(missing.camera.width, 32);
  EXPECT_EQ(pyramids.frame(0, 1).image->width, 32);
  EXPECT_EQ(referenceCamera(frames), 0u);
}

TEST(Prediction, AStateIsMovedToTheImageTimeAndItsCovarianceCarried) {
  RigidBodyState state;
  state.pose = pose(Eigen::Vector3d(0, 0, 2));
  state.pose.stamp = 1'000'000;
  state.twist.linear = Eigen::Vector3d(0.1, 0, 0);
  state.covariance.diagonal() << Eigen::Vector3d::Constant(1e-4), Eigen::Vector3d::Constant(1e-6),
      Eigen::Vector3d::Constant(0.01), Eigen::Vector3d::Constant(1e-4);
  const PoseWithCovariance p = predictPose(state, 1'500'000);
  EXPECT_NEAR(p.pose.translation.x(), 0.05, 1e-12);
  EXPECT_EQ(p.pose.stamp, 1'500'000);
  EXPECT_DOUBLE_EQ(p.covariance(0, 0), 1e-4);  // the state's own pose covariance
  const Matrix6d carried = carriedPoseCovariance(state, 1'500'000);
  EXPECT_NEAR(carried(0, 0), 1e-4 + 0.25 * 0.01, 1e-15);
  EXPECT_NEAR(carried(3, 3), 1e-6 + 0.25 * 1e-4, 1e-15);
  // A state newer than the image is not moved back.
  EXPECT_EQ(predictPose(state, 500'000).pose.stamp, 1'000'000);
  EXPECT_DOUBLE_EQ(carriedPoseCovariance(state, 500'000)(0, 0), 1e-4);
}

TEST(Prediction, ItsSpreadInTheImageGrowsWithItsUncertainty) {
  Result<TrackingModel> model = TrackingModel::build(testing::lShapeModel(0.1), {});
  ASSERT_OK(model.status());
  const CameraFrame frame{nullptr, testing::pinholeCamera(640, 480, 600),
                          Transform::identity("camera", "camera")};
  PoseWithCovariance predicted;
  predicted.pose = pose(Eigen::Vector3d(0, 0, 1) - model->centre);
  predicted.covariance.diagonal() << Eigen::Vector3d::Constant(1e-4),
      Eigen::Vector3d::Constant(1e-4);
  const double spread = predictionSpreadPx(*model, frame, predicted, 3, 0.01);
  // 3 sigma of 1 cm laterally on each of two axes at 1 m and 600 px: at least 25 px.
  EXPECT_GT(spread, 3 * std::sqrt(2e-4) * 600);
  predicted.covariance *= 4;
  EXPECT_NEAR(predictionSpreadPx(*model, frame, predicted, 3, 0.01), 2 * spread, 1e-9);
  EXPECT_EQ(predictionSpreadPx(*model, frame, predicted, 0, 0.01), 0);  // acquisition off
  predicted.covariance = noInformationCovariance();
  EXPECT_EQ(predictionSpreadPx(*model, frame, predicted, 3, 0.01), 0);
  EXPECT_NEAR(modelSizePx(*model, frame, predicted, 0.01), 2 * model->radius * 600, 1e-9);
}

// The visible spread (the acquisition's trigger) projects the whole covariance: it follows the
// uncertainty like the bound, stays within it, and a lateral offset and a rotation that
// compensate each other in the image (correlated so) do not add up as the bound adds them.
TEST(Prediction, ItsVisibleSpreadProjectsTheCovarianceWithItsCorrelations) {
  Result<TrackingModel> model = TrackingModel::build(testing::lShapeModel(0.1), {});
  ASSERT_OK(model.status());
  const CameraFrame frame{nullptr, testing::pinholeCamera(640, 480, 600),
                          Transform::identity("camera", "camera")};
  PoseWithCovariance predicted;
  predicted.pose = pose(Eigen::Vector3d(0, 0, 1) - model->centre);
  predicted.covariance.diagonal() << Eigen::Vector3d::Constant(1e-4),
      Eigen::Vector3d::Constant(1e-4);
  const double spread = visibleSpreadPx(*model, frame, predicted, 3, 0.01);
  // 3 sigma of 1 cm laterally on each of two axes at 1 m and 600 px: at least 25 px.
  EXPECT_GT(spread, 3 * std::sqrt(2e-4) * 600);
  EXPECT_LE(spread, predictionSpreadPx(*model, frame, predicted, 3, 0.01));
  predicted.covariance *= 4;
  EXPECT_NEAR(visibleSpreadPx(*model, frame, predicted, 3, 0.01), 2 * spread, 1e-9);
  EXPECT_EQ(visibleSpreadPx(*model, frame, predicted, 0, 0.01), 0);  // acquisition off
  // A model 1 m in front of its origin (towards the camera): a rotation about the origin's y axis
  // moves it sideways as a lateral offset does, so a lateral offset and a rotation correlated to
  // cancel each other (dx = +dtheta_y, in m and rad) leave it (almost) in place. Each alone
  // spreads as the bound says; together, far less.
  PolygonModel shifted = testing::lShapeModel(0.1);
  for (Eigen::Vector3d& p : shifted.points) p.z() -= 1.0;
  Result<TrackingModel> far = TrackingModel::build(shifted, {});
  ASSERT_OK(far.status());
  const double s = 0.01;  // m and rad
  predicted.covariance.setZero();
  predicted.covariance(0, 0) = predicted.covariance(4, 4) = s * s;
  predicted.covariance(0, 4) = predicted.covariance(4, 0) = s * s;
  predicted.pose = pose(Eigen::Vector3d(0, 0, 2));  // the model 1 m in front of the camera
  EXPECT_GT(visibleSpreadPx(*far, frame, predicted, 3, 0.01), 0);
  EXPECT_LT(visibleSpreadPx(*far, frame, predicted, 3, 0.01),
            0.25 * predictionSpreadPx(*far, frame, predicted, 3, 0.01));
}

TEST(AcquisitionGate, AdmitsWhatTheCovarianceCovers) {
  const Transform predicted = pose(Eigen::Vector3d(0, 0, 2));
  const Matrix6d covariance = Matrix6d::Identity() * 1e-4;  // 1 cm, 0.01 rad
  const GateTest near = testGate(pose(Eigen::Vector3d(0.03, 0, 2)), predicted, covariance);
  EXPECT_TRUE(near.admitted);
  EXPECT_NEAR(near.distance, 9, 1e-9);
  const GateTest far =
      testGate(pose(Eigen::Vector3d(0, 0, 2), Eigen::Vector3d(0, 0.05, 0)), predicted, covariance);
  EXPECT_FALSE(far.admitted);
  EXPECT_NEAR(far.distance, 25, 1e-9);
  EXPECT_GT(far.distance, kAcquisitionGate);
  // A singular covariance admits everything.
  const GateTest singular = testGate(pose(Eigen::Vector3d(1, 0, 2)), predicted, Matrix6d::Zero());
  EXPECT_TRUE(singular.admitted);
  EXPECT_EQ(singular.distance, 0);
}

TEST(AcquisitionRestarts, TurnTheAttitudeAboutEachPrincipalAxisBothWaysLargestFirst) {
  const Transform start = pose(Eigen::Vector3d(0.1, 0, 3), Eigen::Vector3d(0, 0.2, 0));
  Matrix6d covariance = Matrix6d::Identity() * 1e-4;
  covariance.bottomRightCorner<3, 3>().diagonal() << 1e-4, 4e-4, 9e-4;  // 0.01, 0.02, 0.03 rad
  const std::vector<Transform> all = restartStarts(start, covariance, 2, 0, 8);
  ASSERT_EQ(all.size(), 8u);
  const Eigen::Vector3d expected[] = {{0, 0, 0.06},  {0, 0, -0.06}, {0, 0.04, 0},
                                      {0, -0.04, 0}, {0.02, 0, 0},  {-0.02, 0, 0}};
  for (std::size_t i = 0; i < all.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_TRUE(all[i].translation.isApprox(start.translation));
    // The turn is applied in the reference frame, as the covariance's perturbation; an
    // eigenvector's sign is the solver's, so each pair is checked up to it, one way then the other.
    const Vector6d d = poseDifference(all[i], start);
    EXPECT_NEAR(std::abs(d.tail<3>().dot(expected[i % 6])), expected[i % 6].squaredNorm(), 1e-9);
    EXPECT_NEAR(d.tail<3>().norm(), expected[i % 6].norm(), 1e-9);
    if (i % 2 == 1)
      EXPECT_TRUE(d.tail<3>().isApprox(-poseDifference(all[i - 1], start).tail<3>(), 1e-9));
  }
  // A later part of the sequence is the same as its place in the whole.
  const std::vector<Transform> part = restartStarts(start, covariance, 2, 3, 2);
  ASSERT_EQ(part.size(), 2u);
  EXPECT_TRUE(part[0].rotation.isApprox(all[3].rotation));
  EXPECT_TRUE(part[1].rotation.isApprox(all[4].rotation));
  // None without restarts, sigmas or an attitude covariance.
  EXPECT_TRUE(restartStarts(start, covariance, 2, 0, 0).empty());
  EXPECT_TRUE(restartStarts(start, covariance, 0, 0, 2).empty());
  EXPECT_TRUE(restartStarts(start, Matrix6d::Zero(), 2, 0, 2).empty());
}

TEST(AcquisitionConfirmation, TheNextFrameConfirmsWhatItsPredictionAdmits) {
  const Transform predicted = pose(Eigen::Vector3d(0, 0, 2));
  const Matrix6d narrow = Matrix6d::Identity() * 1e-6, wide = Matrix6d::Identity() * 1e-2;
  AcquisitionConfirmation c;
  EXPECT_FALSE(c.confirm(false, predicted, predicted, narrow).checked);  // nothing awaits
  c.acquired(wide);
  EXPECT_TRUE(c.awaiting());
  // 1 mm off under a 1 mm standard deviation: squared Mahalanobis distance 1.
  const AcquisitionConfirmation::Check check =
      c.confirm(false, pose(Eigen::Vector3d(0.001, 0, 2)), predicted, narrow);
  EXPECT_TRUE(check.checked);
  EXPECT_TRUE(check.confirmed);
  EXPECT_NEAR(check.distance, 1, 1e-9);
  EXPECT_FALSE(c.awaiting());
  EXPECT_EQ(c.widened(narrow), narrow);
}

TEST(AcquisitionConfirmation, ARejectedAcquisitionIsSearchedAgainAsWideAsItWas) {
  const Transform predicted = pose(Eigen::Vector3d(0, 0, 2));
  const Matrix6d narrow = Matrix6d::Identity() * 1e-6, wide = Matrix6d::Identity() * 1e-2;
  AcquisitionConfirmation c;
  c.acquired(wide);
  const AcquisitionConfirmation::Check rejected =
      c.confirm(false, pose(Eigen::Vector3d(0.1, 0, 2)), predicted, narrow);
  EXPECT_TRUE(rejected.checked);
  EXPECT_FALSE(rejected.confirmed);
  EXPECT_EQ(c.widened(narrow), wide);
  EXPECT_EQ(c.widened(wide * 2), wide * 2);  // a wider prediction stands
  // A lost frame confirms nothing either; a confirmation ends the widening.
  c.acquired(wide);
  EXPECT_FALSE(c.confirm(true, predicted, predicted, narrow).confirmed);
  c.acquired(wide);
  EXPECT_TRUE(c.confirm(false, predicted, predicted, narrow).confirmed);
  EXPECT_EQ(c.widened(narrow), narrow);
}

TEST(AcquisitionConfirmation, AfterARejectionTheSearchStartsWhereTheAcquisitionsDid) {
  const Transform predicted = pose(Eigen::Vector3d(0, 0, 2));
  const Matrix6d narrow = Matrix6d::Identity() * 1e-6, wide = Matrix6d::Identity() * 1e-2;
  AcquisitionConfirmation c;
  Transform later = pose(Eigen::Vector3d(0.2, 0, 2));
  later.stamp = 7;
  EXPECT_TRUE(c.anchored(later).translation.isApprox(later.translation));  // nothing rejected
  // An acquisition searched about (0.5, 0, 2), then not confirmed: the following frames search
  // from there, at their own time, until a confirmation.
  c.acquired(wide, predicted, pose(Eigen::Vector3d(0.5, 0, 2)));
  EXPECT_FALSE(c.confirm(true, predicted, predicted, narrow).confirmed);
  const Transform anchored = c.anchored(later);
  EXPECT_TRUE(anchored.translation.isApprox(Eigen::Vector3d(0.5, 0, 2)));
  EXPECT_EQ(anchored.stamp, 7);
  // A replacing acquisition (acquired again, not admitted) keeps that anchor.
  PosePrediction prediction;
  prediction.pose = {later, wide};
  c.acquired(wide, predicted, anchored);
  TrackingResult replacing;
  replacing.status = TrackingStatus::kTracking;
  replacing.reference_T_model = pose(Eigen::Vector3d(1, 0, 2));
  confirmAcquisition(c, replacing, true, PosePrediction{{later, narrow}, narrow});
  EXPECT_EQ(replacing.status, TrackingStatus::kDegraded);
  EXPECT_TRUE(c.awaiting());
  EXPECT_FALSE(c.confirm(true, predicted, predicted, narrow).confirmed);
  EXPECT_TRUE(c.anchored(later).translation.isApprox(Eigen::Vector3d(0.5, 0, 2)));
  // A confirmation ends it.
  c.acquired(wide, predicted, anchored);
  EXPECT_TRUE(c.confirm(false, predicted, predicted, narrow).confirmed);
  EXPECT_TRUE(c.anchored(later).translation.isApprox(later.translation));
}

// A frame that acquired again does not confirm the awaited pose, even where the prediction
// admits its estimate: the acquisition's wide search slides along a wrong alignment's valley (at
// 17 m, farther and turned) as readily as it found it. It replaces the awaited pose instead; a
// frame that tracked the same estimate confirms it.
TEST(AcquisitionConfirmation, AFrameThatAcquiredAgainDoesNotConfirm) {
  AcquisitionConfirmation c;
  PosePrediction prediction;
  prediction.pose.pose = pose(Eigen::Vector3d(0, 0, 2));
  prediction.pose.covariance = Matrix6d::Identity() * 1e-2;
  prediction.carried_covariance = Matrix6d::Identity() * 1e-2;
  TrackingResult acquired;
  acquired.status = TrackingStatus::kTracking;
  acquired.reference_T_model = prediction.pose.pose;
  acquired.covariance = Matrix6d::Identity() * 1e-8;
  confirmAcquisition(c, acquired, true, prediction);
  ASSERT_TRUE(c.awaiting());
  // 1 mm from the prediction under a 0.1 m standard deviation: admitted, but acquired again.
  TrackingResult again = acquired;
  again.reference_T_model = pose(Eigen::Vector3d(0.001, 0, 2));
  confirmAcquisition(c, again, true, prediction);
  EXPECT_EQ(again.status, TrackingStatus::kDegraded);
  EXPECT_NE(again.reason.find("acquired again, does not confirm it"), std::string::npos);
  EXPECT_TRUE(c.awaiting());
  ASSERT_TRUE(c.acquiredPose());
  EXPECT_TRUE(c.acquiredPose()->translation.isApprox(again.reference_T_model.translation));
  // The same estimate tracked (no acquisition) confirms it.
  TrackingResult tracked = again;
  tracked.status = TrackingStatus::kTracking;
  confirmAcquisition(c, tracked, false, prediction);
  EXPECT_EQ(tracked.status, TrackingStatus::kTracking);
  EXPECT_FALSE(c.awaiting());
}

TEST(AcquisitionConfirmation, AnEdgeTrackingResultIsDegradedUntilConfirmed) {
  AcquisitionConfirmation c;
  PosePrediction prediction;
  prediction.pose.pose = pose(Eigen::Vector3d(0, 0, 2));
  prediction.pose.covariance = Matrix6d::Identity() * 1e-2;
  TrackingResult acquired;
  acquired.status = TrackingStatus::kTracking;
  acquired.reference_T_model = prediction.pose.pose;
  acquired.covariance = Matrix6d::Identity() * 1e-8;
  confirmAcquisition(c, acquired, true, prediction);
  EXPECT_EQ(acquired.status, TrackingStatus::kDegraded);
  EXPECT_TRUE(c.awaiting());
  // The next frame's prediction carries a covariance that does not admit an estimate 5 cm off.
  prediction.pose.covariance = Matrix6d::Identity() * 1e-6;
  prediction.carried_covariance = Matrix6d::Identity() * 1e-6;
  TrackingResult next = acquired;
  next.status = TrackingStatus::kTracking;
  next.reference_T_model = pose(Eigen::Vector3d(0.05, 0, 2));
  confirmAcquisition(c, next, false, prediction);
  EXPECT_EQ(next.status, TrackingStatus::kLost);
  EXPECT_NE(next.reason.find("did not confirm the acquired pose"), std::string::npos);
  EXPECT_EQ(next.covariance, noInformationCovariance());
  EXPECT_EQ(c.widened(prediction.pose.covariance), Matrix6d::Identity() * 1e-2);
}

}  // namespace
}  // namespace cdff::tracking
