// The 3D view's and the error plots' encoders and routes: a cloud thinned to its bound, the
// binary layouts of points and meshes, the error of a pose and its requirement thresholds (as
// `cdff eval` measures them), GET .../mesh, .../errors, /api/requirements and /api/graphs/model,
// and their refusals (JSON 4xx).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/eval/requirements.hpp"
#include "cdff/serve/contour.hpp"
#include "cdff/serve/scene.hpp"
#include "serve_fixture.hpp"

namespace cdff::serve::testing {
namespace {

using nlohmann::json;

// The header and payload of a binary body (4 bytes of little-endian header length, the header).
struct Split {
  json header;
  std::string payload;
};
Split split(const std::string& data) {
  EXPECT_GE(data.size(), 4u);
  std::uint32_t n = 0;
  std::memcpy(&n, data.data(), 4);
  EXPECT_LE(4 + n, data.size());
  return {json::parse(data.substr(4, n)), data.substr(4 + n)};
}

template <typename T>
std::vector<T> values(const std::string& payload, std::size_t offset, std::size_t count) {
  std::vector<T> out(count);
  EXPECT_LE(offset + count * sizeof(T), payload.size());
  std::memcpy(out.data(), payload.data() + offset, count * sizeof(T));
  return out;
}

PointCloud cloudOf(int n, int nan_every) {
  std::vector<Eigen::Vector3f> xyz;
  for (int i = 0; i < n; ++i) {
    const float v = nan_every > 0 && i % nan_every == 0 ? std::numeric_limits<float>::quiet_NaN()
                                                        : static_cast<float>(i);
    xyz.emplace_back(v, 2.0f * i, -1.0f);
  }
  return PointCloud::fromXyz(xyz, "lidar", 5);
}

TEST(Scene, DecimationKeepsAtMostTheBoundSpreadOverTheScan) {
  const PointCloud cloud = cloudOf(10000, 7);  // 1429 NaN, 8571 finite
  for (std::size_t bound : {1u, 2u, 100u, 1000u, 8570u, 8571u, 20000u}) {
    const DecimatedCloud d = decimateCloud(cloud, bound);
    EXPECT_EQ(d.source_points, 10000u);
    EXPECT_EQ(d.finite_points, 8571u);
    const std::size_t kept = d.xyz.size() / 3;
    EXPECT_LE(kept, bound) << bound;
    // Every stride-th finite point: no fewer than the bound allows.
    EXPECT_EQ(kept, (8571 + d.stride - 1) / d.stride) << bound;
    EXPECT_EQ(d.stride, (8571 + bound - 1) / bound) << bound;
    for (float v : d.xyz) EXPECT_TRUE(std::isfinite(v));
    // Spread over the scan: the first finite point, and one within a stride of the last.
    EXPECT_EQ(d.xyz[0], 1.0f);
    EXPECT_GE(d.xyz[3 * (kept - 1)], 9999.0f - 7.0f / 6.0f * static_cast<float>(d.stride) - 1)
        << bound;
  }
  EXPECT_EQ(decimateCloud(cloud, 0).xyz.size(), 3u);  // a bound of 0 is taken as 1
  EXPECT_TRUE(decimateCloud(PointCloud{}, 10).xyz.empty());
}

TEST(Scene, PointsFrameLayout) {
  const PointCloud cloud = cloudOf(10, 0);
  const DecimatedCloud d = decimateCloud(cloud, 4);  // stride 3: points 0, 3, 6, 9
  const Split s = split(pointsFrame({{"channel", "/lidar/points"}, {"t", 0.5}}, cloud, d));
  EXPECT_EQ(s.header["type"], "points");
  EXPECT_EQ(s.header["channel"], "/lidar/points");
  EXPECT_EQ(s.header["frame"], "lidar");
  EXPECT_EQ(s.header["count"], 4);
  EXPECT_EQ(s.header["source_count"], 10);
  EXPECT_EQ(s.header["stride"], 3);
  ASSERT_EQ(s.payload.size(), 4u * 3 * sizeof(float));
  const std::vector<float> xyz = values<float>(s.payload, 0, 12);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(xyz[3 * k], 3.0f * k);
    EXPECT_EQ(xyz[3 * k + 1], 6.0f * k);
    EXPECT_EQ(xyz[3 * k + 2], -1.0f);
  }
}

TEST(Scene, MeshBodyLayoutAndInvalidMeshes) {
  TriangleMesh mesh;
  mesh.frame_id = "target";
  mesh.vertices = Buffer<Eigen::Vector3f>::fromVector({{0, 0, 0}, {1, 0, 0}, {0, 2, 0}, {0, 0, 3}});
  mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector({{0, 2, 1}, {0, 1, 3}});
  Result<std::string> body = meshBody(mesh, {{"source", "test"}});
  ASSERT_TRUE(body.isOk()) << body.status().message();
  const Split s = split(*body);
  EXPECT_EQ(s.header["type"], "mesh");
  EXPECT_EQ(s.header["vertices"], 4);
  EXPECT_EQ(s.header["triangles"], 2);
  EXPECT_EQ(s.header["frame"], "target");
  EXPECT_EQ(s.header["source"], "test");
  ASSERT_EQ(s.payload.size(), 4u * 12 + 2u * 12);
  const std::vector<float> v = values<float>(s.payload, 0, 12);
  EXPECT_EQ(v[4], 0.0f);
  EXPECT_EQ(v[7], 2.0f);
  EXPECT_EQ(v[11], 3.0f);
  const std::vector<std::uint32_t> t = values<std::uint32_t>(s.payload, 48, 6);
  EXPECT_EQ(t, (std::vector<std::uint32_t>{0, 2, 1, 0, 1, 3}));

  TriangleMesh bad = mesh;
  bad.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector({{0, 1, 4}});
  Result<std::string> refused = meshBody(bad, {});
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("4"), std::string::npos) << refused.status().message();
  EXPECT_FALSE(meshBody(TriangleMesh{}, {}).isOk());
}

TEST(Scene, PoseErrorIsEvalsWithTheThresholdsOfItsRange) {
  // The errors `cdff eval` computes for the same pair, at a close, a mid and a far range.
  for (double range : {1.0, 10.0, 2000.0}) {
    Transform truth = Transform::identity("servicer", "target", 1000);
    truth.translation = Eigen::Vector3d(0, 0.6, 0.8) * range;
    truth.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
    Transform estimate = truth;
    estimate.translation += Eigen::Vector3d(0.03, -0.04, 0);
    estimate.rotation =
        truth.rotation * Eigen::AngleAxisd(0.05, Eigen::Vector3d(1, 1, 0).normalized());
    const PoseError e = poseError(estimate, truth);
    eval::EstimateSample sample;
    sample.pose = estimate;
    Result<eval::PoseEvaluation> reference = eval::evaluatePoses({sample}, {truth});
    ASSERT_TRUE(reference.isOk()) << reference.status().message();
    ASSERT_EQ(reference->errors.size(), 1u);
    EXPECT_NEAR(e.position_error_m, reference->errors[0].position_error_m, 1e-12);
    EXPECT_NEAR(e.angle_error_deg, reference->errors[0].angle_error_deg, 1e-9);
    EXPECT_NEAR(e.range_m, range, 1e-9);
    EXPECT_NEAR(e.position_error_m, 0.05, 1e-12);
    EXPECT_NEAR(e.angle_error_deg, 0.05 * 180 / M_PI, 1e-9);
    if (range < 2) {
      EXPECT_EQ(e.requirement, "SR_DFPC_0101");
      EXPECT_EQ(e.position_threshold_m, 0.05);
      EXPECT_EQ(e.angle_threshold_deg, 5.0);
    } else if (range < 1000) {
      EXPECT_EQ(e.requirement, "SR_DFPC_0100");
      EXPECT_EQ(e.position_threshold_m, 1.0);
      EXPECT_EQ(e.angle_threshold_deg, 10.0);
    } else {
      EXPECT_EQ(e.requirement, "");
      EXPECT_FALSE(e.position_threshold_m);
      EXPECT_FALSE(e.angle_threshold_deg);
    }
  }
}

TEST(Scene, ThresholdsAreEvalsRequirementTable) {
  const json t = poseThresholdsJson();
  std::size_t accuracy = 0;
  for (const eval::RequirementSpec& r : eval::poseRequirements()) {
    if (r.quantity != eval::RequirementSpec::Quantity::kPositionError &&
        r.quantity != eval::RequirementSpec::Quantity::kAngleError)
      continue;
    ASSERT_LT(accuracy, t.size());
    EXPECT_EQ(t[accuracy]["id"], r.id);
    EXPECT_EQ(t[accuracy]["threshold"], r.threshold);
    EXPECT_EQ(t[accuracy]["min_range_m"], r.min_range_m);
    EXPECT_EQ(t[accuracy]["max_range_m"], r.max_range_m);
    ++accuracy;
  }
  EXPECT_EQ(t.size(), accuracy);
  EXPECT_EQ(accuracy, 4u);  // SR_DFPC_0100 and 0101, position and angle
}

// A unit cube (per-face vertices, as flat-shaded meshes have them), outward triangles.
TriangleMesh cube() {
  std::vector<Eigen::Vector3f> v;
  std::vector<std::array<std::uint32_t, 3>> t;
  for (int axis = 0; axis < 3; ++axis)
    for (float side : {-0.5f, 0.5f}) {
      const Eigen::Vector3f n = Eigen::Vector3f::Unit(axis) * side * 2;
      const Eigen::Vector3f u = Eigen::Vector3f::Unit((axis + 1) % 3) * 0.5f;
      const Eigen::Vector3f w = n.cross(u);  // u x w = n / 4: counter-clockwise from outside
      const auto base = static_cast<std::uint32_t>(v.size());
      const Eigen::Vector3f centre = n * 0.5f;
      v.push_back(centre - u - w);
      v.push_back(centre + u - w);
      v.push_back(centre + u + w);
      v.push_back(centre - u + w);
      t.push_back({base, base + 1, base + 2});
      t.push_back({base, base + 2, base + 3});
    }
  TriangleMesh mesh;
  mesh.frame_id = "target";
  mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(v));
  mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(t));
  return mesh;
}

CameraModel pinhole() {
  CameraModel camera;
  camera.width = 100;
  camera.height = 100;
  camera.fx = camera.fy = 100;
  camera.cx = camera.cy = 50;
  return camera;
}

TEST(Contour, ACubeSeenFaceOnShowsItsFrontSquare) {
  Result<MeshOutline> outline = MeshOutline::of(cube());
  ASSERT_TRUE(outline.isOk()) << outline.status().message();
  EXPECT_EQ(outline->edges(), 18u);  // 12 sides and 6 diagonals, welded
  Transform pose = Transform::identity("camera_optical", "target");
  pose.translation = Eigen::Vector3d(0, 0, 5);
  Result<std::vector<std::array<float, 4>>> s = outline->project(pose, pinhole());
  ASSERT_TRUE(s.isOk()) << s.status().message();
  // Only the face at z = 4.5 faces the camera: its 4 sides, corners at 50 +- 100 * 0.5 / 4.5.
  ASSERT_EQ(s->size(), 4u);
  const float d = 100.0f * 0.5f / 4.5f;
  for (const auto& seg : *s)
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(std::abs(seg[k] - 50.0f), d, 1e-3) << k;
}

TEST(Contour, ACubeSeenFromACornerShowsItsHexagonAndThreeCreases) {
  Result<MeshOutline> outline = MeshOutline::of(cube());
  ASSERT_TRUE(outline.isOk());
  // The camera on the cube's diagonal (1, 1, 1), 6 m away, looking at its centre.
  const Eigen::Vector3d eye = Eigen::Vector3d(1, 1, 1).normalized() * 6;
  const Eigen::Vector3d z = -eye.normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Matrix3d model_R_camera;
  model_R_camera << x, z.cross(x), z;
  Eigen::Isometry3d model_T_camera = Eigen::Isometry3d::Identity();
  model_T_camera.linear() = model_R_camera;
  model_T_camera.translation() = eye;
  const Transform pose =
      Transform::fromIsometry(model_T_camera.inverse(), "camera_optical", "target");
  Result<std::vector<std::array<float, 4>>> s = outline->project(pose, pinhole());
  ASSERT_TRUE(s.isOk());
  EXPECT_EQ(s->size(), 9u);  // 6 silhouette edges, 3 creases between the visible faces
  // The faces meet at 90 degrees: creases from a threshold below it, none above.
  EXPECT_EQ(outline->project(pose, pinhole(), 89)->size(), 9u);
  EXPECT_EQ(outline->project(pose, pinhole(), 91)->size(), 6u);
}

TEST(Contour, BehindTheCameraNothingAndABadCameraIsRefused) {
  Result<MeshOutline> outline = MeshOutline::of(cube());
  ASSERT_TRUE(outline.isOk());
  Transform pose = Transform::identity("camera_optical", "target");
  pose.translation = Eigen::Vector3d(0, 0, -5);
  EXPECT_TRUE(outline->project(pose, pinhole())->empty());
  CameraModel bad = pinhole();
  bad.fx = 0;
  pose.translation = Eigen::Vector3d(0, 0, 5);
  EXPECT_FALSE(outline->project(pose, bad).isOk());
  TriangleMesh broken = cube();
  broken.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector({{0, 1, 99}});
  EXPECT_FALSE(MeshOutline::of(broken).isOk());
}

class SceneRoutes : public ::testing::Test {
 protected:
  void SetUp() override {
    files_ = makeFiles("scene_routes");
    files_.recording = writeSceneRecording(files_);
    server_ = startServer(files_);
    ASSERT_TRUE(server_);
    port_ = server_->port();
  }
  Files files_;
  std::unique_ptr<Server> server_;
  unsigned short port_ = 0;
};

TEST_F(SceneRoutes, MeshOfARecordingsTriangleMeshChannel) {
  const Reply r = get(port_, "/api/recordings/0/mesh?channel=/truth/target_mesh");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.headers.at("Content-Type"), "application/octet-stream");
  const Split s = split(r.body);
  EXPECT_EQ(s.header["vertices"], 4);
  EXPECT_EQ(s.header["triangles"], 2);
  EXPECT_EQ(s.header["frame"], "target");
  EXPECT_EQ(s.header["channel"], "/truth/target_mesh");
  ASSERT_EQ(s.payload.size(), 4u * 12 + 2u * 12);
  EXPECT_EQ(values<float>(s.payload, 0, 12)[11], 0.5f);
  EXPECT_EQ(values<std::uint32_t>(s.payload, 48, 6),
            (std::vector<std::uint32_t>{0, 2, 1, 0, 3, 2}));
}

TEST_F(SceneRoutes, MeshRefusals) {
  const auto expectError = [&](const std::string& target, int status, const std::string& says) {
    Reply r = get(port_, target);
    EXPECT_EQ(r.status, status) << target << ": " << r.body;
    EXPECT_EQ(r.headers["Content-Type"], "application/json") << target;
    EXPECT_NE(r.json().value("error", "").find(says), std::string::npos)
        << target << ": " << r.body;
  };
  expectError("/api/recordings/0/mesh", 400, "'channel' is missing");
  expectError("/api/recordings/0/mesh?channel=/lidar/points", 400, "expected a TriangleMesh");
  expectError("/api/recordings/0/mesh?channel=/nope", 404, "/nope");
  expectError("/api/recordings/0/mesh?channel=/truth/target_mesh&x=1", 400, "'x' is unknown");
  expectError("/api/recordings/7/mesh?channel=/truth/target_mesh", 404, "recording '7'");
  expectError("/api/recordings/0/errors", 400, "'estimate' is missing");
  expectError("/api/recordings/0/errors?estimate=/nope", 404, "/nope");
  expectError("/api/recordings/0/errors?estimate=/cdff/test/pose&truth=/nope", 404, "/nope");
  expectError("/api/recordings/0/errors?estimate=/cdff/test/pose&max_points=1", 400, "max_points");
  expectError("/api/requirements?x=1", 400, "'x' is unknown");
  // A graph this server does not serve (it serves none).
  expectError("/api/graphs/model?graph=x.yaml", 404, "is not a served graph");
}

// The fixture's mesh at the truth of frame 0, (0, 0, 10) m straight ahead: both triangles face
// the camera, so its 4 border edges and the crease between them (35 degrees) are drawn.
TEST_F(SceneRoutes, ContourOfTheModelAtAPoseOverTheImage) {
  Reply r = get(port_, "/api/recordings/0/contour?image=/camera/image&t=0&pose=/truth/target_pose");
  ASSERT_EQ(r.status, 200) << r.body;
  json c = r.json();
  EXPECT_EQ(c["count"], 5);
  EXPECT_EQ(c["mesh"], "/truth/target_mesh");
  EXPECT_EQ(c["frame"], "camera_optical");
  EXPECT_EQ(c["source_width"], 64);
  ASSERT_EQ(c["segments"].size(), 20u);
  const auto hasEnd = [](const json& segments, double u, double v) {
    for (std::size_t i = 0; i + 1 < segments.size(); i += 2)
      if (std::abs(segments[i].get<double>() - u) < 1e-3 &&
          std::abs(segments[i + 1].get<double>() - v) < 1e-3)
        return true;
    return false;
  };
  // (0, 0, 10) -> (32, 24); (1, 0, 10) -> (32 + 50 / 10, 24); (1, 1, 10) -> (37, 29).
  EXPECT_TRUE(hasEnd(c["segments"], 32, 24)) << c.dump();
  EXPECT_TRUE(hasEnd(c["segments"], 37, 24)) << c.dump();
  EXPECT_TRUE(hasEnd(c["segments"], 37, 29)) << c.dump();
  // The estimate, 0.1 m further along x: its origin at 32 + 50 * 0.1 / 10.
  r = get(port_, "/api/recordings/0/contour?image=/camera/image&t=0.35&pose=/cdff/test/pose");
  ASSERT_EQ(r.status, 200) << r.body;
  c = r.json();
  EXPECT_NEAR(c["t"].get<double>(), 0.3, 1e-9);
  EXPECT_TRUE(hasEnd(c["segments"], 32 + kSceneFocal * kProductOffset / 7, 24)) << c.dump();

  const auto expectError = [&](const std::string& target, int status, const std::string& says) {
    Reply e = get(port_, target);
    EXPECT_EQ(e.status, status) << target << ": " << e.body;
    EXPECT_NE(e.json().value("error", "").find(says), std::string::npos)
        << target << ": " << e.body;
  };
  const std::string route = "/api/recordings/0/contour?";
  expectError(route + "image=/camera/image&t=0", 400, "'pose' is missing");
  expectError(route + "pose=/truth/target_pose", 400, "'image' is missing");
  expectError(route + "image=/lidar/points&pose=/truth/target_pose", 400, "expected an Image");
  expectError(route + "image=/camera/image&pose=/lidar/points", 400, "expected PoseWithCovariance");
  expectError(route + "image=/camera/image&pose=/truth/target_pose&mesh=/lidar/points", 400,
              "expected a TriangleMesh");
  expectError(route + "image=/camera/image&pose=/truth/target_pose&t=-1", 400, "t = '-1'");
  expectError(route + "image=/camera/image&pose=/truth/target_pose&t=nan", 400, "t = 'nan'");
  expectError(route + "image=/nope&pose=/truth/target_pose", 404, "/nope");
}

// The target's trajectory in LVLH: servicer_T_target through lvlh_T_servicer.
TEST_F(SceneRoutes, PosesViaAnotherTransform) {
  Reply r = get(port_, "/api/recordings/0/poses?channel=/truth/target_pose&via=/truth/tf/servicer");
  ASSERT_EQ(r.status, 200) << r.body;
  const json p = r.json();
  EXPECT_EQ(p["frame"], "lvlh");
  EXPECT_EQ(p["child_frame"], "target");
  EXPECT_EQ(p["unmatched"], 0);
  ASSERT_EQ(p["t"].size(), static_cast<std::size_t>(kFrames));
  for (int k = 0; k < kFrames; ++k) {
    // (k, 0, 0) + Rx(90 deg) (0, 0, 10 - k) = (k, -(10 - k), 0).
    EXPECT_NEAR(p["x"][k].get<double>(), k, 1e-9);
    EXPECT_NEAR(p["y"][k].get<double>(), -(10.0 - k), 1e-9);
    EXPECT_NEAR(p["z"][k].get<double>(), 0, 1e-9);
  }
  r = get(port_, "/api/recordings/0/poses?channel=/truth/target_pose&via=/cdff/test/pose");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_NE(r.json().value("error", "").find("child frame is 'servicer'"), std::string::npos)
      << r.body;
  r = get(port_, "/api/recordings/0/poses?channel=/truth/target_pose&via=/camera/image");
  EXPECT_EQ(r.status, 400) << r.body;
  r = get(port_, "/api/recordings/0/poses?channel=/truth/target_pose&via=/nope");
  EXPECT_EQ(r.status, 404) << r.body;
}

TEST_F(SceneRoutes, ErrorsAreEvalsWithTheirThresholds) {
  const Reply r = get(port_, "/api/recordings/0/errors?estimate=/cdff/test/pose");
  ASSERT_EQ(r.status, 200) << r.body;
  const json e = r.json();
  EXPECT_EQ(e["truth"], "/truth/target_pose");  // paired by frames, as `cdff eval` pairs
  EXPECT_EQ(e["frame"], "servicer");
  EXPECT_EQ(e["matched_frames"], kFrames);
  ASSERT_EQ(e["t"].size(), static_cast<std::size_t>(kFrames));
  EXPECT_EQ(e["requirements"], poseThresholdsJson());
  for (int k = 0; k < kFrames; ++k) {
    EXPECT_NEAR(e["t"][k].get<double>(), 0.1 * k, 1e-9);
    EXPECT_NEAR(e["position_error_m"][k].get<double>(), kProductOffset, 1e-9);
    EXPECT_NEAR(e["angle_error_deg"][k].get<double>(), kProductTurnDeg, 1e-6);
    EXPECT_NEAR(e["range_m"][k].get<double>(), 10.0 - k, 1e-9);
    // Mid range (>= 2 m) until the last frame, at 1 m: close range.
    const bool close = k == kFrames - 1;
    EXPECT_EQ(e["position_threshold_m"][k], close ? 0.05 : 1.0) << k;
    EXPECT_EQ(e["angle_threshold_deg"][k], close ? 5.0 : 10.0) << k;
    EXPECT_EQ(e["requirement"][k], close ? "SR_DFPC_0101" : "SR_DFPC_0100") << k;
  }
  const Reply few = get(port_, "/api/recordings/0/errors?estimate=/cdff/test/pose&max_points=3");
  ASSERT_EQ(few.status, 200) << few.body;
  EXPECT_LE(few.json()["t"].size(), 3u);
  EXPECT_EQ(few.json()["stride"], 4);

  const Reply table = get(port_, "/api/requirements");
  ASSERT_EQ(table.status, 200) << table.body;
  EXPECT_EQ(table.json()["pose"], poseThresholdsJson());
}

}  // namespace
}  // namespace cdff::serve::testing
