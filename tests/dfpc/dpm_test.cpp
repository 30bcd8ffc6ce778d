// The Data Product Manager: queries, bounded history, pose interpolation, concurrent access
// (run under ThreadSanitizer: make test SANITIZE=thread), save and restore.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <thread>

#include "cdff/dfpc/data_product_manager.hpp"
#include "cdff/types/types.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfpc {
namespace {

namespace fs = std::filesystem;

PoseWithCovariance pose(Timestamp t, const Eigen::Vector3d& p, const Eigen::Vector3d& rv,
                        double sigma) {
  PoseWithCovariance z;
  z.pose = Transform::identity("servicer", "target", t);
  z.pose.translation = p;
  z.pose.rotation = expSO3(rv);
  z.covariance = Matrix6d::Identity() * sigma * sigma;
  return z;
}

fs::path freshDirectory(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("cdff_dpm_" + name);
  fs::remove_all(dir);
  return dir;
}

TEST(DataProducts, LatestAtOrBeforeAndBoundedHistory) {
  DataProductManager dpm(3);
  EXPECT_EQ(dpm.latest("a/x").status().code(), StatusCode::kNotFound);
  for (int k = 0; k < 5; ++k) ASSERT_OK(dpm.publish<double>("a/x", 10 * k, k));
  EXPECT_EQ(*dpm.latestAs<double>("a/x").value(), 4.0);
  EXPECT_EQ(dpm.history("a/x")->size(), 3u);  // 2, 3, 4 kept
  EXPECT_EQ(*dpm.atOrBefore("a/x", 35)->as<double>(), 3.0);
  EXPECT_EQ(*dpm.atOrBefore("a/x", 30)->as<double>(), 3.0);
  const Status too_old = dpm.atOrBefore("a/x", 15).status();
  EXPECT_NE(too_old.message().find("no sample at or before t = 15 us (oldest kept: 20 us)"),
            std::string::npos)
      << too_old.message();
  // Out of order: kept sorted.
  ASSERT_OK(dpm.publish<double>("a/x", 35, 3.5));
  std::vector<Timestamp> stamps;
  const std::vector<Product> history = dpm.history("a/x").value();
  for (const Product& p : history) stamps.push_back(p.stamp);
  EXPECT_EQ(stamps, (std::vector<Timestamp>{30, 35, 40}));
  // A product keeps its type.
  const Status wrong = dpm.publish<int>("a/x", 50, 1);
  EXPECT_NE(wrong.message().find("product 'a/x' holds Double values; got a Int"), std::string::npos)
      << wrong.message();
  EXPECT_EQ(dpm.latestAs<int>("a/x").status().code(), StatusCode::kInvalidInput);
  ASSERT_OK(dpm.setHistoryLimit("a/x", 1));
  EXPECT_EQ(dpm.history("a/x")->size(), 1u);
  EXPECT_EQ(dpm.names(), (std::vector<std::string>{"a/x"}));
}

TEST(DataProducts, PoseIsInterpolatedBetweenTheSamplesAroundT) {
  DataProductManager dpm;
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 2).normalized();
  ASSERT_OK(dpm.publish("d/pose", 1000, pose(1000, {0, 0, 10}, axis * 0.2, 0.1)));
  ASSERT_OK(dpm.publish("d/pose", 2000, pose(2000, {1, -2, 12}, axis * 0.6, 0.3)));
  Result<PoseWithCovariance> at = dpm.poseAt("d/pose", 1250);
  ASSERT_OK(at.status());
  EXPECT_EQ(at->pose.stamp, 1250);
  EXPECT_TRUE(at->pose.translation.isApprox(Eigen::Vector3d(0.25, -0.5, 10.5), 1e-12));
  // Slerp about a fixed axis: the angle is interpolated linearly.
  EXPECT_NEAR(angularDistance(at->pose.rotation, expSO3(axis * 0.3)), 0.0, 1e-12);
  EXPECT_NEAR(at->covariance(0, 0), 0.75 * 0.01 + 0.25 * 0.09, 1e-15);
  EXPECT_EQ(at->pose.parent_frame, "servicer");
  // Exact at a sample, an error outside the history.
  EXPECT_TRUE(dpm.poseAt("d/pose", 2000)->pose.translation.isApprox(Eigen::Vector3d(1, -2, 12)));
  const Status outside = dpm.poseAt("d/pose", 2001).status();
  EXPECT_NE(outside.message().find("outside the kept history [1000, 2000] us"), std::string::npos)
      << outside.message();
  ASSERT_OK(dpm.publish<double>("d/number", 0, 1.0));
  EXPECT_NE(dpm.poseAt("d/number", 0).status().message().find("expected PoseWithCovariance"),
            std::string::npos);
}

TEST(DataProducts, StateInterpolationCoversTwistAndRejectsFrameChanges) {
  DataProductManager dpm;
  RigidBodyState a, b;
  a.pose = Transform::identity("servicer", "target", 0);
  b.pose = Transform::identity("servicer", "target", 1000000);
  b.pose.translation = Eigen::Vector3d(2, 0, 0);
  a.twist.linear = Eigen::Vector3d(1, 0, 0);
  b.twist.linear = Eigen::Vector3d(3, 0, 0);
  a.covariance = Matrix12d::Identity();
  b.covariance = 3 * Matrix12d::Identity();
  ASSERT_OK(dpm.publish("d/state", 0, a));
  ASSERT_OK(dpm.publish("d/state", 1000000, b));
  Result<RigidBodyState> mid = dpm.stateAt("d/state", 500000);
  ASSERT_OK(mid.status());
  EXPECT_NEAR(mid->pose.translation.x(), 1.0, 1e-12);
  EXPECT_NEAR(mid->twist.linear.x(), 2.0, 1e-12);
  EXPECT_NEAR(mid->covariance(11, 11), 2.0, 1e-12);
  EXPECT_NEAR(dpm.poseAt("d/state", 500000)->covariance(5, 5), 2.0, 1e-12);
  RigidBodyState c = b;
  c.pose.child_frame = "other";
  ASSERT_OK(dpm.publish("d/state", 2000000, c));
  EXPECT_NE(dpm.stateAt("d/state", 1500000).status().message().find("expected the same frames"),
            std::string::npos);
}

// Writers publish poses whose content encodes their stamp; readers check that what they get is
// consistent (a stamp and its value, sorted histories, interpolation between neighbours).
TEST(DataProducts, ConcurrentReadersAndWritersSeeConsistentProducts) {
  DataProductManager dpm(50);
  constexpr int kWriters = 3, kReaders = 3, kSamples = 2000;
  std::atomic<int> writers_done{0};
  std::atomic<int> inconsistencies{0};
  std::vector<std::thread> threads;
  for (int w = 0; w < kWriters; ++w) {
    threads.emplace_back([&, w] {
      const std::string own = "w" + std::to_string(w) + "/pose";
      for (int k = 0; k < kSamples; ++k) {
        const Timestamp t = 1000 * k;
        (void)dpm.publish(own, t, pose(t, {double(k), 0, 0}, {0, 0, 0}, 0.1));
        (void)dpm.publish<double>("shared/count", t + w, static_cast<double>(t + w));
      }
      ++writers_done;
    });
  }
  for (int r = 0; r < kReaders; ++r) {
    threads.emplace_back([&] {
      while (writers_done.load() < kWriters) {
        for (int w = 0; w < kWriters; ++w) {
          const std::string own = "w" + std::to_string(w) + "/pose";
          Result<Product> latest = dpm.latest(own);
          if (!latest) continue;
          auto value = latest->as<PoseWithCovariance>();
          if (!value || value->pose.translation.x() != latest->stamp / 1000) ++inconsistencies;
          Result<PoseWithCovariance> mid = dpm.poseAt(own, latest->stamp - 500);
          if (mid && std::abs(mid->pose.translation.x() - (latest->stamp - 500) / 1000.0) > 1e-9)
            ++inconsistencies;
        }
        Result<std::vector<Product>> h = dpm.history("shared/count");
        if (h) {
          if (h->size() > 50) ++inconsistencies;
          for (std::size_t i = 1; i < h->size(); ++i)
            if ((*h)[i - 1].stamp > (*h)[i].stamp) ++inconsistencies;
          for (const Product& p : *h)
            if (*p.as<double>() != static_cast<double>(p.stamp)) ++inconsistencies;
        }
        Result<Product> before = dpm.atOrBefore("shared/count", 500000);
        if (before && before->stamp > 500000) ++inconsistencies;
        (void)dpm.names();
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(inconsistencies.load(), 0);
  for (int w = 0; w < kWriters; ++w)
    EXPECT_EQ(dpm.latest("w" + std::to_string(w) + "/pose")->stamp, 1000 * (kSamples - 1));
  EXPECT_EQ(dpm.history("shared/count")->size(), 50u);
}

TEST(DataProducts, SaveAndRestoreEveryStoredKind) {
  DataProductManager dpm;
  const Eigen::Vector3d rv(0.1, -0.2, 0.3);
  ASSERT_OK(dpm.setHistoryLimit("track/pose", 7));
  ASSERT_OK(dpm.publish("track/pose", 5, pose(5, {1, 2, 3}, rv, 0.01)));
  ASSERT_OK(dpm.publish("track/pose", 9, pose(9, {1, 2, 4}, rv, 0.02)));
  RigidBodyState s;
  s.pose = Transform::identity("servicer", "target", 9);
  s.twist.angular = Eigen::Vector3d(0.01, 0.02, 0.03);
  for (int i = 0; i < 12; ++i) s.covariance(i, i) = 0.1 * (i + 1);
  s.covariance(0, 6) = s.covariance(6, 0) = 0.05;
  ASSERT_OK(dpm.publish("track/state", 9, s));
  ASSERT_OK(dpm.publish<double>("track/nis", 9, std::nan("")));
  ASSERT_OK(dpm.publish<std::string>("track/status", 9, "TRACKING"));
  ASSERT_OK(dpm.publish<bool>("track/accepted", 9, true));
  ASSERT_OK(dpm.publish<int>("track/count", 9, -4));
  ASSERT_OK(dpm.publish<Timestamp>("track/time", 9, 1234567890123));
  std::vector<Eigen::Vector3f> xyz{{1, 2, 3}, {-1, 0.5f, 2}, {0, 0, 7}};
  PointCloud cloud = PointCloud::fromXyz(xyz, "lidar", 8);
  cloud.intensity = Buffer<float>::fromVector({0.1f, 0.2f, 0.3f});
  cloud.normals = Buffer<Point4f>::fromVector({{0, 0, 1}, {0, 1, 0}, {1, 0, 0}});
  ASSERT_OK(dpm.publish("map/cloud", 8, cloud));
  TriangleMesh mesh;
  mesh.frame_id = "target";
  mesh.stamp = 3;
  mesh.vertices = Buffer<Eigen::Vector3f>::fromVector({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
  mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(
      {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}});
  ASSERT_OK(dpm.publish("model/mesh", 3, mesh));

  const fs::path dir = freshDirectory("roundtrip");
  ASSERT_OK(dpm.save(dir.string()));
  DataProductManager back;
  ASSERT_OK(back.publish<double>("stale/product", 0, 1.0));  // replaced by the restore
  ASSERT_OK(back.restore(dir.string()));
  EXPECT_EQ(back.names(), dpm.names());
  EXPECT_EQ(back.history("track/pose")->size(), 2u);
  auto p = back.latestAs<PoseWithCovariance>("track/pose").value();
  EXPECT_EQ(p->pose.stamp, 9);
  EXPECT_EQ(p->pose.translation, Eigen::Vector3d(1, 2, 4));
  EXPECT_NEAR(angularDistance(p->pose.rotation, expSO3(rv)), 0.0, 1e-15);
  EXPECT_EQ(p->covariance, Matrix6d::Identity() * 0.02 * 0.02);
  auto st = back.latestAs<RigidBodyState>("track/state").value();
  EXPECT_EQ(st->covariance, s.covariance);
  EXPECT_EQ(st->twist.angular, s.twist.angular);
  EXPECT_TRUE(std::isnan(*back.latestAs<double>("track/nis").value()));
  EXPECT_EQ(*back.latestAs<std::string>("track/status").value(), "TRACKING");
  EXPECT_TRUE(*back.latestAs<bool>("track/accepted").value());
  EXPECT_EQ(*back.latestAs<int>("track/count").value(), -4);
  EXPECT_EQ(*back.latestAs<Timestamp>("track/time").value(), 1234567890123);
  auto c = back.latestAs<PointCloud>("map/cloud").value();
  EXPECT_EQ(c->frame_id, "lidar");
  EXPECT_EQ(c->stamp, 8);
  ASSERT_EQ(c->size(), 3u);
  EXPECT_EQ(c->points[1].vec(), Eigen::Vector3f(-1, 0.5f, 2));
  EXPECT_EQ(c->normals[2].vec(), Eigen::Vector3f(1, 0, 0));
  EXPECT_EQ(c->intensity[2], 0.3f);
  EXPECT_OK(c->validate());
  auto m = back.latestAs<TriangleMesh>("model/mesh").value();
  EXPECT_EQ(m->triangleCount(), 4u);
  EXPECT_EQ(m->triangles[3], (std::array<std::uint32_t, 3>{1, 2, 3}));
  EXPECT_EQ(m->vertices[3], Eigen::Vector3f(0, 0, 1));
  EXPECT_OK(m->validate());
  // The history limit survives: 7 for the pose.
  for (int k = 0; k < 10; ++k) ASSERT_OK(back.publish("track/pose", 100 + k, *p));
  EXPECT_EQ(back.history("track/pose")->size(), 7u);
}

TEST(DataProducts, SaveReportsWhatItCannotWriteAndRestoreRejectsCorruptFiles) {
  DataProductManager dpm;
  ASSERT_OK(dpm.publish<double>("ok/value", 1, 2.0));
  // An image whose buffer is smaller than its rows cannot be written as a message.
  Image broken = testing::toImage(cv::Mat(4, 4, CV_8UC1, cv::Scalar(3)), 1);
  broken.height = 8;
  ASSERT_OK(dpm.publish("camera/image", 1, broken));
  const fs::path dir = freshDirectory("partial");
  const Status s = dpm.save(dir.string());
  EXPECT_EQ(s.code(), StatusCode::kIoError);
  EXPECT_NE(s.message().find("product 'camera/image' sample 0"), std::string::npos) << s.message();
  DataProductManager back;
  ASSERT_OK(back.restore(dir.string()));  // what could be saved is there
  EXPECT_EQ(back.names(), (std::vector<std::string>{"ok/value"}));

  // A corrupt index leaves the manager unchanged.
  std::ofstream(dir / "products.json") << "{\"format\": \"cdff-data-products\", \"version\": 1, ";
  EXPECT_EQ(back.restore(dir.string()).code(), StatusCode::kCorruptData);
  EXPECT_EQ(back.names(), (std::vector<std::string>{"ok/value"}));

  // A truncated PLY names its file.
  DataProductManager clouds;
  ASSERT_OK(
      clouds.publish("map/cloud", 1, PointCloud::fromXyz({{1, 2, 3}, {4, 5, 6}}, "lidar", 1)));
  const fs::path cloud_dir = freshDirectory("truncated");
  ASSERT_OK(clouds.save(cloud_dir.string()));
  fs::path ply;
  for (const auto& entry : fs::recursive_directory_iterator(cloud_dir))
    if (entry.path().extension() == ".ply") ply = entry.path();
  ASSERT_FALSE(ply.empty());
  fs::resize_file(ply, fs::file_size(ply) - 5);
  const Status truncated = back.restore(cloud_dir.string());
  EXPECT_EQ(truncated.code(), StatusCode::kCorruptData);
  EXPECT_NE(truncated.message().find(ply.filename().string() + ": product 'map/cloud'"),
            std::string::npos)
      << truncated.message();
  EXPECT_NE(truncated.message().find("truncated PLY body"), std::string::npos)
      << truncated.message();
  EXPECT_EQ(back.restore((dir / "nowhere").string()).code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace cdff::dfpc
