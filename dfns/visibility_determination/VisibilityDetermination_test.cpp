// VisibilityDetermination/HiddenLineRemoval against a brute-force ground truth: every model edge
// is sampled densely and each sample's visibility is decided by casting the ray from the camera
// to it through every face (an implementation independent of the DFI's Cyrus-Beck clipping);
// the DFI's visible segments must cover the visible samples and none of the hidden ones, up to a
// pixel at the transitions.
#include <gtest/gtest.h>

#include <cmath>

#include "VisibilityDetermination.gen.hpp"
#include "cdff/tracking/tracking_model.hpp"
#include "support/dfn_testing.hpp"
#include "support/model_rendering.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

using testing::lookAt;

std::unique_ptr<VisibilityDetermination> make(const std::string& yaml = "{}") {
  return testing::makeDfn<VisibilityDetermination>("VisibilityDetermination", "HiddenLineRemoval",
                                                   yaml);
}

Transform poseOf(const Eigen::Isometry3d& camera_T_model) {
  return Transform::fromIsometry(camera_T_model, "camera", "model");
}

// True when the segment from the camera centre to `x` (camera frame) crosses no face of `model`
// before reaching within `tolerance` of x; faces in `skip` (those the edge lies on) are ignored.
bool visibleBruteForce(const tracking::TrackingModel& model, const Eigen::Isometry3d& c_T_m,
                       const Eigen::Vector3d& x, const int skip[2], double tolerance) {
  for (std::size_t f = 0; f < model.faces.size(); ++f) {
    if (static_cast<int>(f) == skip[0] || static_cast<int>(f) == skip[1]) continue;
    const auto& face = model.faces[f];
    const Eigen::Vector3d n = c_T_m.linear() * face.normal;
    const double d = n.dot(c_T_m * face.centroid);
    const double denom = n.dot(x);
    if (std::abs(denom) < 1e-12) continue;
    const double s = d / denom;  // the ray hits the plane at s * x
    if (s <= 0 || s * x.norm() >= x.norm() - tolerance) continue;
    const Eigen::Vector3d hit = s * x;
    // Inside the face polygon (in its plane): same side of every edge for a convex piece.
    for (const auto& piece : face.convex_pieces) {
      bool inside = true;
      for (std::size_t i = 0; i < piece.size() && inside; ++i) {
        const Eigen::Vector3d a = c_T_m * model.points[piece[i]];
        const Eigen::Vector3d b = c_T_m * model.points[piece[(i + 1) % piece.size()]];
        inside = n.dot((b - a).cross(hit - a)) >= 0;
      }
      if (inside) return false;
    }
  }
  return true;
}

struct Coverage {
  int visible = 0, hidden = 0, visible_missed = 0, hidden_reported = 0;
};

// Compares the DFI's segments with the brute-force visibility of samples along every edge that
// is a contour candidate (skipping samples within `margin_px` of a visibility change).
Coverage compare(const PolygonModel& polygon_model, const ModelContours& contours,
                 double margin_px) {
  auto model = tracking::TrackingModel::build(polygon_model).value();
  const Eigen::Isometry3d c_T_m = contours.camera_T_model.isometry();
  const CameraModel& k = contours.camera;
  Coverage c;
  for (std::size_t e = 0; e < model.edges.size(); ++e) {
    const auto& edge = model.edges[e];
    // Every edge of these models is a 90 degree crease: with two-sided faces each one is a
    // contour wherever it is not hidden.
    const Eigen::Vector3d a = model.points[edge.a], b = model.points[edge.b];
    const int n = 400;
    std::vector<int> state(n + 1);
    for (int i = 0; i <= n; ++i) {
      const Eigen::Vector3d x = c_T_m * (a + (b - a) * (double(i) / n));
      state[i] = visibleBruteForce(model, c_T_m, x, edge.faces, 1e-6) ? 1 : 0;
    }
    const double px_per_step = (k.project(c_T_m * a) - k.project(c_T_m * b)).norm() / n;
    const int guard = static_cast<int>(std::ceil(margin_px / std::max(px_per_step, 1e-9)));
    for (int i = 0; i <= n; ++i) {
      bool near_change = false;
      for (int j = std::max(0, i - guard); j <= std::min(n, i + guard); ++j)
        near_change = near_change || state[j] != state[i];
      if (near_change) continue;
      const Eigen::Vector3d x = a + (b - a) * (double(i) / n);
      bool reported = false;
      for (const ContourSegment& s : contours.segments) {
        if (s.edge != e) continue;
        const double t = (x - s.a).dot(s.b - s.a) / (s.b - s.a).squaredNorm();
        if (t >= -1e-9 && t <= 1 + 1e-9 && (s.a + t * (s.b - s.a) - x).norm() < 1e-9)
          reported = true;
      }
      if (state[i]) {
        ++c.visible;
        c.visible_missed += reported ? 0 : 1;
      } else {
        ++c.hidden;
        c.hidden_reported += reported ? 1 : 0;
      }
    }
  }
  return c;
}

TEST(VisibilityDetermination, ABoxFromACornerShowsNineEdgesFully) {
  auto node = make();
  const CameraModel camera = testing::pinholeCamera(640, 480, 600);
  const PolygonModel box = testing::boxModel({0.3, 0.2, 0.15});
  node->in.model.set(box);
  node->in.camera.set(camera);
  node->in.pose.set(poseOf(lookAt({0.5, -0.62, 0.41}, Eigen::Vector3d::Zero())));
  ASSERT_OK(node->process());
  const ModelContours& c = *node->out.contours;
  ASSERT_EQ(c.segments.size(), 9u);  // 3 faces seen: 3 creases and 6 silhouette edges
  int silhouettes = 0, creases = 0;
  for (const ContourSegment& s : c.segments) {
    silhouettes += s.kind == ContourKind::kSilhouette;
    creases += s.kind == ContourKind::kCrease;
    // Unoccluded edges are reported whole: their ends are box corners (|coordinates| = half size).
    for (const Eigen::Vector3d& p : {s.a, s.b})
      EXPECT_NEAR((p.cwiseAbs() - Eigen::Vector3d(0.15, 0.1, 0.075)).cwiseAbs().maxCoeff(), 0,
                  1e-9);
  }
  EXPECT_EQ(silhouettes, 6);
  EXPECT_EQ(creases, 3);
  EXPECT_EQ(*node->out.segment_count, 9);
  EXPECT_EQ(c.faces.size(), 6u) << "two-sided faces: the back faces are seen from behind";
  auto one_sided = make("{two_sided_faces: false}");
  one_sided->in.model.set(box);
  one_sided->in.camera.set(camera);
  one_sided->in.pose.set(node->in.pose.shared());
  ASSERT_OK(one_sided->process());
  EXPECT_EQ(one_sided->out.contours->faces.size(), 3u);
  EXPECT_EQ(one_sided->out.contours->segments.size(), 9u);
}

TEST(VisibilityDetermination, HiddenPartsOfANonConvexModelAreRemovedExactly) {
  auto node = make("{min_segment_length: 0}");  // keep even the tiniest visible pieces
  const CameraModel camera = testing::pinholeCamera(640, 480, 600);
  const PolygonModel l_shape = testing::lShapeModel(0.1);
  node->in.model.set(l_shape);
  node->in.camera.set(camera);
  // Views in which one arm of the L hides parts of the other.
  // (Coordinates off round numbers: a view along a plane of the model, where a hidden edge lies
  // exactly behind a visible one, is a degenerate case of measure zero.)
  for (const Eigen::Vector3d eye :
       {Eigen::Vector3d(0.4537, 0.5123, 0.2461), Eigen::Vector3d(-0.2171, 0.5939, 0.3127),
        Eigen::Vector3d(0.5513, 0.3471, -0.2093), Eigen::Vector3d(0.0317, 0.6029, 0.1543)}) {
    SCOPED_TRACE(::testing::PrintToString(std::vector<double>{eye.x(), eye.y(), eye.z()}));
    node->in.pose.set(poseOf(lookAt(eye, Eigen::Vector3d(0, 0, 0))));
    ASSERT_OK(node->process());
    const Coverage c = compare(l_shape, *node->out.contours, 0.5);
    EXPECT_GT(c.visible, 1000);
    EXPECT_GT(c.hidden, 50) << "the view should hide part of the contours";
    EXPECT_EQ(c.visible_missed, 0);
    EXPECT_EQ(c.hidden_reported, 0);
  }
}

TEST(VisibilityDetermination, TheInsideOfAnOpenBoxShowsOnlyWithTwoSidedFaces) {
  PolygonModel open = testing::boxModel({0.2, 0.2, 0.2});
  open.faces.erase(open.faces.begin() + 1);  // no lid
  const CameraModel camera = testing::pinholeCamera(640, 480, 600);
  const Transform pose = poseOf(lookAt({0.05, -0.3, 0.6}, Eigen::Vector3d::Zero()));
  auto two_sided = make("{min_segment_length: 0}");
  two_sided->in.model.set(open);
  two_sided->in.camera.set(camera);
  two_sided->in.pose.set(pose);
  ASSERT_OK(two_sided->process());
  auto one_sided = make("{two_sided_faces: false}");
  one_sided->in.model.set(open);
  one_sided->in.camera.set(camera);
  one_sided->in.pose.set(pose);
  ASSERT_OK(one_sided->process());
  // Looking into the box: the inner corners and the far rim are contours only when the inside of
  // the walls counts as surface.
  EXPECT_GT(two_sided->out.contours->segments.size(), one_sided->out.contours->segments.size());
  const Coverage c = compare(open, *two_sided->out.contours, 0.5);
  EXPECT_EQ(c.visible_missed, 0);
  EXPECT_EQ(c.hidden_reported, 0);
}

TEST(VisibilityDetermination, ACylinderShowsItsLimbsWhereTheyAre) {
  PolygonModel m;
  m.points = {{0, 0, -0.1}, {0, 0, 0.1}};
  const double r = 0.05;
  m.cylinders = {{0, 1, r, "mast"}};
  auto node = make("{cylinder_segments: 72}");
  node->in.model.set(m);
  node->in.camera.set(testing::pinholeCamera(640, 480, 600));
  const Eigen::Vector3d eye(0.5, 0, 0);
  node->in.pose.set(poseOf(lookAt(eye, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, -1))));
  ASSERT_OK(node->process());
  // The true limbs lie in the planes through the camera tangent to the cylinder: with the axis
  // parallel to the image's y axis they are the image columns cx +- f tan(asin(r / d)). The
  // inscribed prism's outline lies inside, by at most r (1 - cos(pi / N)) seen from distance d - r.
  const double d = eye.norm(), f = 600, cx = (640 - 1) / 2.0;
  const double u_limb = f * std::tan(std::asin(r / d));
  const double tolerance = f * r * (1 - std::cos(M_PI / 72)) / (d - r) + 1e-6;
  const Eigen::Isometry3d c_T_m = node->out.contours->camera_T_model.isometry();
  const CameraModel& k = node->out.contours->camera;
  int limbs = 0;
  for (const ContourSegment& s : node->out.contours->segments) {
    if (s.kind != ContourKind::kSilhouette) continue;
    ++limbs;
    for (const Eigen::Vector3d& p : {s.a, s.b}) {
      const double u = std::abs(k.project(c_T_m * p).x() - cx);
      EXPECT_LE(u, u_limb + 1e-6);
      EXPECT_GE(u, u_limb - tolerance);
      EXPECT_NEAR(std::abs(p.z()), 0.1, 1e-9);
    }
  }
  EXPECT_EQ(limbs, 2);
}

TEST(VisibilityDetermination, AModelBehindTheCameraGivesNoContoursAndAWarning) {
  auto node = make();
  node->in.model.set(testing::boxModel({0.2, 0.2, 0.2}));
  node->in.camera.set(testing::pinholeCamera(640, 480, 600));
  Eigen::Isometry3d behind = Eigen::Isometry3d::Identity();
  behind.translation() << 0, 0, -0.5;
  node->in.pose.set(poseOf(behind));
  ASSERT_OK(node->process());
  EXPECT_TRUE(node->out.contours->segments.empty());
  EXPECT_EQ(*node->out.segment_count, 0);
  EXPECT_EQ(node->diagnostics().warning_count, 1u);
}

TEST(VisibilityDetermination, TheCameraCanComeWithTheImageAndSitElsewhereInTheRig) {
  auto node = make();
  const PolygonModel box = testing::boxModel({0.2, 0.2, 0.2});
  node->in.model.set(box);
  Image image = testing::toImage(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)));
  image.camera = testing::pinholeCamera(640, 480, 600);
  node->in.image.set(image);
  const Eigen::Isometry3d left_T_model = lookAt({0.4, -0.5, 0.3}, Eigen::Vector3d::Zero());
  Eigen::Isometry3d right_T_left = Eigen::Isometry3d::Identity();
  right_T_left.translation() << -0.1, 0, 0;
  node->in.pose.set(Transform::fromIsometry(left_T_model, "left", "model"));
  node->in.camera_extrinsics.set(Transform::fromIsometry(right_T_left, "right", "left"));
  ASSERT_OK(node->process());
  const ModelContours& c = *node->out.contours;
  EXPECT_LT((c.camera_T_model.isometry().matrix() - (right_T_left * left_T_model).matrix()).norm(),
            1e-12);
  EXPECT_EQ(c.camera_T_model.parent_frame, "right");
  EXPECT_FALSE(c.segments.empty());
}

TEST(VisibilityDetermination, BadInputsAreRejected) {
  const Transform pose = poseOf(lookAt({0.4, -0.5, 0.3}, Eigen::Vector3d::Zero()));
  {
    auto node = make();
    node->in.model.set(testing::boxModel({0.2, 0.2, 0.2}));
    node->in.pose.set(pose);
    testing::expectRejected(*node, "neither 'camera' nor 'image' is set");
  }
  {
    auto node = make();
    node->in.model.set(testing::boxModel({0.2, 0.2, 0.2}));
    node->in.pose.set(pose);
    CameraModel distorted = testing::pinholeCamera(640, 480, 600);
    distorted.distortion_model = DistortionModel::kRadialTangential;
    distorted.distortion = {0.1, 0.0, 0.0, 0.0};
    node->in.camera.set(distorted);
    testing::expectRejected(*node, "expected an undistorted image");
  }
  {
    auto node = make();
    PolygonModel broken = testing::boxModel({0.2, 0.2, 0.2});
    broken.faces[2].points[1] = 42;
    node->in.model.set(broken);
    node->in.pose.set(pose);
    node->in.camera.set(testing::pinholeCamera(640, 480, 600));
    testing::expectRejected(*node, "input 'model': model face 2 ('front') refers to point 42");
  }
  {
    auto node = make();
    node->in.model.set(testing::boxModel({0.2, 0.2, 0.2}));
    Transform nan = pose;
    nan.translation.x() = std::nan("");
    node->in.pose.set(nan);
    node->in.camera.set(testing::pinholeCamera(640, 480, 600));
    testing::expectRejected(*node, "camera_T_model");
  }
}

}  // namespace
}  // namespace cdff::dfn
