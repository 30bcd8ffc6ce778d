#include "samples.hpp"

#include <random>

#include <nlohmann/json.hpp>

namespace cdff::testing {

namespace {

std::vector<std::uint8_t> bytesOf(std::size_t n, std::mt19937& rng) {
  std::vector<std::uint8_t> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::uint8_t>((i * 7 + rng()) & 0xFF);
  return v;
}

Image makeImage(int w, int h, PixelFormat format, std::size_t padding, Timestamp stamp,
                std::string frame, std::mt19937& rng) {
  const std::size_t stride = static_cast<std::size_t>(w) * bytesPerPixel(format) + padding;
  auto bytes = bytesOf(stride * h, rng);
  if (format == PixelFormat::kFloat32)
    for (std::size_t i = 0; i + 4 <= bytes.size(); i += 4) {
      const float v = 0.5f + static_cast<float>(i % 1000) * 0.01f;
      std::memcpy(bytes.data() + i, &v, 4);
    }
  Image im = Image::fromBytes(std::move(bytes), w, h, format, stride).value();
  im.stamp = stamp;
  im.frame_id = std::move(frame);
  return im;
}

}  // namespace

IoSamples makeIoSamples(int index, Timestamp stamp, bool small) {
  std::mt19937 rng(static_cast<std::uint32_t>(1000 + index));
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  IoSamples s;
  const int w = small ? 32 : 1624, h = small ? 24 : 1234;

  s.camera.width = w;
  s.camera.height = h;
  s.camera.fx = 1100.5 + index;
  s.camera.fy = 1101.25;
  s.camera.cx = w / 2.0 - 0.5;
  s.camera.cy = h / 2.0 + 0.25;
  s.camera.distortion_model = DistortionModel::kRadialTangential;
  s.camera.distortion = {-0.21, 0.05, 0.001, -0.0005, 0.002};

  s.image_mono = makeImage(w, h, PixelFormat::kGray8, 8, stamp, "camera_left_optical", rng);
  s.image_mono.camera = s.camera;
  s.image_bgr = makeImage(w, h, PixelFormat::kBgr8, 0, stamp, "camera_right_optical", rng);
  s.image_float = makeImage(w / 2, h / 2, PixelFormat::kFloat32, 0, stamp, "thermal", rng);

  // A real PNG signature and IHDR chunk start, so that viewers recognise the format.
  std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  for (std::uint8_t b : bytesOf(64, rng)) png.push_back(b);
  s.compressed = {stamp, "camera_left_optical", "png",
                  Buffer<std::uint8_t>::fromVector(std::move(png))};

  s.stereo.left = s.image_mono;
  s.stereo.right = makeImage(w, h, PixelFormat::kGray8, 0, stamp, "camera_right_optical", rng);
  CameraModel right_camera = s.camera;
  right_camera.distortion_model = DistortionModel::kEquidistant;
  right_camera.distortion = {0.01, -0.002, 0.0003, -0.00004};
  s.stereo.right.camera = right_camera;
  s.stereo.right_T_left.parent_frame = "camera_right_optical";
  s.stereo.right_T_left.child_frame = "camera_left_optical";
  s.stereo.right_T_left.stamp = stamp;
  s.stereo.right_T_left.translation = {-0.12, 0.0005, 0.001};
  s.stereo.right_T_left.rotation = expSO3({0.001, -0.002, 0.0005});

  s.depth_m.image = makeImage(w, h, PixelFormat::kFloat32, 0, stamp, "tof_optical", rng);
  s.depth_m.meters_per_unit = 1.0;
  s.depth_mm.image = makeImage(w, h, PixelFormat::kGray16, 4, stamp, "tof_optical", rng);
  s.depth_mm.meters_per_unit = 0.001;
  s.depth_mm.image.camera = s.camera;

  const std::size_t n = small ? 50 : 30'000;
  std::vector<Point4f> points(n), normals(n);
  std::vector<float> intensity(n);
  std::vector<std::uint16_t> ring(n);
  std::vector<std::int32_t> offsets(n);
  for (std::size_t i = 0; i < n; ++i) {
    points[i] = Point4f(static_cast<float>(u(rng) * 10), static_cast<float>(u(rng) * 10),
                        static_cast<float>(2 + u(rng)));
    Eigen::Vector3f nv =
        Eigen::Vector3f(static_cast<float>(u(rng)), static_cast<float>(u(rng)), 1).normalized();
    normals[i] = Point4f(nv.x(), nv.y(), nv.z());
    intensity[i] = static_cast<float>(i % 255) + 0.5f;
    ring[i] = static_cast<std::uint16_t>(i % 64);
    offsets[i] = static_cast<std::int32_t>(i * 3) - 40;
  }
  s.cloud.stamp = stamp;
  s.cloud.frame_id = "lidar";
  s.cloud.points = Buffer<Point4f>::fromVector(std::vector<Point4f>(points));
  s.cloud.normals = Buffer<Point4f>::fromVector(std::move(normals));
  s.cloud.intensity = Buffer<float>::fromVector(std::move(intensity));
  s.cloud.ring = Buffer<std::uint16_t>::fromVector(std::move(ring));
  s.cloud.time_offset_us = Buffer<std::int32_t>::fromVector(std::move(offsets));
  s.cloud_xyz.stamp = stamp;
  s.cloud_xyz.frame_id = "lidar";
  s.cloud_xyz.points = Buffer<Point4f>::fromVector(std::move(points));

  s.transform.stamp = stamp;
  s.transform.parent_frame = "chaser";
  s.transform.child_frame = "camera_left_optical";
  s.transform.translation = {0.3 + 0.01 * index, -0.1, 0.25};
  s.transform.rotation = expSO3({u(rng), u(rng), u(rng)});

  s.pose.pose.stamp = stamp;
  s.pose.pose.parent_frame = "chaser";
  s.pose.pose.child_frame = "target";
  s.pose.pose.translation = {u(rng) * 5, u(rng) * 5, 10 + u(rng)};
  s.pose.pose.rotation = expSO3({u(rng), u(rng), u(rng)});
  Matrix6d a = Matrix6d::Random();
  s.pose.covariance = a * a.transpose() * 1e-3;

  s.state.pose = s.pose.pose;
  s.state.pose.parent_frame = "lvlh";
  s.state.twist.linear = {0.01, -0.02, 0.003 * index};
  s.state.twist.angular = {0.001, 0.002, -0.03};
  Matrix12d b = Matrix12d::Random();
  s.state.covariance = b * b.transpose() * 1e-4;

  s.trajectory.stamp = stamp;
  s.trajectory.frame_id = "lvlh";
  for (int k = 0; k < 5; ++k) {
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.translation() = Eigen::Vector3d(k, 0.5 * k, -k);
    p.linear() = expSO3({0.1 * k, 0, 0.05}).toRotationMatrix();
    s.trajectory.poses.push_back(p);
  }

  s.mesh.stamp = stamp;
  s.mesh.frame_id = "target";
  std::vector<Eigen::Vector3f> vertices = {
      {0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 1}};
  for (auto& v : vertices) v += Eigen::Vector3f(static_cast<float>(u(rng)), 0, 0) * 0.01f;
  std::vector<Eigen::Vector3f> vn;
  for (const auto& v : vertices) vn.push_back((v - Eigen::Vector3f(0.5f, 0.5f, 0.3f)).normalized());
  s.mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  s.mesh.vertex_normals = Buffer<Eigen::Vector3f>::fromVector(std::move(vn));
  s.mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(
      {{0, 2, 1}, {0, 3, 2}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}});

  const int features = small ? 20 : 2000;
  s.features2d.stamp = stamp;
  s.features2d.frame_id = "camera_left_optical";
  for (int k = 0; k < features; ++k) {
    Keypoint2D kp;
    kp.position = {static_cast<float>(k * 3.25), static_cast<float>(k * 1.5 + 0.25)};
    kp.size = 31;
    kp.angle = static_cast<float>(k % 360);
    kp.response = 0.001f * static_cast<float>(k);
    kp.octave = k % 8;
    s.features2d.keypoints.push_back(kp);
  }
  s.features2d.descriptors.element = DescriptorMatrix::Element::kUint8;
  s.features2d.descriptors.distance = DescriptorMatrix::Distance::kHamming;
  s.features2d.descriptors.rows = features;
  s.features2d.descriptors.cols = 32;
  s.features2d.descriptors.data = Buffer<std::uint8_t>::fromVector(bytesOf(features * 32, rng));

  s.features3d.stamp = stamp;
  s.features3d.frame_id = "target";
  for (int k = 0; k < features; ++k) {
    Keypoint3D kp;
    kp.position = {static_cast<float>(u(rng)), static_cast<float>(u(rng)),
                   static_cast<float>(u(rng))};
    kp.normal = Eigen::Vector3f(0, 0, 1);
    s.features3d.keypoints.push_back(kp);
  }
  std::vector<std::uint8_t> real(features * 33 * 4);
  for (std::size_t k = 0; k < real.size() / 4; ++k) {
    const float v = static_cast<float>(k) * 0.125f;
    std::memcpy(real.data() + 4 * k, &v, 4);
  }
  s.features3d.descriptors.element = DescriptorMatrix::Element::kFloat32;
  s.features3d.descriptors.distance = DescriptorMatrix::Distance::kL2;
  s.features3d.descriptors.rows = features;
  s.features3d.descriptors.cols = 33;
  s.features3d.descriptors.data = Buffer<std::uint8_t>::fromVector(std::move(real));

  for (int k = 0; k < features; ++k) {
    s.matches.matches.push_back({k, features - 1 - k, static_cast<float>(k) * 0.5f});
    s.corr2d.first.emplace_back(k, k + 0.5);
    s.corr2d.second.emplace_back(k + 1.25, k - 0.75);
    s.corr3d.first.emplace_back(u(rng), u(rng), u(rng));
    s.corr3d.second.emplace_back(u(rng), u(rng), u(rng));
    s.corr2d3d.points.emplace_back(u(rng), u(rng), 5 + u(rng));
    s.corr2d3d.pixels.emplace_back(100 + k, 200 - k);
  }
  s.matches.matches[0].query = -1;  // negative indices survive (int32 varints)

  s.imu.stamp = stamp;
  s.imu.frame_id = "imu";
  s.imu.angular_velocity = {0.001 * index, -0.002, 0.0003};
  s.imu.linear_acceleration = {0.01, 9.80665e-6, -1e-3 * index};
  s.imu.angular_velocity_covariance = Eigen::Matrix3d::Identity() * 1e-6;
  s.imu.angular_velocity_covariance(0, 1) = 2e-8;
  s.imu.linear_acceleration_covariance = Eigen::Matrix3d::Identity() * 4e-4;
  s.imu.linear_acceleration_covariance(2, 2) = std::nan("");  // unknown: survives as NaN

  s.wrench.stamp = stamp;
  s.wrench.frame_id = "ft_sensor";
  s.wrench.force = {1.5, -0.25, 10.0 + index};
  s.wrench.torque = {0.01, 0.02, -0.03};

  s.joints.stamp = stamp;
  s.joints.names = {"shoulder", "elbow", "wrist"};
  s.joints.position = {0.1, -0.2 * index, 1.5707963267948966};
  s.joints.velocity = {0.0, 0.01, -0.02};
  s.joints.effort = {};

  s.record = {{"dfn", "pose_estimation/icp"},
              {"wall_s", 0.0123},
              {"cpu_s", 0.0119},
              {"status", "ok"},
              {"iterations", 12 + index}};
  return s;
}

Status writeIoSamples(io::Recorder& r, const IoSamples& s, Timestamp stamp) {
  CDFF_RETURN_IF_ERROR(r.write("/chaser/camera/left/image", s.image_mono));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/camera/right/image", s.image_bgr));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/thermal/image", s.image_float));
  CDFF_RETURN_IF_ERROR(r.writeCalibration("/chaser/camera/left/calibration", s.camera, stamp,
                                          "camera_left_optical"));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/camera/left/compressed", s.compressed));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/stereo/pair", s.stereo));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/tof/depth", s.depth_m));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/tof/depth_mm", s.depth_mm));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/lidar/points", s.cloud));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/lidar/points_xyz", s.cloud_xyz));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/tf/camera_left", s.transform));
  CDFF_RETURN_IF_ERROR(r.write("/cdff/pose_estimation/pose", s.pose));
  CDFF_RETURN_IF_ERROR(r.write("/truth/target_state", s.state));
  CDFF_RETURN_IF_ERROR(r.write("/cdff/pose_estimation/trajectory", s.trajectory));
  CDFF_RETURN_IF_ERROR(r.write("/cdff/reconstruction/mesh", s.mesh));
  CDFF_RETURN_IF_ERROR(r.write("/cdff/tracking/features", s.features2d));
  CDFF_RETURN_IF_ERROR(r.write("/cdff/tracking/features3d", s.features3d));
  CDFF_RETURN_IF_ERROR(r.write("/cdff/tracking/matches", s.matches, stamp));
  CDFF_RETURN_IF_ERROR(r.write("/cdff/tracking/correspondences2d", s.corr2d, stamp));
  CDFF_RETURN_IF_ERROR(r.write("/cdff/tracking/correspondences3d", s.corr3d, stamp));
  CDFF_RETURN_IF_ERROR(r.write("/cdff/tracking/correspondences2d3d", s.corr2d3d, stamp));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/imu", s.imu));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/arm/wrench", s.wrench));
  CDFF_RETURN_IF_ERROR(r.write("/chaser/arm/joints", s.joints));
  CDFF_RETURN_IF_ERROR(r.writeJson("/cdff/pose_estimation/timing", stamp, s.record));
  return r.writeEvent(stamp, "info", "orchestrator", "sample written");
}

}  // namespace cdff::testing
